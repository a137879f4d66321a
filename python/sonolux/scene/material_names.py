"""A scene's ``[materials]`` table, and how material names are resolved.

A name used by the geometry (a shoebox face, a mesh material, ``material = ...``) is looked up
in the scene's own ``[materials]`` first, then in the material library
(:mod:`sonolux.scene.materials`). A ``[materials.NAME]`` entry is either

- an override: it starts from the library entry named by ``base`` (or, without ``base``, from
  the library entry of the same name) and replaces the fields it gives; or
- a new material: then ``absorption`` is required, and the other fields default to
  scattering 0.1, diffuse_rgb [0.8, 0.8, 0.8], specular 0, roughness 0.5.

The library is read only when a name needs it, so a scene that defines all its materials
(like the built-in ``paper-*`` scenes) loads without it.
"""

from __future__ import annotations

import math

import numpy as np

from sonolux.acoustics.surface import PARIS_PEAK_G, WellSurface, paris_absorption
from sonolux.errors import SceneError, close_matches
from sonolux.scene.materials import Library
from sonolux.scene.materials import library as shipped_library
from sonolux.scene.schema import LIBRARY_BAND_SET, REQUIRED, Context, Material, Table

MATERIAL_KEYS = ("base", "description", "bands_hz", "absorption", "scattering", "surface",
                 "diffuse_rgb", "specular", "roughness", "transmittance")

#: Keys of a ``[materials.NAME.surface]`` table (docs/scene.md; sonolux.acoustics.surface).
SURFACE_KEYS = ("depths_m", "patch_m")
#: At most this many well depths (a designed sequence is a period of a few to a few dozen).
MAX_WELLS = 256

#: Defaults of a new material's optional fields.
NEW_MATERIAL_DEFAULTS = {"scattering": 0.1, "diffuse_rgb": (0.8, 0.8, 0.8), "specular": 0.0,
                         "roughness": 0.5}


class MaterialNames:
    """Resolves material names for one scene: its ``[materials]`` first, then the library."""

    def __init__(self, table: Table | None, ctx: Context, library: Library | None = None) -> None:
        self.ctx = ctx
        self._library = library
        self._library_error: SceneError | None = None
        self.defined: dict[str, Material] = {}
        if table is not None:
            for name in table.data:
                self.defined[name] = self._read(table, name)

    def library(self, required: bool = True) -> Library | None:
        """The library in use; None when it cannot be read and ``required`` is False."""
        if self._library is None and self._library_error is None:
            try:
                self._library = shipped_library()
            except SceneError as exc:
                self._library_error = exc
        if self._library is None and required:
            assert self._library_error is not None
            raise self._library_error
        return self._library

    def names(self) -> list[str]:
        lib = self.library(required=False)
        return sorted(set(self.defined) | set(lib.names() if lib else ()))

    def find(self, name: str) -> Material | None:
        if name in self.defined:
            return self.defined[name]
        lib = self.library(required=False)
        return lib.find(name) if lib is not None else None

    def resolve(self, name: str, key: str) -> Material:
        """The material called ``name``; a SceneError at ``key`` listing close matches if none."""
        m = self.find(name)
        if m is None:
            lib = self.library(required=False)
            where = f"the library {lib.path}" if lib is not None else "the library (unreadable)"
            raise self.ctx.error(key, name, f"a material defined in [materials] or in {where}",
                                 matches=close_matches(name, self.names()))
        return m

    def _read(self, materials: Table, name: str) -> Material:
        t = materials.table(name)
        assert t is not None
        t.check_keys(MATERIAL_KEYS)
        base_name = t.string("base", None)
        if base_name is not None:
            lib = self.library(required=True)
            assert lib is not None
            if base_name not in lib:
                raise self.ctx.error(t.path("base"), base_name,
                                     f"a material of the library {lib.path}",
                                     matches=close_matches(base_name, lib.names()))
            start = lib.materials[base_name]
        else:
            lib = self.library(required=False)
            start = lib.find(name) if lib is not None else None
        # The bands the table's absorption and scattering lists are given in (octaves or
        # thirds, docs/bands.md); values not given keep their own bands.
        grid = t.band_grid("bands_hz", LIBRARY_BAND_SET)
        surface = _surface(t)
        if surface is not None and t.has("scattering"):
            raise self.ctx.error(t.path("scattering"), t.data["scattering"],
                                 message="give either scattering or a surface profile "
                                         "([materials.NAME.surface]), not both: a profile sets "
                                         "the scattering")
        if start is None:
            if surface is not None:
                _check_surface_absorption(t, t.bands("absorption", None, grid))
            if not t.has("absorption"):
                raise self.ctx.error(
                    t.path("absorption"),
                    allowed="a new material needs its absorption (a number in [0, 1] or one "
                            "per band of bands_hz), or base = NAME to start from a library "
                            "material")
            d = NEW_MATERIAL_DEFAULTS
            return Material(
                name=name,
                absorption=t.bands("absorption", REQUIRED, grid),
                scattering=t.bands("scattering", np.full(grid.n_bands, d["scattering"]), grid),
                absorption_bands=grid, scattering_bands=grid,
                diffuse_rgb=t.vector("diffuse_rgb", 3, d["diffuse_rgb"], lo=0.0, hi=1.0),
                specular=t.number("specular", d["specular"], lo=0.0, hi=1.0),
                roughness=t.number("roughness", d["roughness"], lo=0.0, hi=1.0),
                description=t.string("description", ""),
                transmittance=_transmittance(t, d["diffuse_rgb"]),
                surface=surface,
            )
        if surface is not None:
            _check_surface_absorption(t, t.bands("absorption", start.absorption.copy(), grid)
                                      if t.has("absorption") else start.absorption)
        return Material(
            name=name,
            absorption=t.bands("absorption", start.absorption.copy(), grid)
            if t.has("absorption") else start.absorption.copy(),
            scattering=t.bands("scattering", start.scattering.copy(), grid)
            if t.has("scattering") else start.scattering.copy(),
            absorption_bands=grid if t.has("absorption") else start.absorption_bands,
            scattering_bands=grid if t.has("scattering") else start.scattering_bands,
            diffuse_rgb=t.vector("diffuse_rgb", 3, start.diffuse_rgb, lo=0.0, hi=1.0),
            specular=t.number("specular", start.specular, lo=0.0, hi=1.0),
            roughness=t.number("roughness", start.roughness, lo=0.0, hi=1.0),
            description=t.string("description", start.description),
            transmittance=_transmittance(t, start.diffuse_rgb, start.transmittance),
            # A profile given here replaces the start's scattering; scattering given here
            # replaces the start's profile.
            surface=surface if surface is not None else
            (None if t.has("scattering") else start.surface),
        )


def _transmittance(t: Table, default_rgb: object, default: float = 0.0) -> float:
    """The visible transmittance, checked against the reflectance: ρ + τ ≤ 1 per channel."""
    tau = t.number("transmittance", default, lo=0.0, hi=1.0)
    rho = np.asarray(t.data.get("diffuse_rgb", default_rgb), float)
    if tau > 0 and np.any(rho + tau > 1.0 + 1e-12):
        raise t.ctx.error(t.path("transmittance"), tau,
                          f"at most 1 - diffuse_rgb = {1 - float(rho.max()):g} (reflected and "
                          "transmitted light cannot exceed what arrives)")
    return tau


def _surface(t: Table) -> WellSurface | None:
    """The material's ``surface`` table: wells of ``depths_m`` (a list of depths in m, each
    equally likely) behind square patches of side ``patch_m`` (m); None when not given."""
    st = t.table("surface")
    if st is None:
        return None
    st.check_keys(SURFACE_KEYS)
    allowed = (f"a list of 1 to {MAX_WELLS} well depths in m, each in [0, 10], at least one "
               "> 0 (each drawn with equal probability per patch)")
    depths = st.data.get("depths_m")
    if (not isinstance(depths, list) or not 1 <= len(depths) <= MAX_WELLS
            or not all(isinstance(d, (int, float)) and not isinstance(d, bool)
                       and math.isfinite(d) and 0.0 <= d <= 10.0 for d in depths)
            or not any(d > 0 for d in depths)):
        raise t.ctx.error(st.path("depths_m"), depths if "depths_m" in st.data else None,
                          allowed)
    patch = st.number("patch_m", lo=0.0, lo_open=True, hi=100.0)
    return WellSurface(tuple(float(d) for d in depths), patch)


def _check_surface_absorption(t: Table, absorption: np.ndarray | None) -> None:
    """A profile's wells sit in front of a locally reacting face (sonolux.acoustics.surface),
    which absorbs at most Paris' peak, 0.951, at random incidence."""
    if absorption is None:
        return
    peak = float(paris_absorption(PARIS_PEAK_G))
    if np.any(np.asarray(absorption) > peak):
        raise t.ctx.error(t.path("surface"), message=(
            f"a surface profile needs absorption ≤ {peak:.3f} in every band (its flat face is a "
            f"locally reacting wall); the absorption reaches {float(np.max(absorption)):.3f}"))
