"""The ``/light`` group of a field file (see :mod:`sonolux.fieldfile` for the file itself).

    /light                 attrs: settings (JSON: particles and why, seed, threads, patch_size_m,
                                  hits_per_patch, max_bounces, area_m2, volume_m3),
                                  stats (JSON: particles, bounces, escaped_particles,
                                  flux_emitted_w / flux_absorbed_w / flux_escaped_w /
                                  flux_roulette_w per channel, seconds, particles_per_second,
                                  hits_per_particle, cancelled), patch_size_m
    /light/patch_resolution   uint32[triangle]      k: the triangle holds k² patches
    /light/patch_offset       uint64[triangle + 1]  its patches are offset[t]..offset[t + 1]
    /light/patch_area_m2      float64[patch]
    /light/flux_w             float64[patch, 3]     incident flux per RGB channel, W (gzip)
    /light/hits               uint64[patch]         particles that landed on the patch
    /light/scene/vertices_m   float64[vertex, 3];   /light/scene/triangles  int64[triangle, 3]
    /light/scene/material_index  int32[triangle];   /light/scene/surface_tag  str[triangle]
    /light/scene/material_names  str[material]
    /light/scene/rho          float64[material, 3]  total reflectance per channel
    /light/scene/specular, /light/scene/roughness   float64[material]
    /light/scene/emitted_radiance  float64[triangle, 3]  W/m²/sr (surface lights), else 0
    /light/emitters/triangles_m  float64[emitter, 3, 3]  (emitter, corner, xyz)
    /light/emitters/radiance     float64[emitter, 3]     W/m²/sr
    /light/emitters/light        int32[emitter]          index into the per-light lists
    /light/lights/names, /light/lights/kinds  str[light];  /light/lights/power_w  float64[light]
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.light.field import LightField

SCENE_ARRAYS = ("vertices_m", "triangles", "material_index", "rho", "specular", "roughness",
                "emitted_radiance")


def write_group(f: Any, field: LightField, json_default: Any) -> None:
    """Writes ``field`` into a new ``/light`` group of the open h5py file ``f``."""
    import h5py

    text = h5py.string_dtype()
    g = f.create_group("light")
    g.attrs["settings"] = json.dumps(field.settings, default=json_default)
    g.attrs["stats"] = json.dumps(field.stats, default=json_default)
    g.attrs["patch_size_m"] = field.patch_size_m
    g["patch_resolution"] = np.asarray(field.patch_resolution, np.uint32)
    g["patch_offset"] = np.asarray(field.patch_offset, np.uint64)
    g.create_dataset("patch_area_m2", data=field.patch_area_m2, compression="gzip", shuffle=True)
    g.create_dataset("flux_w", data=field.flux_w, compression="gzip", shuffle=True)
    g.create_dataset("hits", data=np.asarray(field.hits, np.uint64), compression="gzip",
                     shuffle=True)
    s = g.create_group("scene")
    for name in SCENE_ARRAYS:
        s[name] = getattr(field, name)
    s["surface_tag"] = np.array([str(t) for t in field.surface_tag], dtype=text)
    s["material_names"] = np.array(field.material_names, dtype=text)
    e = g.create_group("emitters")
    e["triangles_m"] = field.emitter_triangles_m
    e["radiance"] = field.emitter_radiance
    e["light"] = np.asarray(field.emitter_light, np.int32)
    lights = g.create_group("lights")
    lights["names"] = np.array(field.light_names, dtype=text)
    lights["kinds"] = np.array(field.light_kinds, dtype=text)
    lights["power_w"] = field.light_power_w


def _strings(d: Any) -> list[str]:
    return [v.decode() if isinstance(v, bytes) else str(v) for v in d[...]]


def read_group(f: Any, path: str) -> LightField:
    """The light field in the open h5py file ``f`` (a clear error when /light is missing)."""
    if "light" not in f:
        raise SonoluxError(f"{path}: the file holds no light field (/light is missing; it was "
                           "baked without light: run sonolux bake with --light)")
    g = f["light"]
    try:
        s, e, lights = g["scene"], g["emitters"], g["lights"]
        return LightField(
            patch_size_m=float(g.attrs["patch_size_m"]),
            patch_resolution=g["patch_resolution"][...], patch_offset=g["patch_offset"][...],
            patch_area_m2=g["patch_area_m2"][...], flux_w=g["flux_w"][...], hits=g["hits"][...],
            **{name: s[name][...] for name in SCENE_ARRAYS},
            surface_tag=np.array(_strings(s["surface_tag"]), dtype=str),
            material_names=_strings(s["material_names"]),
            emitter_triangles_m=e["triangles_m"][...], emitter_radiance=e["radiance"][...],
            emitter_light=e["light"][...], light_names=_strings(lights["names"]),
            light_kinds=_strings(lights["kinds"]), light_power_w=lights["power_w"][...],
            settings=json.loads(g.attrs["settings"]), stats=json.loads(g.attrs["stats"]),
            scene_name=str(f.attrs.get("scene_name", "")),
            scene_origin=str(f.attrs.get("scene_origin", "")), path=str(path))
    except KeyError as exc:
        raise SonoluxError(f"{path}: the light field is incomplete ({exc.args[0]} is "
                           "missing)") from None
