"""The sound bake in ray ranges: checkpointed, resumable, spread over a Dask cluster.

:class:`SoundRanges` is the sound bake's :class:`sonolux.ranges.RangeWork`: it traces a range
with :func:`sonolux.sound.bake.bake` (``ray_range``, which keeps the tracer's exact fixed-point
counts), sums ranges as integers (:class:`SoundSum`) and turns the complete sum into the
:class:`SoundField` of the bake: energy = counts × quantum, computed exactly as the core does, so
the field has the bits of one bake done at once.

:func:`bake` is ``sonolux.bake``: the plain bake, or with ``client=`` (a ``dask.distributed``
Client) and/or ``checkpoint=`` (a side file) the bake in ranges.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sonolux import range_bake, ranges
from sonolux.checkpoint import fingerprint
from sonolux.errors import SonoluxError
from sonolux.scene.schema import Scene
from sonolux.sound import walls
from sonolux.sound.bake import add_waves, check_waves, ray_count, with_wave_range
from sonolux.sound.bake import bake as bake_whole
from sonolux.sound.compact import CompactArray, add_counts, energy_of, reduced
from sonolux.sound.early import add_arrivals
from sonolux.sound.field import SoundField, with_source_energy
from sonolux.sound.options import SoundOptions
from sonolux.sound.stats import combine_stats
from sonolux.sound.waves import is_wave_part, with_scene, with_wave_part
from sonolux.version import __version__

#: The SoundField arrays a sum carries besides the counts (small: bins, bands, points).
SMALL_ARRAYS = ("bin_start_s", "bin_width_s", "bands_hz", "positions_m", "source_positions_m",
                "source_powers_w")
@dataclass
class SoundSum:
    """The exact sum of some ray ranges of one sound bake: ``counts``
    uint64[receiver, direction, band, time] (energy = counts × quantum), the summed statistics,
    and ``template``, the rest of the field (its energy left out)."""

    counts: Any  # uint64 ndarray, or a CompactArray of them
    stats: dict[str, Any]
    template: SoundField

    @classmethod
    def of(cls, field: SoundField) -> SoundSum:
        if field.counts is None:
            raise SonoluxError("a sound field without counts cannot be summed (bake a ray range)")
        template = replace(field, energy=np.zeros((0,), np.float32), counts=None, path=None,
                           per_source=None)
        counts = field.counts if isinstance(field.counts, CompactArray) else \
            np.ascontiguousarray(field.counts, np.uint64)
        return cls(counts, dict(field.stats), template)

    def add(self, other: SoundSum) -> SoundSum:
        t, o = self.template, other.template
        if t.quantum != o.quantum or self.counts.shape != other.counts.shape:
            raise SonoluxError("these ranges come from different bakes and cannot be summed")
        if o.early is not None:  # a hybrid's arrivals: only the range from ray 0 holds them
            if t.early is not None:
                raise SonoluxError("both ranges hold the bake's early arrivals (each starts at "
                                   "ray 0): summing them would count those rays twice")
            self.template = t = replace(t, early=o.early)
        if is_wave_part(o.waves):  # a hybrid's waves: only the range from ray 0 holds them
            if is_wave_part(t.waves):
                raise SonoluxError("both ranges hold the bake's waves (each starts at ray 0): "
                                   "summing them would count those rays twice")
            self.template = t = replace(t, waves=o.waves)
        if o.settings.get("with_waves"):
            self.template = replace(t, settings=dict(t.settings, with_waves=True))
        self.counts = add_counts(self.counts, other.counts)
        self.stats = combine_stats(self.stats, other.stats)
        return self


class SoundRanges:
    """The sound bake of ``scene`` with ``options`` as a :class:`sonolux.ranges.RangeWork`.

    The automatic ray count is resolved here, once; ``options.ray_range`` (if any) is the part
    of the bake this run traces. Pickled (for Dask), it carries the scene's content without its
    BVH, which a worker rebuilds once from the triangles."""

    kind = "sound"
    unit = "rays"

    def __init__(self, scene: Scene, options: SoundOptions | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        # The scene's [waves] table resolved here too, so that the check and finish agree.
        options = with_scene(scene, (options or SoundOptions()).validate())
        rays = ray_count(scene, options, log=log)
        self.total = rays
        self.target = tuple(options.ray_range or (0, rays))
        if self.target[1] > rays:
            raise SonoluxError(f"ray_range {options.ray_range} goes past the bake's {rays} rays")
        # Before any range is traced: the hybrid's clearance, and the memory of its waves when
        # this work holds ray 0 (finish computes them then).
        check_waves(scene, options, from_ray_zero=self.target[0] == 0, log=log)
        # The memory limits do not change the bits: they are left out of the fingerprint.
        self.options = replace(options, rays=rays, ray_range=None, max_field_bytes=None,
                               memory_bytes=None)
        self.max_field_bytes = options.max_field_bytes
        self.memory_bytes = options.memory_bytes
        self.scene, self.name = scene, scene.name
        self.stamp = {"scene": fingerprint(ranges.scene_content(scene)),
                      "settings": fingerprint(self.options), "version": __version__}
        self.fingerprint = fingerprint("sound", self.stamp)
        self._log = log  # for the waves of a hybrid, added in this process (finish)

    def __getstate__(self) -> dict[str, Any]:
        return dict(self.__dict__, scene=replace(self.scene, geometry=None), _log=None)

    def loaded_scene(self, threads: int | None = None) -> Scene:
        return ranges.loaded_scene(self.scene, self.stamp["scene"], threads)

    def trace(self, first: int, end: int, threads: int | None = None,
              progress: ranges.Progress | None = None, tail: Any = None) -> SoundSum:
        # The rays alone; the waves are added once, to the whole field (finish). The rays keep
        # the wall model the hybrid chose (the waves' wall: sound/walls.py). ``tail``: the late
        # contributions a progressive round watches (sound/tail.py), in the stats as "tail".
        scene = self.loaded_scene(threads)
        options = replace(self.options, ray_range=(first, end),
                          max_field_bytes=self.max_field_bytes,
                          memory_bytes=getattr(self, "memory_bytes", None), waves=False,
                          crossover_hz=None,
                          wall_model=walls.resolve(scene, self.options)[0])
        return SoundSum.of(bake_whole(scene, options, progress=progress, tail=tail))

    def add(self, total: SoundSum | None, part: SoundSum) -> SoundSum:
        return part if total is None else total.add(part)

    def encode(self, total: SoundSum) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return encode_sum(total)

    def decode(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> SoundSum:
        return decode_sum(meta, arrays)

    def finish(self, total: SoundSum, done: list[ranges.Range]) -> SoundField:
        field = field_of_sum(total, done, self.total, self.fingerprint)
        if self.options.waves:
            options = replace(self.options, max_field_bytes=self.max_field_bytes)
            if field.counts is None:
                field = add_waves(self.loaded_scene(), options, field,
                                  progress=self._log is not None, log=self._log)
            else:  # a part of a hybrid: the waves go with the part from ray 0 (docs/waves-hybrid.md)
                field = with_wave_range(self.loaded_scene(), options, field, self.target[0],
                                        progress=self._log is not None, log=self._log)
        return field


def encode_sum(total: SoundSum) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A sum as JSON-able metadata and exact arrays (for the checkpoint)."""
    t = total.template
    meta = {"settings": t.settings, "stats": total.stats, "theory": t.theory,
            "scene_name": t.scene_name, "scene_origin": t.scene_origin,
            "radius_m": t.radius_m, "grid_spacing_m": t.grid_spacing_m, "quantum": t.quantum}
    arrays = {**counts_arrays(total.counts), **{k: getattr(t, k) for k in SMALL_ARRAYS}}
    if t.grid_index is not None:
        arrays["grid_index"] = np.asarray(t.grid_index)
    for k, v in (t.early or {}).items():
        arrays[f"early_{k}"] = np.asarray(v)
    if is_wave_part(t.waves):
        meta["waves"] = {k: v for k, v in t.waves.items() if k not in ("energy", "pressure")}
        arrays["waves_energy"], arrays["waves_pressure"] = t.waves["energy"], t.waves["pressure"]
    return _jsonable(meta), arrays


def decode_sum(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> SoundSum:
    """The sum that :func:`encode_sum` wrote."""
    template = SoundField(
        energy=np.zeros((0,), np.float32), **{k: arrays[k] for k in SMALL_ARRAYS},
        radius_m=meta["radius_m"], grid_index=arrays.get("grid_index"),
        grid_spacing_m=meta["grid_spacing_m"], settings=meta["settings"], stats={},
        scene_name=meta["scene_name"], scene_origin=meta["scene_origin"],
        quantum=meta["quantum"], theory=meta["theory"],
        early={k[len("early_"):]: np.asarray(v) for k, v in arrays.items()
               if k.startswith("early_")} or None,
        waves=dict(meta["waves"], energy=np.asarray(arrays["waves_energy"]),
                   pressure=np.asarray(arrays["waves_pressure"])) if "waves" in meta else None)
    return SoundSum(counts_of_arrays(arrays), meta["stats"], template)


def counts_arrays(counts: Any) -> dict[str, np.ndarray]:
    """Plain arrays of a sum's counts, dense or compact, for the checkpoint."""
    if isinstance(counts, CompactArray):
        return {"counts_offset": counts.offset, "counts_cell": counts.cell,
                "counts_value": counts.value, "counts_late": counts.late,
                "counts_early_bins": np.array([counts.early_bins, counts.late_split], np.int64)}
    return {"counts": counts}


def counts_of_arrays(arrays: dict[str, np.ndarray]) -> Any:
    """The counts that :func:`counts_arrays` wrote."""
    if "counts" in arrays:
        return np.array(arrays["counts"], np.uint64)
    early_bins, late_split = (int(v) for v in arrays["counts_early_bins"])
    return CompactArray(early_bins, np.array(arrays["counts_offset"]),
                        np.array(arrays["counts_cell"]), np.array(arrays["counts_value"]),
                        np.array(arrays["counts_late"]), late_split)


def field_of_sum(total: SoundSum, done: list[ranges.Range], rays: int,
                 fingerprint: str | None) -> SoundField:
    """The field of the summed ranges ``done`` of a bake of ``rays`` rays. A whole bake looks as
    if done at once (no counts); a part keeps its counts and says which ranges it holds."""
    t = total.template
    parts = ranges.join(done)
    settings = dict(t.settings, ray_range=[parts[0][0], parts[-1][1]])
    if fingerprint:
        settings["fingerprint"] = fingerprint
    settings.pop("ray_ranges", None)
    whole = parts == [(0, rays)]
    if len(parts) > 1:
        settings["ray_ranges"] = [list(r) for r in parts]
    stats = dict(total.stats)
    seconds = stats.get("seconds") or 0.0
    for k, n in (("rays_per_second", "rays"), ("segments_per_second", "segments")):
        stats[k] = stats.get(n, 0) / seconds if seconds > 0 else None
    energy = energy_of(total.counts, t.quantum)
    if whole:
        energy = reduced(energy, t.settings)
        if t.early is not None:  # the exact early arrivals of a hybrid, as a whole bake has
            energy = add_arrivals(energy, t.early)
    field = with_source_energy(replace(t, counts=None if whole else total.counts,
                                       settings=settings, stats=stats), energy)
    if whole and settings.get("with_waves"):
        # A hybrid's waves, from the part that holds ray 0, joined as the bake at once joins them.
        if not is_wave_part(t.waves):
            raise SonoluxError("these parts make a whole hybrid bake, but none holds its waves "
                               "(the part from ray 0 computes them): merge that part's field file")
        field = with_wave_part(field, t.waves)
    return field


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def bake(scene: Scene, options: SoundOptions | None = None, *, client: Any = None,
         checkpoint: str | Path | None = None, resume: bool = False, restart: bool = False,
         checkpoint_every_s: float = 60.0, range_rays: int | None = None,
         tasks: int | None = None, progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, **overrides: Any) -> SoundField:
    """Traces the scene's sound sources into a sound field over its receivers.

    ``options`` (or keyword overrides such as ``rays=100_000``) set the bake, as for
    :func:`sonolux.sound.bake.bake`; ``progress=True`` prints a progress line, or pass
    ``f(done, total, elapsed_s) -> bool``; ``log`` receives one-line notes.

    ``client``: a ``dask.distributed.Client``: the rays are traced as ``tasks`` ranges on its
    workers (default 2 per worker thread) and summed exactly: the same bits as here.
    ``checkpoint``: a side file that finished ranges are written to every
    ``checkpoint_every_s``; ``resume=True`` continues from it, ``restart=True`` discards it; it
    is removed when the bake is complete. ``range_rays`` fixes the rays per range in this process.
    """
    options = replace(options or SoundOptions(), **overrides)
    if client is None and checkpoint is None:
        return bake_whole(scene, options, progress=progress, log=log)
    work = SoundRanges(scene, options, log=log)
    return range_bake.bake_field(work, client=client, checkpoint=checkpoint, resume=resume,
                                 restart=restart, checkpoint_every_s=checkpoint_every_s,
                                 range_rays=range_rays, tasks=tasks, progress=progress, log=log)
