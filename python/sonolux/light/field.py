"""The light field: the flux that arrived on every surface patch, with the scene it belongs to,
so that a picture can be made from the file alone.

Axes and units (the same in memory and in the file, see :mod:`sonolux.fieldfile`):

- Patches: triangle t is cut into k² equal sub-triangles, k = ``patch_resolution[t]``; they are
  patches ``patch_offset[t]`` to ``patch_offset[t + 1]`` (numbering: see
  :mod:`sonolux.light.patches`). ``patch_area_m2`` float64[P].
- ``flux_w`` float64[P, 3]: the flux incident on each patch per RGB channel, W (before the
  surface absorbs any); ``hits`` uint64[P]: how many particles landed there.
- Derived: irradiance E = flux / area (W/m²); the radiance that a diffuse patch sends out,
  ρ (1 − specular) E / π plus what it emits itself (W/m²/sr); the relative noise of a patch,
  about 1 / sqrt(hits).
- The scene: ``vertices_m`` float64[n, 3], ``triangles`` int64[T, 3] (facing into the room),
  ``material_index`` int32[T], ``surface_tag`` str[T]; per material ``rho`` float64[M, 3]
  (total reflectance), ``specular``, ``roughness`` float64[M]; ``emitted_radiance``
  float64[T, 3] of scene triangles that belong to a surface light; every emitting triangle in
  ``emitter_triangles_m`` float64[E, 3, 3] (triangle, corner, xyz; emitting on the side of
  (b − a) × (c − a)) with ``emitter_radiance`` float64[E, 3] and ``emitter_light`` int32[E]
  into the per-light lists.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError


@dataclass
class LightField:
    patch_size_m: float
    patch_resolution: np.ndarray
    patch_offset: np.ndarray
    patch_area_m2: np.ndarray
    flux_w: np.ndarray
    hits: np.ndarray
    vertices_m: np.ndarray
    triangles: np.ndarray
    material_index: np.ndarray
    surface_tag: np.ndarray
    material_names: list[str]
    rho: np.ndarray
    specular: np.ndarray
    roughness: np.ndarray
    emitted_radiance: np.ndarray
    emitter_triangles_m: np.ndarray
    emitter_radiance: np.ndarray
    emitter_light: np.ndarray
    light_names: list[str]
    light_kinds: list[str]
    light_power_w: np.ndarray
    settings: dict[str, Any]
    stats: dict[str, Any]
    scene_name: str = ""
    scene_origin: str = ""
    #: The work plane's illuminance (a :class:`sonolux.light.workplane.WorkplaneResult`) when
    #: the bake had one; not stored in the field file yet.
    workplane: Any = None
    path: str | None = None

    # --- shape -------------------------------------------------------------------------------
    @property
    def n_patches(self) -> int:
        return int(self.patch_area_m2.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def patch_triangle(self) -> np.ndarray:
        """int64[P]: the scene triangle each patch lies on."""
        counts = np.diff(self.patch_offset.astype(np.int64))
        return np.repeat(np.arange(self.n_triangles, dtype=np.int64), counts)

    @property
    def patch_material(self) -> np.ndarray:
        """int64[P]: the material index of each patch."""
        return self.material_index.astype(np.int64)[self.patch_triangle]

    @property
    def rectangle_emitters(self) -> np.ndarray:
        """bool[E]: emitters that are not scene surfaces (rectangle lights): a picture must
        intersect them itself, since they are not in the scene's geometry."""
        kinds = np.array(self.light_kinds + [""], dtype=object)
        return kinds[self.emitter_light] == "rectangle"

    # --- light on the patches -----------------------------------------------------------------
    @property
    def irradiance_w_m2(self) -> np.ndarray:
        """float64[P, 3]: incident flux per unit area."""
        return self.flux_w / self.patch_area_m2[:, None]

    @property
    def diffuse_reflectance(self) -> np.ndarray:
        """float64[P, 3]: ρ (1 − specular) of each patch's material."""
        diffuse = self.rho * (1.0 - self.specular)[:, None]
        return diffuse[self.patch_material]

    @property
    def radiance_w_m2_sr(self) -> np.ndarray:
        """float64[P, 3]: radiance leaving each patch diffusely, ρ (1 − specular) E / π, plus
        its own emission (surface lights). The specular share is not in it: a picture follows
        the reflection for that (see :mod:`sonolux.light.render`)."""
        own = self.emitted_radiance[self.patch_triangle]
        return self.diffuse_reflectance * self.irradiance_w_m2 / np.pi + own

    @property
    def relative_noise(self) -> np.ndarray:
        """float64[P]: about the relative standard deviation of each patch's flux,
        1 / sqrt(hits) (inf where no particle landed)."""
        with np.errstate(divide="ignore"):
            return 1.0 / np.sqrt(self.hits.astype(np.float64))

    def mean_irradiance_w_m2(self, by: str = "surface") -> dict[str, np.ndarray]:
        """Mean irradiance float64[3] over each surface tag (``by="surface"``: a shoebox's
        faces, a mesh's groups) or each material (``by="material"``): Σ flux / Σ area."""
        if by == "surface":
            names, index = np.unique(np.asarray(self.surface_tag, dtype=str), return_inverse=True)
        elif by == "material":
            names = np.asarray(self.material_names, dtype=str)
            index = self.material_index.astype(np.int64)
        else:
            raise SonoluxError(f"mean irradiance by = {by!r} is not allowed: surface or material")
        group = np.asarray(index, np.int64).reshape(-1)[self.patch_triangle]
        flux = np.stack([np.bincount(group, self.flux_w[:, c], minlength=len(names))
                         for c in range(3)], axis=1)
        area = np.bincount(group, self.patch_area_m2, minlength=len(names))
        return {str(n): flux[i] / area[i] for i, n in enumerate(names) if area[i] > 0}

    def balance_relative_error(self) -> np.ndarray:
        """float64[3]: (emitted + roulette − absorbed − escaped) / emitted; zero to rounding."""
        st = self.stats
        emitted = np.asarray(st["flux_emitted_w"], float)
        rest = (np.asarray(st["flux_roulette_w"], float) - np.asarray(st["flux_absorbed_w"], float)
                - np.asarray(st["flux_escaped_w"], float))
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(emitted > 0, (emitted + rest) / emitted, 0.0)
