"""What a field file must hold to be used: checked once, when it is read
(:mod:`sonolux.fieldfile`), so that a damaged, truncated or edited file is a
:class:`~sonolux.errors.FieldFileError` naming the file and the dataset at fault, never a
traceback (or a WAV of NaN) later in ``params``, ``report``, ``info`` or ``auralize``.

Checked: every array's shape against the others (docs/fieldfile.md: energy is
[receiver, direction, band, time]), values finite, energies, fluxes and powers ≥ 0, widths,
bands, radius and patch sizes > 0, and the settings that the readers use. Before a large
dataset is read its size is checked against the memory this machine can give
(:mod:`sonolux.memory`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonolux.acoustics.bands import KINDS, is_contiguous_run
from sonolux.errors import FieldFileError, MemoryLimitError
from sonolux.memory import check_memory
from sonolux.sound.compact import CompactArray


class Checker:
    """Checks of one group (``/sound`` or ``/light``) of the file ``path``."""

    def __init__(self, path: str, group: str) -> None:
        self.path = path
        self.group = group

    def fail(self, name: str, problem: str) -> FieldFileError:
        return FieldFileError(f"{self.path}: /{self.group}/{name} {problem}; the file is damaged "
                              "or was not written by sonolux (bake it again)")

    def dataset(self, g: Any, name: str) -> np.ndarray:
        """Reads ``g[name]`` after a memory check; a missing or unreadable one is named."""
        if name not in g:
            raise self.fail(name, "is missing")
        d = g[name]
        nbytes = float(np.prod(d.shape, dtype=np.float64)) * d.dtype.itemsize
        try:
            check_memory(nbytes, f"reading /{self.group}/{name}", f"shape {d.shape}")
        except MemoryLimitError as exc:
            raise FieldFileError(f"{self.path}: {exc}") from None
        try:
            return d[...]
        except (OSError, ValueError, TypeError) as exc:
            raise self.fail(name, f"cannot be read ({' '.join(str(exc).split())})") from None

    def array(self, name: str, a: Any, ndim: int, *, lo: float | None = None,
              positive: bool = False, kind: str = "fiu", shape: tuple | None = None) -> np.ndarray:
        """``a`` as an array of ``ndim`` axes of numbers of a dtype kind in ``kind``, finite,
        ≥ ``lo`` (or > 0 when ``positive``), with ``shape`` where an axis is not None."""
        a = np.asarray(a)
        if a.ndim != ndim:
            raise self.fail(name, f"has {a.ndim} axes, not {ndim}")
        if a.dtype.kind not in kind:
            raise self.fail(name, f"holds {a.dtype} values, not numbers")
        if shape is not None:
            for axis, (got, want) in enumerate(zip(a.shape, shape)):
                if want is not None and got != want:
                    raise self.fail(name, f"has shape {a.shape}: axis {axis} should be {want}")
        if a.dtype.kind == "f" and a.size and not np.all(np.isfinite(a)):
            raise self.fail(name, "holds NaN or infinite values")
        if lo is not None and a.size and np.min(a) < lo:
            raise self.fail(name, f"holds values below {lo:g} (min {np.min(a):.3g})")
        if positive and a.size and np.min(a) <= 0:
            raise self.fail(name, f"holds values ≤ 0 (min {np.min(a):.3g})")
        return a

    def number(self, name: str, v: Any, *, positive: bool = False, nan_ok: bool = False) -> float:
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise self.fail(name, f"= {v!r} is not a number") from None
        if np.isnan(x) and nan_ok:
            return x
        if not np.isfinite(x) or (positive and x <= 0):
            raise self.fail(name, f"= {x!r} is not {'a number > 0' if positive else 'finite'}")
        return x


def check_sound(path: str, a: dict[str, Any]) -> None:
    """The arrays of a sound field, as read (``a``: the SoundField's keyword arguments)."""
    c = Checker(path, "sound")
    s = a["settings"]
    if not isinstance(s, dict):
        raise c.fail("settings", "is not a JSON object")
    for key in ("sample_rate_hz", "azimuth_bands", "elevation_bands"):
        v = s.get(key)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
            raise c.fail(f"settings.{key}", f"= {v!r} is not a whole number ≥ 1")
    n_dir = s["azimuth_bands"] * s["elevation_bands"]
    e = _field_array(c, "energy", a["energy"], "f")
    n_r, _, n_b, n_t = e.shape
    if e.shape[1] != n_dir:
        raise c.fail("energy", f"has shape {e.shape}: axis 1 should be {n_dir}")
    c.array("bin_start_s", a["bin_start_s"], 1, lo=0.0, shape=(n_t,))
    c.array("bin_width_s", a["bin_width_s"], 1, positive=True, shape=(n_t,))
    bands = c.array("bands_hz", a["bands_hz"], 1, positive=True, shape=(n_b,))
    kind = s.get("bands")
    if kind is not None and not (kind in KINDS and is_contiguous_run(bands.tolist(), kind)):
        raise c.fail("settings.bands", f"= {kind!r} does not describe bands_hz "
                     f"{bands.tolist()}: \"octave\" or \"third-octave\" with a contiguous run "
                     "of that kind's centres")
    c.array("receivers_m", a["positions_m"], 2, shape=(n_r, 3))
    c.number("radius_m", a["radius_m"], positive=True)
    if a["grid_index"] is not None:
        c.array("grid_index", a["grid_index"], 2, kind="iu", shape=(n_r, 2))
    if a["grid_spacing_m"] is not None:
        c.number("grid_spacing_m", a["grid_spacing_m"], positive=True)
    src = c.array("sources_m", a["source_positions_m"], 2, shape=(None, 3))
    c.array("source_powers_w", a["source_powers_w"], 1, lo=0.0, shape=(src.shape[0],))
    if a["counts"] is not None:
        counts = _field_array(c, "counts", a["counts"], "iu")
        if counts.shape != e.shape:
            raise c.fail("counts", f"has shape {counts.shape}, not the energy's {e.shape}")
    c.number("quantum", a["quantum"], nan_ok=False)


def _field_array(c: Checker, name: str, a: Any, kind: str) -> Any:
    """A [receiver, direction, band, time] array, dense or compact (its stored parts checked,
    never made dense): numbers of ``kind``, finite, ≥ 0."""
    if isinstance(a, CompactArray):
        c.array(f"{name}/late", a.late, 4, lo=0, kind=kind)
        c.array(f"{name}/early", a.value, 1, lo=0, kind=kind)
        return a
    return c.array(name, a, 4, lo=0, kind=kind)


def check_light(path: str, a: dict[str, Any], n_lights: int) -> None:
    """The arrays of a light field, as read (``a``: the LightField's keyword arguments), of a
    bake of ``n_lights`` lights (as many names as are stored)."""
    c = Checker(path, "light")
    c.number("patch_size_m", a["patch_size_m"], positive=True)
    tris = c.array("scene/triangles", a["triangles"], 2, lo=0, kind="iu", shape=(None, 3))
    verts = c.array("scene/vertices_m", a["vertices_m"], 2, shape=(None, 3))
    if tris.size and np.max(tris) >= verts.shape[0]:
        raise c.fail("scene/triangles", f"names vertex {np.max(tris)} of {verts.shape[0]}")
    n_t = tris.shape[0]
    res = c.array("patch_resolution", a["patch_resolution"], 1, kind="iu", shape=(n_t,))
    off = c.array("patch_offset", a["patch_offset"], 1, kind="iu", shape=(n_t + 1,))
    n_p = int(np.sum(res.astype(np.float64) ** 2))
    if off.size and (int(off[0]) != 0 or np.any(np.diff(off.astype(np.int64)) != res.astype(np.int64) ** 2)):
        raise c.fail("patch_offset", "does not match patch_resolution (k² patches a triangle)")
    c.array("patch_area_m2", a["patch_area_m2"], 1, lo=0.0, shape=(n_p,))
    c.array("flux_w", a["flux_w"], 2, lo=0.0, shape=(n_p, 3))
    c.array("hits", a["hits"], 1, lo=0, kind="iu", shape=(n_p,))
    rho = c.array("scene/rho", a["rho"], 2, lo=0.0, shape=(None, 3))
    n_m = rho.shape[0]
    index = c.array("scene/material_index", a["material_index"], 1, lo=0, kind="iu", shape=(n_t,))
    if index.size and int(np.max(index)) >= n_m:
        raise c.fail("scene/material_index", f"names material {np.max(index)} of {n_m}")
    c.array("scene/specular", a["specular"], 1, lo=0.0, shape=(n_m,))
    c.array("scene/roughness", a["roughness"], 1, lo=0.0, shape=(n_m,))
    c.array("scene/emitted_radiance", a["emitted_radiance"], 2, lo=0.0, shape=(n_t, 3))
    emitters = c.array("emitters/triangles_m", a["emitter_triangles_m"], 3, shape=(None, 3, 3))
    n_e = emitters.shape[0]
    c.array("emitters/radiance", a["emitter_radiance"], 2, lo=0.0, shape=(n_e, 3))
    owner = c.array("emitters/light", a["emitter_light"], 1, lo=0, kind="iu", shape=(n_e,))
    power = c.array("lights/power_w", a["light_power_w"], 1, lo=0.0, shape=(n_lights,))
    if owner.size and int(np.max(owner)) >= power.shape[0]:
        raise c.fail("emitters/light", f"names light {np.max(owner)} of {power.shape[0]}")

