"""The sound bake's memory, set by a budget: how many receivers are traced at once (a tile), and
what the whole bake will hold, said before it starts.

The tracer's accumulator holds every (receiver, time bin, direction, band) cell of the receivers
it traces as a u64, and hands back their float32 energies (and u64 counts): 20 bytes a cell
(``FIELD_BYTES_PER_CELL`` of the core; a little more with the accumulator's band padding). A
receiver of paper-large (8 directions, 7 octaves, 3,840 one-sample early bins and 3 s of late
bins) is tens of thousands of cells, so a floor of receivers would need tens of gigabytes at once.
So the bake traces its receivers in **tiles**: each tile retraces the same rays (same seed: each
ray's path depends on (seed, source, ray) only, and each deposit's rounding on (seed, source, ray,
receiver, event): ``keyed_uniform`` in the core), keeps its tile's field in the compact form
(:mod:`sonolux.sound.compact`) and frees the accumulator. Every receiver gets the bits it would
get in one bake of all receivers; a tile costs one more pass over the rays.

What the bake keeps is estimated from the settings: the dense late part exactly, the early
part's non-zero cells from the sphere crossings and rain deposits expected in it (rays fill the
room: N c t π r² / V crossings per receiver by time t), never more than its dense size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sonolux.errors import MemoryLimitError
from sonolux.memory import gb

#: Bytes of one cell while tracing (the core's FIELD_BYTES_PER_CELL: the u64 accumulator, the
#: f32 energy and the u64 counts it hands back), before the accumulator's band padding
#: (:func:`trace_bytes_per_cell`).
TRACE_BYTES_PER_CELL = 20


def band_stride(bands: int) -> int:
    """Counts the core's accumulator keeps for a (receiver, time, direction) cell of ``bands``
    bands (its ``band_stride``): the next power of two up to 8 where that adds at most one count
    in seven (7 bands → 8: one aligned cache line), else the bands packed."""
    padded = 1 << (bands - 1).bit_length()
    return padded if bands <= 8 and 7 * (padded - bands) <= bands else bands


def trace_bytes_per_cell(bands: int) -> float:
    """Bytes of one cell while tracing a field of ``bands`` bands (the core's
    ``field_bytes_per_cell``): :data:`TRACE_BYTES_PER_CELL` with the accumulator's u64 padded
    to :func:`band_stride` counts a cell (7 bands: 8 · 8/7 + 12 ≈ 21.1 bytes; others 20)."""
    return TRACE_BYTES_PER_CELL - 8 + 8 * band_stride(bands) / bands
#: What the rest of a bake holds besides its field (the scene, the BVH, the interpreter), and
#: a margin for the estimate of the early cells.
BASE_BYTES = 300_000_000
EARLY_MARGIN = 2.0


@dataclass(frozen=True)
class FieldShape:
    """The bake's field: receivers × directions × bands × (early one-sample + late bins)."""

    receivers: int
    directions: int
    bands: int
    early_bins: int
    late_bins: int

    @property
    def cells_per_receiver(self) -> int:
        return self.directions * self.bands * (self.early_bins + self.late_bins)


@dataclass(frozen=True)
class MemoryPlan:
    """What a bake will hold: ``kept_bytes`` for its result, ``tile_receivers`` receivers
    traced at once (``tile_bytes`` while tracing), in ``tiles`` passes over the rays."""

    shape: FieldShape
    budget_bytes: int
    kept_bytes: int
    tile_receivers: int
    tile_bytes: int
    compact: bool
    fields: int = 1
    group_bands: int | None = None

    @property
    def tiles(self) -> int:
        return math.ceil(self.shape.receivers / self.tile_receivers)

    @property
    def total_bytes(self) -> int:
        return BASE_BYTES + self.kept_bytes + self.tile_bytes

    def describe(self) -> str:
        s = self.shape
        passes = "one pass over the rays" if self.tiles == 1 else \
            f"{self.tiles} tiles of {self.tile_receivers:,} receivers (one pass over the rays each)"
        joined = ("" if self.group_bands is None else
                  f" (level of detail: a tile's field joined over every band + one group of "
                  f"{self.group_bands} band(s) traced at a time)")
        return (f"memory: about {gb(self.total_bytes)} of a {gb(self.budget_bytes)} budget: "
                f"{gb(self.kept_bytes)} for the {'compact' if self.compact else 'full'} field"
                f"{f's of {self.fields} sources' if self.fields > 1 else ''} of "
                f"{s.receivers:,} receivers, {gb(self.tile_bytes)} while tracing{joined}; "
                f"{passes}")


def early_cells_estimate(shape: FieldShape, *, rays: int, sources: int, estimator: str,
                         sample_rate_hz: float, speed_of_sound_m_s: float, volume_m3: float,
                         area_m2: float, radius_m: float) -> int:
    """Non-zero early cells of one receiver to expect (× EARLY_MARGIN), at most all of them:
    every sphere crossing (paper) or rain deposit touches one (time, direction) cell's bands."""
    early_s = shape.early_bins / sample_rate_hz
    path_m = speed_of_sound_m_s * early_s
    crossings = rays * sources * path_m * math.pi * radius_m**2 / volume_m3
    if estimator == "rain":
        crossings += rays * sources * path_m * area_m2 / (4.0 * volume_m3)
    dense = shape.directions * shape.bands * shape.early_bins
    return int(min(dense, EARLY_MARGIN * (crossings + 1) * shape.bands))


def flag_size(n: float) -> str:
    """A size as --memory takes it, rounded up: 950M, 12G."""
    return f"{math.ceil(n / 1e6)}M" if n < 1e10 else f"{math.ceil(n / 1e9)}G"


def plan(shape: FieldShape, budget_bytes: int, *, compact: bool, keep_counts: bool,
         early_cells: int, reduced: tuple[int, int] | None = None,
         fields: int = 1, group_bands: int | None = None) -> MemoryPlan:
    """The tile size that fits ``budget_bytes``, or :class:`MemoryLimitError` saying what would
    fit. Kept per receiver: float32 energies (and u64 counts for a ray range) of the late part
    and of the early part: dense when full; when compact its non-zero cells (each with a u32
    index), or, ``reduced`` = (arrivals, samples per envelope bin) for a whole bake, its
    envelope and the cells of its strongest arrivals (twice as many, for the onset's).
    ``fields``: fields kept per receiver (one per source of a bake of several sources, each
    traced alone: the tracer holds one at a time). ``group_bands``: with level of detail
    (:func:`sonolux.sound.levels.trace`), the bands of the largest group traced at once: a tile
    then holds its joined field over every band (float32, and u64 counts for a ray range) and
    the tracer's cells of one group, not the tracer's cells of every band."""
    value = 4 + (8 if keep_counts else 0)
    late = shape.directions * shape.bands * shape.late_bins
    early_dense = shape.directions * shape.bands * shape.early_bins
    early = early_cells * (value + 4) + 8 if compact else early_dense * value
    if compact and reduced is not None:
        arrivals, split = reduced
        envelope = shape.directions * shape.bands * -(-shape.early_bins // split) * 4
        early = min(early, envelope + 2 * arrivals * shape.bands * (value + 4) + 16)
    kept = fields * shape.receivers * (late * value + early)
    per_receiver = math.ceil(shape.cells_per_receiver * trace_bytes_per_cell(shape.bands))
    if group_bands is not None:  # the join over every band + one group's tracer cells
        per_receiver = shape.cells_per_receiver * value + math.ceil(
            shape.cells_per_receiver * group_bands // shape.bands * trace_bytes_per_cell(group_bands))
    room = budget_bytes - BASE_BYTES - kept
    tile = min(shape.receivers, room // per_receiver) if room > 0 else 0
    if tile < 1:
        need = BASE_BYTES + kept + per_receiver
        raise MemoryLimitError(
            f"the sound bake needs at least {gb(need)} ({gb(kept)} for the "
            f"{'compact' if compact else 'full'} field of {shape.receivers:,} receivers, "
            f"{gb(per_receiver)} to trace one receiver at a time, {gb(BASE_BYTES)} for the "
            f"rest), more than the budget of {gb(budget_bytes)}: give --memory {flag_size(need * 1.05)} "
            "or more, or fewer receivers, a shorter max_time_s or wider late bins")
    tile = int(tile)
    return MemoryPlan(shape, budget_bytes, kept, tile, tile * per_receiver, compact, fields,
                      group_bands)
