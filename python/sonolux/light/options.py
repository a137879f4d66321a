"""Settings of a light bake that are not part of the scene: how many particles, how large the
patches are that store the light. One dataclass with defaults and ``validate()``.
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.errors import SonoluxError


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
        def bad(field: str, value: object, allowed: str) -> SonoluxError:
            return SonoluxError(f"light option {field} = {value!r} is not allowed: {allowed}")

        def whole(v: object) -> bool:
            return isinstance(v, int) and not isinstance(v, bool)

        if self.particles != "auto" and not (whole(self.particles) and self.particles >= 1):
            raise bad("particles", self.particles, 'a whole number ≥ 1, or "auto"')
        if not (isinstance(self.patch_size_m, (int, float)) and 1e-3 <= self.patch_size_m <= 100):
            raise bad("patch_size_m", self.patch_size_m, "a size from 0.001 to 100 m")
        if not (whole(self.hits_per_patch) and 1 <= self.hits_per_patch <= 1_000_000):
            raise bad("hits_per_patch", self.hits_per_patch, "a whole number from 1 to 1,000,000")
        if not (whole(self.max_bounces) and 1 <= self.max_bounces <= 1_000_000):
            raise bad("max_bounces", self.max_bounces, "a whole number from 1 to 1,000,000")
        return self
