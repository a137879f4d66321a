"""Baking the light: the scene's optics and lights go to the Rust particle tracer (the one that
traces sound, on the same BVH), a :class:`LightField` comes back. Also the automatic particle
count.

Colour convention: a light's ``power_w`` is the mean of its flux over the three channels, so
channel c carries ``power_w × color_rgb[c] / mean(color_rgb)`` W, shared among the light's
triangles by area. Its radiance is then uniform, Φ_c / (π A) W/m²/sr (cosine emission).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.errors import SonoluxError
from sonolux.light.field import LightField
from sonolux.light.options import LightOptions
from sonolux.light.photometry import MAX_LUMINOUS_EFFICACY_LM_PER_W
from sonolux.light.sources import other_sources
from sonolux.light.workplane import plane_request, workplane_result
from sonolux.progress import ProgressLine
from sonolux.scene.schema import Scene

#: Particles of the pilot run that measures how many surface hits a particle makes.
PILOT_PARTICLES = 4096
MIN_PARTICLES, MAX_PARTICLES = 10_000, 50_000_000


def channel_flux_w(power_w: float, color_rgb: np.ndarray) -> np.ndarray:
    """float64[3]: flux per channel, power_w × color / mean(color) (zero for a black light)."""
    color = np.asarray(color_rgb, float)
    mean = float(color.mean())
    return power_w * color / mean if mean > 0 else np.zeros(3)


def _areas(tris: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)


def light_arrays(scene: Scene) -> dict[str, Any]:
    """What the tracer and the pictures need from the scene's materials and lights.

    rho float64[M, 3], specular and roughness float64[M]; emitters float64[E, 3, 3] with
    emitter_flux float64[E, 3] (W) and emitter_radiance float64[E, 3] (W/m²/sr),
    emitter_light int32[E]; emitted_radiance float64[T, 3] of the scene's own triangles
    (surface lights); per light: names, kinds, power_w. Also ``sources`` (luminaires, sky and
    sun: see :func:`sonolux.light.sources.other_sources`), ``sky``, ``transmittance``
    float64[M, 3] and ``work_plane`` (the core's plane request, or None).
    """
    n_tri = scene.triangles.shape[0]
    names = [m.name for m in scene.materials]
    emitters, flux, radiance, owner = [], [], [], []
    emitted = np.zeros((n_tri, 3))
    for i, light in enumerate(scene.lights):
        if light.kind == "ies":
            continue
        tris = np.asarray(light.triangles_m, float).reshape(-1, 3, 3)
        area = _areas(tris)
        total = float(area.sum())
        phi = channel_flux_w(light.power_w, light.color_rgb)
        if total <= 0 or not np.any(phi > 0):
            continue
        keep = area > 0
        emitters.append(tris[keep])
        flux.append(np.outer(area[keep] / total, phi))
        radiance.append(np.repeat((phi / (math.pi * total))[None], int(keep.sum()), axis=0))
        owner.append(np.full(int(keep.sum()), i, np.int32))
        if light.kind == "surface" and light.material in names:
            mine = scene.material_index == names.index(light.material)
            emitted[mine] += phi / (math.pi * total)
    sources, sky = other_sources(scene)
    if not emitters and not sources:
        raise SonoluxError(f"{scene.origin}: the scene has no light that emits (add a [[lights]] "
                           "entry with power_w > 0 and a colour that is not black, or a "
                           "[daylight] sky and glazing)")
    if not emitters:
        emitters, flux, radiance = [np.zeros((0, 3, 3))], [np.zeros((0, 3))], [np.zeros((0, 3))]
        owner = [np.zeros(0, np.int32)]
    return {
        "sources": sources, "sky": sky,
        "work_plane": plane_request(scene.workplane) if scene.workplane is not None else None,
        "transmittance": np.ascontiguousarray(
            np.repeat([[m.transmittance] for m in scene.materials], 3, axis=1), float),
        "rho": np.ascontiguousarray([m.diffuse_rgb for m in scene.materials], float),
        "specular": np.array([m.specular for m in scene.materials], float),
        "roughness": np.array([m.roughness for m in scene.materials], float),
        "emitters": np.ascontiguousarray(np.concatenate(emitters), float),
        "emitter_flux": np.ascontiguousarray(np.concatenate(flux), float),
        "emitter_radiance": np.concatenate(radiance),
        "emitter_light": np.concatenate(owner),
        "emitted_radiance": emitted,
        "light_names": [light.name for light in scene.lights],
        "light_kinds": [light.kind for light in scene.lights],
        "light_power_w": np.array([light.power_w for light in scene.lights], float),
    }


def _trace(scene: Scene, arrays: dict[str, Any], options: LightOptions, particles: int,
           progress: Any = None) -> dict[str, Any]:
    optics = engine.Optics(arrays["rho"], arrays["specular"], arrays["roughness"])
    emitters = engine.Emitters(arrays["emitters"], arrays["emitter_flux"])
    settings = engine.LightSettings(
        particles=particles, first_ray=0, end_ray=particles, seed=scene.settings.seed,
        threads=scene.settings.threads, patch_size_m=float(options.patch_size_m),
        max_bounces=options.max_bounces)
    lighting = engine.Lighting(sources=arrays["sources"], transmittance=arrays["transmittance"],
                               work_plane=arrays["work_plane"])
    return engine.trace_light(scene.geometry, optics, emitters, settings, progress, lighting)


def auto_particles(scene: Scene, options: LightOptions, arrays: dict[str, Any]) -> tuple[int, str]:
    """The particle count, and why: enough that the average patch is hit
    ``options.hits_per_patch`` times (its noise is then about 1/sqrt of that). A pilot run of
    PILOT_PARTICLES particles measures how many surfaces a particle hits before roulette ends
    it (in a closed room, about 1 / (1 − the mean reflectance it meets))."""
    pilot = _trace(scene, arrays, options, PILOT_PARTICLES)
    n_patches = int(pilot["patch_area_m2"].shape[0])
    hits_each = pilot["stats"]["bounces"] / PILOT_PARTICLES
    wanted = options.hits_per_patch * n_patches / max(hits_each, 1e-9)
    n = int(min(max(math.ceil(wanted), MIN_PARTICLES), MAX_PARTICLES))
    why = (f"{n:,} particles: {options.hits_per_patch} hits on the average one of {n_patches:,} "
           f"patches ({options.patch_size_m:g} m; relative noise about "
           f"{1 / math.sqrt(options.hits_per_patch):.0%}); a pilot of {PILOT_PARTICLES:,} "
           f"particles made {hits_each:.2f} surface hits each")
    if n == MAX_PARTICLES:
        why += f" (capped at {MAX_PARTICLES:,})"
    return n, why


def bake_light(scene: Scene, options: LightOptions | None = None, *,
               progress: bool | Callable[[int, int, float], bool] = False,
               log: Callable[[str], None] | None = None, **overrides: Any) -> LightField:
    """Traces light particles from the scene's lights and stores the flux on every patch.

    ``options`` (or keyword overrides such as ``particles=200_000``, ``patch_size_m=0.1``) set
    the bake; ``progress=True`` prints a progress line, or pass ``f(done, total, elapsed_s) ->
    bool`` (False stops the bake). ``log`` receives one-line notes (particle count and why).
    """
    options = replace(options or LightOptions(), **overrides).validate()
    if not scene.lights and scene.daylight is None:
        raise SonoluxError(f"{scene.origin}: the scene has no light to bake")
    arrays = light_arrays(scene)
    if options.particles == "auto":
        particles, why = auto_particles(scene, options, arrays)
        if log:
            log(why)
    else:
        particles, why = int(options.particles), "given"
    callback = (ProgressLine(f"light {scene.name}", unit="particles") if progress is True
                else (progress or None))
    started = time.perf_counter()
    out = _trace(scene, arrays, options, particles, callback)
    seconds = time.perf_counter() - started
    stats = dict(out["stats"])
    stats.update(seconds=seconds,
                 particles_per_second=stats["particles"] / seconds if seconds > 0 else None,
                 hits_per_particle=stats["bounces"] / max(stats["particles"], 1),
                 cancelled=bool(out["cancelled"]))
    settings = {"particles": particles, "particles_reason": why, "seed": scene.settings.seed,
                "threads": scene.settings.threads, "patch_size_m": float(options.patch_size_m),
                "hits_per_patch": options.hits_per_patch, "max_bounces": options.max_bounces,
                "area_m2": scene.area_m2, "volume_m3": scene.volume_m3}
    return LightField(
        patch_size_m=float(options.patch_size_m), patch_resolution=np.asarray(out["patch_resolution"]),
        patch_offset=np.asarray(out["patch_offset"]), patch_area_m2=np.asarray(out["patch_area_m2"]),
        flux_w=np.asarray(out["flux_w"]), hits=np.asarray(out["hits"]),
        vertices_m=np.asarray(scene.vertices_m, float), triangles=np.asarray(scene.triangles, np.int64),
        material_index=np.asarray(scene.material_index, np.int32),
        surface_tag=np.asarray(scene.surface_tag, dtype=str),
        material_names=[m.name for m in scene.materials], rho=arrays["rho"],
        specular=arrays["specular"], roughness=arrays["roughness"],
        emitted_radiance=arrays["emitted_radiance"], emitter_triangles_m=arrays["emitters"],
        emitter_radiance=arrays["emitter_radiance"], emitter_light=arrays["emitter_light"],
        light_names=arrays["light_names"], light_kinds=arrays["light_kinds"],
        light_power_w=arrays["light_power_w"], settings=settings, stats=stats,
        scene_name=scene.name, scene_origin=scene.origin,
        workplane=_workplane(scene, arrays, out))


def _workplane(scene: Scene, arrays: dict[str, Any], out: dict[str, Any]) -> Any:
    """The work-plane result; daylight factors when an overcast sky is the only light."""
    if arrays["work_plane"] is None:
        return None
    sky = arrays["sky"]
    df_base = (sky.sky_horizontal_lx if sky is not None and sky.kind == "overcast"
               and not scene.lights else None)
    return workplane_result(scene.workplane, arrays["work_plane"], np.asarray(out["plane_flux_w"]),
                            np.asarray(out["plane_hits"]), MAX_LUMINOUS_EFFICACY_LM_PER_W, df_base)
