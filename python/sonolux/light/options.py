"""Settings of a light bake that are not part of the scene: how many particles, how large the
patches are that store the light. One dataclass with defaults and ``validate()``.
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.errors import check_number
from sonolux.limits import MAX_RAYS


@dataclass(frozen=True)
class LightOptions:
    """How to bake the light.

    particles: particles to trace, or "auto" (see :func:`sonolux.light.bake.auto_particles`:
        enough that the average patch is hit ``hits_per_patch`` times).
    patch_size_m: the patches' size: a triangle of area A is cut into k² equal sub-triangles
        with k = ceil(sqrt(2 A) / patch_size_m), so a patch's legs are about this long.
    hits_per_patch: what "auto" aims at; a patch's relative noise is about 1/sqrt(hits).
    max_bounces: a guard on the length of a path (Russian roulette ends paths long before).
    """

    particles: int | str = "auto"
    patch_size_m: float = 0.25
    hits_per_patch: int = 400
    max_bounces: int = 10_000

    def validate(self) -> LightOptions:
        if self.particles != "auto":
            check_number("light option particles", self.particles, 1, MAX_RAYS, integer=True)
        check_number("light option patch_size_m", self.patch_size_m, 1e-3, 100, unit="m")
        check_number("light option hits_per_patch", self.hits_per_patch, 1, 1_000_000,
                     integer=True)
        check_number("light option max_bounces", self.max_bounces, 1, 1_000_000, integer=True)
        return self
