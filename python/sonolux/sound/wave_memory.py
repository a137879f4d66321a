"""What the waves of a hybrid bake (``--waves``) will take in memory, checked at the edge: before
any ray is traced, so that a bake whose waves cannot fit is refused at once, not after minutes of
rays (issue 18).

The waves' memory has phases that do not overlap, and one that does (the join):

- **grid**: the wave run itself (cells, boundary, the receiver points' responses), the core's own
  estimate (``WaveSettings.memory_estimate``, ``crates/sonolux-core/src/wave/settings.rs``), with
  each wall's branches as its fit will have them, the faces of walls fitted rigid at the rigid
  node's bytes (session 12), and a described surface's wells' branches at every face of its
  material (tests/wave_memory.rs checks it against the solver's allocation);
- **binning**: the responses kept, plus the energy per receiver point, direction, *wave* band
  and time bin, 8 bytes while it is summed and 4 for the array handed back
  (``bands::reflected_energies`` bins only the bands below the crossover);
- **spheres**: that float32 array, and each sphere's mean of its points in float64 with the sum
  over the sources beside it (:func:`sonolux.sound.waves.ball_means`, in chunks of receivers);
- **join**: the tracer's field copied with its wave bands replaced
  (:func:`sonolux.sound.waves.keep_wave_bands`): receivers × directions × every band × time
  bins × 4 bytes, on top of the field the tracer holds.

The peak is the largest of the first three plus the join. It is compared with the bake's
``max_field_bytes``, else its memory budget (``memory_bytes``, ``--memory``), else
:func:`sonolux.memory.budget_bytes` (80% of what this machine has free: the limit the binning
itself is held to). :func:`sonolux.sound.bake.check_waves` makes the estimate, with the
clearance of directional sources, at every edge that traces rays (docs/waves.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.errors import MemoryLimitError
from sonolux.memory import budget_bytes, gb

#: Bytes of one cell of the waves' energy while the core bins it (f64 sum + f32 array returned).
BINNING_BYTES_PER_CELL = 8 + 4


@dataclass(frozen=True)
class WaveMemory:
    """The waves' memory estimate, in bytes, and what drives it."""

    grid_bytes: int
    binning_bytes: int
    spheres_bytes: int
    join_bytes: int
    points: int
    directions: int
    wave_bands: int
    bands: int
    time_bins: int
    crossover_hz: float

    @property
    def total_bytes(self) -> int:
        return max(self.grid_bytes, self.binning_bytes, self.spheres_bytes) + self.join_bytes

    def describe(self) -> str:
        return (f"grid {gb(self.grid_bytes)}, binning {gb(self.binning_bytes)} ({self.points} "
                f"receiver points × {self.directions} directions × {self.wave_bands} wave "
                f"band(s) of {self.bands} × {self.time_bins} time bins), spheres "
                f"{gb(self.spheres_bytes)}, join {gb(self.join_bytes)}")


def field_axis(early_s: float, stored_late_bin_s: float, split: int, sample_rate_hz: float,
               max_time_s: float) -> tuple[int, float]:
    """(time bins, end in s) of a bake's field as the waves will see it, before any ray: the core's
    layout (``SoundSettings::layout``: ``early_s`` rounded to samples, then late bins of
    ``stored_late_bin_s`` to ``max_time_s``) shown at ``split`` view bins per stored late bin
    (:func:`sonolux.sound.tiles.trace_tiles`), and the end that
    :func:`sonolux.sound.bake.wave_part` takes for the waves' duration: the later of
    ``max_time_s`` and the last bin's end, computed with the same floating-point operations as
    the core and the tiles, so that the crossover chosen here is the one the waves will choose."""
    early_bins = round(early_s * sample_rate_hz)
    early = early_bins / sample_rate_hz
    late_bins = math.ceil(max(max_time_s - early, 0.0) / stored_late_bin_s)
    if late_bins == 0:  # early bins only: the last ends at its start + one sample
        return early_bins, max(max_time_s, (early_bins - 1) / sample_rate_hz + 1.0 / sample_rate_hz
                               if early_bins else 0.0)
    if split > 1:
        fine = stored_late_bin_s / split
        n_late = late_bins * split
        last_start = early + fine * float(n_late - 1)
        return early_bins + n_late, max(max_time_s, last_start + fine)
    last_start = early + float(late_bins - 1) * stored_late_bin_s
    return early_bins + late_bins, max(max_time_s, last_start + stored_late_bin_s)


def estimate(scene: Any, cross: Any, *, duration_s: float, time_bins: int, directions: int,
             max_field_bytes: int | None, absorption: np.ndarray | None = None) -> WaveMemory:
    """The estimate for a hybrid bake of ``scene`` at the crossover ``cross`` (the one
    :func:`sonolux.sound.waves.choose_crossover` chose for it, without the timing run), whose
    field has ``time_bins`` bins over ``duration_s`` (:func:`field_axis`) and ``directions``
    direction bins. ``absorption`` float64[material, band], the bake's: the walls' branches are
    counted from their fits (else one per fitted band is assumed)."""
    from sonolux.sound import wave_sources
    from sonolux.sound import waves as wave_sound
    from sonolux.sound.surfaces import wells_of

    bands = np.asarray(scene.settings.bands_hz, float)
    c = scene.settings.speed_of_sound_m_s
    delay_s = 6.0 / (math.pi * cross.max_frequency_hz)
    if any(s.directivity != "omni" for s in scene.sources):
        delay_s = max(delay_s, wave_sources.longest_pulse_delay_s(bands, cross.max_frequency_hz))
    settings = wave_sound.wave_settings(cross.max_frequency_hz, duration_s + delay_s, c,
                                        scene.settings.threads,
                                        wave_sound.memory_limit(max_field_bytes))
    centres = scene.receivers.count
    points = centres * wave_sound.BALL_POINTS
    # The walls fitted as the run will fit them, and a described surface's wells: their
    # branches' state at every boundary face (wave/settings.rs, tests/wave_memory.rs).
    grid = engine.wave_memory_estimate(settings, scene.geometry, points, bands,
                                       absorption=absorption, wells=wells_of(scene))
    k = cross.wave_bands
    cells = directions * k * time_bins
    return WaveMemory(
        grid_bytes=int(grid["total_bytes"]),
        binning_bytes=int(grid["receiver_bytes"]) + points * cells * BINNING_BYTES_PER_CELL,
        spheres_bytes=points * cells * 4 + centres * cells * 8 * 2,
        join_bytes=centres * directions * bands.size * time_bins * 4,
        points=points, directions=directions, wave_bands=k, bands=int(bands.size),
        time_bins=time_bins, crossover_hz=cross.crossover_hz)


def limit_bytes(max_field_bytes: int | None, memory_bytes: int | None) -> tuple[int, str]:
    """The waves' limit and the setting it comes from: ``max_field_bytes`` (Python only), else
    the bake's memory budget (``--memory``), else 80% of what this machine has free (the limit
    the core's binning holds them to)."""
    if max_field_bytes:
        return int(max_field_bytes), f"SoundOptions.max_field_bytes = {int(max_field_bytes):,}"
    if memory_bytes:
        return int(memory_bytes), (f"--memory, SoundOptions.memory_bytes = "
                                   f"{int(memory_bytes):,}")
    return budget_bytes(), "80% of the memory this machine has free"


def check(memory: WaveMemory, max_field_bytes: int | None, memory_bytes: int | None = None,
          ) -> None:
    """Refuses (:class:`MemoryLimitError`) waves that would not fit, naming the parts, the
    estimate, the limit and the setting it comes from, and what to change."""
    limit, given = limit_bytes(max_field_bytes, memory_bytes)
    if memory.total_bytes <= limit:
        return
    raise MemoryLimitError(
        f"the waves of this hybrid bake (--waves) would need about {gb(memory.total_bytes)} "
        f"({memory.describe()}), more than the limit of {gb(limit)} ({given}); refused before "
        f"any ray is traced: use fewer receivers (a wider grid spacing), a lower crossover "
        f"(--crossover-hz, now {memory.crossover_hz:.0f} Hz), fewer directions, a shorter "
        f"max_time_s, or a limit of at least {gb(memory.total_bytes)} (--memory, or "
        "SoundOptions.max_field_bytes) on a machine that has it")
