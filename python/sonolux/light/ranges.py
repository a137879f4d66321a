"""The light bake in particle ranges: checkpointed, resumable, spread over a Dask cluster.

:class:`LightRanges` is the light bake's :class:`sonolux.ranges.RangeWork`. The light tracer
sums flux in fixed point with a quantum that depends on the lights only (2⁻⁵⁰ of their total
flux), and its energy tallies in units of 2⁻⁶⁴ W, and a particle's random numbers and weight
depend on (seed, particle, particle count) only. So the exact counts of any particle ranges add
up, as integers, to the counts of the bake done at once, and the field made from them
(:func:`sonolux.light.bake.light_field`, flux = counts × quantum as the core computes it) has
the same bits.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sonolux import range_bake, ranges
from sonolux.checkpoint import fingerprint
from sonolux.errors import SonoluxError
from sonolux.light.bake import auto_particles, bake_light, light_arrays, light_field, trace_particles
from sonolux.light.field import LightField
from sonolux.light.options import LightOptions
from sonolux.scene.schema import Scene
from sonolux.version import __version__

#: What the core returns per patch (and work-plane cell) that adds up over ranges.
COUNT_ARRAYS = ("flux_counts", "hits", "plane_flux_counts", "plane_hits")
#: What is the same in every range (the patches; the quantum).
FIXED_ARRAYS = ("patch_resolution", "patch_offset", "patch_area_m2")
#: Statistics that add up over ranges.
SUMMED_STATS = ("particles", "bounces", "escaped_particles", "seconds")
#: The stats' energy tallies, in the order of ``stats["energy_counts"]``.
TALLIES = ("flux_emitted_w", "flux_absorbed_w", "flux_escaped_w", "flux_roulette_w")


@dataclass
class LightSum:
    """The exact sum of some particle ranges of one light bake: the count arrays
    (:data:`COUNT_ARRAYS`, uint64), the fixed arrays, the quanta, the summed stats and the
    energy tallies (Python ints, [tally][channel])."""

    arrays: dict[str, np.ndarray]
    quantum_w: float
    energy_counts: list[list[int]]
    energy_quantum_w: float
    stats: dict[str, Any]

    @classmethod
    def of(cls, out: dict[str, Any], seconds: float) -> LightSum:
        stats = out["stats"]
        arrays = {k: np.array(out[k]) for k in (*COUNT_ARRAYS, *FIXED_ARRAYS) if k in out}
        return cls(arrays, float(out["flux_quantum_w"]),
                   [[int(v) for v in row] for row in stats["energy_counts"]],
                   float(stats["energy_quantum_w"]),
                   {**{k: stats.get(k, 0) for k in SUMMED_STATS if k != "seconds"},
                    "seconds": seconds, "cancelled": bool(out["cancelled"])})

    def add(self, other: LightSum) -> LightSum:
        if self.quantum_w != other.quantum_w or any(
                self.arrays[k].shape != other.arrays[k].shape for k in self.arrays):
            raise SonoluxError("these ranges come from different light bakes and cannot be "
                               "summed")
        for k in COUNT_ARRAYS:
            if k in self.arrays:
                np.add(self.arrays[k], other.arrays[k], out=self.arrays[k])
        self.energy_counts = [[a + b for a, b in zip(r, s)]
                              for r, s in zip(self.energy_counts, other.energy_counts)]
        for k in SUMMED_STATS:
            self.stats[k] = self.stats.get(k, 0) + other.stats.get(k, 0)
        self.stats["cancelled"] = bool(self.stats.get("cancelled")) or \
            bool(other.stats.get("cancelled"))
        return self

    def core_result(self) -> dict[str, Any]:
        """The sum in the shape of the core's result: flux = counts × quantum and the energy
        tallies in W, computed as the core computes them (one rounding each)."""
        out: dict[str, Any] = dict(self.arrays)
        out["flux_w"] = self.arrays["flux_counts"].astype(np.float64) * self.quantum_w
        if "plane_flux_counts" in self.arrays:
            out["plane_flux_w"] = self.arrays["plane_flux_counts"].astype(np.float64) \
                * self.quantum_w
        stats = dict(self.stats)
        for name, row in zip(TALLIES, self.energy_counts):
            stats[name] = [float(v) * self.energy_quantum_w for v in row]
        out["stats"] = stats
        out["cancelled"] = bool(self.stats.get("cancelled"))
        return out


class LightRanges:
    """The light bake of ``scene`` with ``options`` as a :class:`sonolux.ranges.RangeWork`.

    The automatic particle count is resolved here, once. Pickled (for Dask), it carries the
    scene's content without its BVH; a worker rebuilds the BVH and the light arrays once."""

    kind = "light"
    unit = "particles"

    def __init__(self, scene: Scene, options: LightOptions | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        options = (options or LightOptions()).validate()
        if not scene.lights and scene.daylight is None:
            raise SonoluxError(f"{scene.origin}: the scene has no light to bake")
        self._arrays: dict[str, Any] | None = light_arrays(scene)
        if options.particles == "auto":
            particles, self.why = auto_particles(scene, options, self._arrays)
            if log:
                log(self.why)
        else:
            particles, self.why = int(options.particles), "given"
        self.total = particles
        self.target = (0, particles)
        self.options = replace(options, particles=particles)
        self.scene, self.name = scene, scene.name
        self.stamp = {"scene": fingerprint(ranges.scene_content(scene)),
                      "settings": fingerprint(self.options), "version": __version__}
        self.fingerprint = fingerprint("light", self.stamp)

    def __getstate__(self) -> dict[str, Any]:
        return dict(self.__dict__, scene=replace(self.scene, geometry=None), _arrays=None)

    def arrays(self, scene: Scene) -> dict[str, Any]:
        if self._arrays is None:  # in a worker: the core's light objects are not pickled
            self._arrays = light_arrays(scene)
        return self._arrays

    def trace(self, first: int, end: int, threads: int | None = None,
              progress: ranges.Progress | None = None) -> LightSum:
        scene = ranges.loaded_scene(self.scene, self.stamp["scene"], threads)
        started = time.perf_counter()
        out = trace_particles(scene, self.arrays(scene), self.options, self.total, progress,
                              first=first, end=end, threads=threads)
        return LightSum.of(out, time.perf_counter() - started)

    def add(self, total: LightSum | None, part: LightSum) -> LightSum:
        return part if total is None else total.add(part)

    def encode(self, total: LightSum) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta = {"quantum_w": total.quantum_w, "energy_quantum_w": total.energy_quantum_w,
                # as text: JSON readers other than Python's may round integers past 2⁵³
                "energy_counts": [[str(v) for v in row] for row in total.energy_counts],
                "stats": total.stats}
        return meta, dict(total.arrays)

    def decode(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> LightSum:
        return LightSum({k: np.array(v) for k, v in arrays.items()}, float(meta["quantum_w"]),
                        [[int(v) for v in row] for row in meta["energy_counts"]],
                        float(meta["energy_quantum_w"]), dict(meta["stats"]))

    def finish(self, total: LightSum, done: list[ranges.Range]) -> LightField:
        scene = ranges.loaded_scene(self.scene, self.stamp["scene"])
        field = light_field(scene, self.options, self.arrays(scene), self.total, self.why,
                            total.core_result())
        field.settings["fingerprint"] = self.fingerprint
        return field


def bake(scene: Scene, options: LightOptions | None = None, *, client: Any = None,
         checkpoint: str | Path | None = None, resume: bool = False, restart: bool = False,
         checkpoint_every_s: float = 60.0, range_particles: int | None = None,
         tasks: int | None = None, progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, **overrides: Any) -> LightField:
    """Traces light particles from the scene's lights and stores the flux on every patch.

    ``options`` (or keyword overrides such as ``particles=200_000``) set the bake, as for
    :func:`sonolux.light.bake.bake_light`, which this is without ``client`` and
    ``checkpoint``. ``client``: a ``dask.distributed.Client``: the particles are traced as
    ``tasks`` ranges on its workers and summed exactly (the same bits as here).
    ``checkpoint``: a side file written every ``checkpoint_every_s``; ``resume=True``
    continues from it, ``restart=True`` discards it; it is removed when the bake is complete.
    """
    options = replace(options or LightOptions(), **overrides)
    if client is None and checkpoint is None:
        return bake_light(scene, options, progress=progress, log=log)
    work = LightRanges(scene, options, log=log)
    return range_bake.bake_field(
        work, client=client, checkpoint=checkpoint, resume=resume, restart=restart,
        checkpoint_every_s=checkpoint_every_s, range_rays=range_particles, tasks=tasks,
        progress=progress, log=log)
