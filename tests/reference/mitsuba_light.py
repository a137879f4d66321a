"""Mitsuba 3 as the independent renderer for light (validation and benchmarks only, never a
runtime dependency of sonolux), and the closed box rooms both renderers are given.

- :func:`box_room` writes a closed box [0, L] × [0, W] × [0, H] as an OBJ file whose ceiling is
  cut around a rectangular lamp flush with it (groups floor, ceiling, lamp, west, east, south,
  north; every triangle faces into the room) and loads it as a sonolux scene whose lamp is a
  surface light. A lamp that is part of the surface is the one kind of light both renderers
  model alike: Mitsuba's lights are shapes that block and reflect, sonolux's rectangle lights
  are emitters only.
- :func:`load_mitsuba` imports ``mitsuba`` (pip-installing it into the running interpreter
  when asked), and :func:`mitsuba_scene` builds the same scene for it: per group a mesh with a
  one-sided ``diffuse`` BSDF of the group's reflectance, the lamp with a one-sided ``area``
  emitter of radiance Φ / (π A), and an ``irradiancemeter`` on every group.
- :func:`mean_irradiance` renders those meters with Mitsuba's ``path`` integrator: the mean
  irradiance per group, W/m², float64[3].
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import sonolux

GROUPS = ("floor", "ceiling", "lamp", "west", "east", "south", "north")


def _quad(a, b, c, d):
    return [(a, b, c), (a, c, d)]


def box_room(directory: str | Path, size_m=(2.0, 2.0, 2.0), lamp_m=(0.5, 0.5),
             reflectance: dict[str, tuple[float, float, float]] | None = None,
             lamp_power_w: float = 50.0, name: str = "box") -> sonolux.Scene:
    """A closed box with a lamp of lamp_m (along x, y) flush in the centre of its ceiling."""
    L, W, H = size_m
    lx, ly = lamp_m
    x0, x1, y0, y1 = (L - lx) / 2, (L + lx) / 2, (W - ly) / 2, (W + ly) / 2
    c = {k: np.array(v, float) for k, v in {
        "000": (0, 0, 0), "100": (L, 0, 0), "110": (L, W, 0), "010": (0, W, 0),
        "001": (0, 0, H), "101": (L, 0, H), "111": (L, W, H), "011": (0, W, H)}.items()}
    i0, i1, i2, i3 = (np.array(p, float) for p in ((x0, y0, H), (x1, y0, H), (x1, y1, H), (x0, y1, H)))
    o0, o1, o2, o3 = c["001"], c["101"], c["111"], c["011"]
    groups = {
        "floor": _quad(c["000"], c["100"], c["110"], c["010"]),
        "ceiling": (_quad(o0, o1, i1, i0) + _quad(o1, o2, i2, i1) + _quad(o2, o3, i3, i2)
                    + _quad(o3, o0, i0, i3)),
        "lamp": _quad(i0, i1, i2, i3),
        "west": _quad(c["000"], c["010"], c["011"], c["001"]),
        "east": _quad(c["100"], c["110"], c["111"], c["101"]),
        "south": _quad(c["000"], c["100"], c["101"], c["001"]),
        "north": _quad(c["010"], c["110"], c["111"], c["011"]),
    }
    centre = np.array([L, W, H]) / 2
    vertices: list[tuple[float, ...]] = []
    index: dict[tuple[float, ...], int] = {}
    lines = []
    for g in GROUPS:
        lines.append(f"g {g}\nusemtl {g}")
        for tri in groups[g]:
            a, b, cc = tri
            n = np.cross(b - a, cc - a)
            if np.dot(n, centre - (a + b + cc) / 3) < 0:  # face into the room
                b, cc = cc, b
            ids = []
            for p in (a, b, cc):
                key = tuple(float(v) for v in p)
                if key not in index:
                    index[key] = len(vertices) + 1
                    vertices.append(key)
                ids.append(index[key])
            lines.append("f {} {} {}".format(*ids))
    path = Path(directory) / f"{name}.obj"
    text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices)
    path.write_text(text + "\n".join(lines) + "\n")
    rho = {"floor": (0.73, 0.73, 0.73), "ceiling": (0.73, 0.73, 0.73), "lamp": (0.78, 0.78, 0.78),
           "west": (0.63, 0.065, 0.05), "east": (0.14, 0.45, 0.091), "south": (0.73, 0.73, 0.73),
           "north": (0.73, 0.73, 0.73)}
    rho.update(reflectance or {})
    return sonolux.load_scene({
        "name": name,
        "materials": {f"{g}-material": {"absorption": 0.1, "diffuse_rgb": list(rho[g]),
                                        "specular": 0.0, "roughness": 1.0} for g in GROUPS},
        "geometry": [{"type": "mesh", "file": str(path),
                      "material_map": {g: f"{g}-material" for g in GROUPS}}],
        "lights": [{"name": "lamp", "type": "surface", "material": "lamp-material",
                    "power_w": lamp_power_w}],
    }, base_dir=directory)


def load_mitsuba(install: bool = False, variant: str = "scalar_rgb") -> tuple[Any | None, str]:
    """(mitsuba with ``variant`` set, "") or (None, why not)."""
    try:
        mi = importlib.import_module("mitsuba")
    except ImportError:
        if not install:
            return None, "mitsuba is not installed (pip install mitsuba)"
        done = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "mitsuba"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            return None, f"pip install mitsuba failed: {done.stderr.strip()[-300:]}"
        importlib.invalidate_caches()
        try:
            mi = importlib.import_module("mitsuba")
        except ImportError as exc:
            return None, f"mitsuba does not import after installing it: {exc}"
    try:
        mi.set_variant(variant)
    except Exception as exc:  # noqa: BLE001  (a variant this build or machine lacks)
        return None, f"mitsuba variant {variant} is not available here: {exc}"
    return mi, ""


def scene_groups(scene: sonolux.Scene) -> dict[str, dict[str, Any]]:
    """Per surface tag: triangles float64[k, 3, 3], reflectance float64[3], and the emitted
    radiance float64[3] (zero unless it is a surface light)."""
    from sonolux.light.bake import light_arrays

    emitted = light_arrays(scene)["emitted_radiance"]
    out = {}
    for tag in dict.fromkeys(scene.surface_tag):
        idx = np.flatnonzero(scene.surface_tag == tag)
        out[str(tag)] = {"triangles": scene.vertices_m[scene.triangles[idx]],
                         "rho": scene.materials[scene.material_index[idx[0]]].diffuse_rgb,
                         "radiance": emitted[idx[0]]}
    return out


def _obj(path: Path, triangles: np.ndarray) -> None:
    v = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in triangles.reshape(-1, 3).tolist())
    f = "".join(f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}\n" for i in range(len(triangles)))
    path.write_text(v + f)


def mitsuba_scene(mi: Any, scene: sonolux.Scene, directory: str | Path, *, meters: bool = True,
                  integrator: dict[str, Any] | None = None,
                  sensors: list[dict[str, Any]] | None = None) -> tuple[Any, list[str]]:
    """(the Mitsuba scene, the group name of each of its sensors in order). Shapes that carry a
    sensor are instantiated one by one: Mitsuba's dict parser would otherwise share one meter
    between identical sensor dicts."""
    d: dict[str, Any] = {"type": "scene",
                         "integrator": integrator or {"type": "path", "max_depth": -1}}
    names = []
    for tag, g in scene_groups(scene).items():
        obj = Path(directory) / f"mi-{tag}.obj"
        _obj(obj, g["triangles"])
        shape: dict[str, Any] = {"type": "obj", "filename": str(obj), "face_normals": True,
                                 "bsdf": {"type": "diffuse",
                                          "reflectance": {"type": "rgb", "value": list(g["rho"])}}}
        if np.any(g["radiance"] > 0):
            shape["emitter"] = {"type": "area",
                                "radiance": {"type": "rgb", "value": list(g["radiance"])}}
        if meters:
            shape["sensor"] = {"type": "irradiancemeter",
                               "film": {"type": "hdrfilm", "width": 1, "height": 1,
                                        "rfilter": {"type": "box"}, "pixel_format": "rgb"}}
            names.append(tag)
            d[f"shape-{tag}"] = mi.load_dict(shape)
        else:
            d[f"shape-{tag}"] = shape
    for k, s in enumerate(sensors or []):
        d[f"sensor-{k}"] = s
    return mi.load_dict(d), names


def mean_irradiance(mi: Any, scene: sonolux.Scene, spp: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Mitsuba's mean irradiance per group (path tracer, ``spp`` samples per meter)."""
    with tempfile.TemporaryDirectory() as tmp:
        ms, names = mitsuba_scene(mi, scene, tmp)
        out = {}
        for k, name in enumerate(names):
            img = mi.render(ms, sensor=k, spp=spp, seed=seed + 7919 * k)
            out[name] = np.asarray(img, float).reshape(-1)[:3]
        return out
