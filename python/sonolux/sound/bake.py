"""Baking a sound field: the scene's arrays go to the Rust tracer, a :class:`SoundField` comes
back. Also the automatic ray count.

One ray, from the scene file to the field: ``load_scene`` resolves geometry, materials, sources
and receivers into arrays; :func:`bake` picks the bands' absorption, scattering and the air's
attenuation (ISO 9613-1), puts them in the engine's settings objects and hands them to
:func:`sonolux.engine.trace_sound`, which emits, traces and deposits (see
``crates/sonolux-core/src/sound``); the energies come back as
float32[receiver, direction, band, time] in J/m². The field also keeps what theory expects of
the room (:func:`sonolux.scene.summary.theory`), for the analysis.

A scene with an ``[early]`` table is baked as a hybrid (:mod:`sonolux.sound.early`): the core's
image sources and edge diffraction give the early arrivals exactly, the tracer leaves out the
specular-only paths they count, and the arrivals are added to the field in their bins.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.acoustics.theory import air_energy_attenuation_per_m, sabine_t60
from sonolux.errors import SonoluxError
from sonolux.memory import budget_bytes
from sonolux.progress import ProgressLine
from sonolux.scene.directivity import builtin_gains
from sonolux.scene.schema import Scene
from sonolux.scene.sofa_directivity import sofa_gains
from sonolux.scene.summary import theory
from sonolux.sound import early as early_sound
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions

#: Sphere crossings wanted per receiver in each late time bin, for the automatic ray count.
HITS_PER_LATE_BIN = 20
#: The paper's budget, 3 million rays for the 6 m room and 48 million for the 24 m room, is
#: this constant × reflections to the energy drop × (largest dimension)².
PAPER_RULE_CONSTANT = 3e6 / (65 * 6.0**2)


def band_arrays(scene: Scene) -> dict[str, np.ndarray]:
    """Absorption and scattering float64[materials, bands] and the air's energy attenuation
    float64[bands] (1/m) for the scene's simulated bands."""
    idx = np.asarray(scene.settings.band_indices)
    air = scene.settings.air
    return {
        "absorption": np.ascontiguousarray([m.absorption[idx] for m in scene.materials], float),
        "scattering": np.ascontiguousarray([m.scattering[idx] for m in scene.materials], float),
        "air": np.asarray(air_energy_attenuation_per_m(np.asarray(scene.settings.bands_hz, float),
                                                       air.temperature_c, air.humidity_percent,
                                                       air.pressure_kpa), float),
    }


def _absorption_area(scene: Scene, absorption: np.ndarray) -> np.ndarray:
    by_material = scene.area_by_material_m2()
    return sum(by_material[m.name] * absorption[i] for i, m in enumerate(scene.materials))


def auto_max_time(scene: Scene, arrays: dict[str, np.ndarray]) -> float:
    """1.5 × the longest Sabine T60 (air included) + the time to cross the room's box."""
    if scene.settings.max_time_s > 0:
        return scene.settings.max_time_s
    t60 = sabine_t60(scene.volume_m3, _absorption_area(scene, arrays["absorption"]), arrays["air"],
                     scene.settings.speed_of_sound_m_s)
    diagonal = float(np.linalg.norm(scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"]))
    t = 1.5 * float(np.max(t60)) + diagonal / scene.settings.speed_of_sound_m_s
    return min(t, 60.0) if math.isfinite(t) else 60.0


def auto_rays(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray]) -> tuple[int, str]:
    """The ray count per source, and why.

    A receiver sphere of radius r in a room of volume V is crossed by N c π r² Δt / V of N
    rays in a late bin of width Δt (rays fill the room evenly by then), so asking for
    HITS_PER_LATE_BIN crossings gives N. The paper's own rule (reflections to the energy drop
    × the largest dimension², scaled to its 3 and 48 million rays) is printed beside it.
    """
    c = scene.settings.speed_of_sound_m_s
    r = scene.receivers.radius_m
    n_hits = HITS_PER_LATE_BIN * scene.volume_m3 / (c * math.pi * r * r * options.late_bin_s)
    mean_alpha = float(np.mean(_absorption_area(scene, arrays["absorption"]))) / scene.area_m2
    reflections = scene.settings.energy_drop_db / (-10 * math.log10(max(1 - mean_alpha, 1e-12)))
    size = float(np.max(scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"]))
    n_paper = PAPER_RULE_CONSTANT * reflections * size**2
    n = int(min(max(n_hits, 1000), 50_000_000))
    bin_ms = options.late_bin_s * 1e3
    why = (f"{n:,} rays: {HITS_PER_LATE_BIN} sphere crossings per receiver per {bin_ms:g} ms "
           f"late bin (V = {scene.volume_m3:.4g} m³, r = {r:g} m); the paper's rule "
           f"({reflections:.0f} reflections to -{scene.settings.energy_drop_db:g} dB × "
           f"{size:g} m²) would take {n_paper:,.0f}")
    return n, why


def bake(scene: Scene, options: SoundOptions | None = None, *,
         progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, **overrides: Any) -> SoundField:
    """Traces the scene's sound sources into a sound field over its receivers.

    ``options`` (or keyword overrides such as ``rays=100_000``, ``estimator="paper"``) set the
    bake; ``progress=True`` prints a progress line, or pass ``f(done, total, elapsed_s) ->
    bool`` (False stops the bake). ``log`` receives one-line notes (ray count and why).
    """
    options = replace(options or SoundOptions(), **overrides).validate()
    if not scene.sources:
        raise SonoluxError(f"{scene.origin}: the scene has no sound source to bake")
    if scene.receivers.count == 0:
        raise SonoluxError(f"{scene.origin}: the scene has no receiver left to bake into")
    arrays = band_arrays(scene)
    if not options.air_absorption:
        arrays["air"] = np.zeros_like(arrays["air"])
    if options.rays == "auto":
        rays, why = auto_rays(scene, options, arrays)
        if log:
            log(why)
    else:
        rays = int(options.rays)
    first, end = options.ray_range or (0, rays)
    if end > rays:
        raise SonoluxError(f"ray_range {options.ray_range} goes past the bake's {rays} rays")
    max_time_s = options.max_time_s or auto_max_time(scene, arrays)
    src = scene.sources
    callback = ProgressLine(f"sound {scene.name}") if progress is True else (progress or None)
    settings = engine.SoundSettings(
        rays=rays, first_ray=first, end_ray=end, seed=scene.settings.seed,
        threads=scene.settings.threads, estimator=options.estimator,
        speed_of_sound_m_s=scene.settings.speed_of_sound_m_s,
        air_attenuation_per_m=arrays["air"].tolist(), energy_drop_db=scene.settings.energy_drop_db,
        max_time_s=max_time_s, sample_rate_hz=float(scene.settings.sample_rate_hz),
        early_s=options.early_s, late_bin_s=options.late_bin_s,
        azimuth_bands=options.azimuth_bands, elevation_bands=options.elevation_bands,
        max_field_bytes=options.max_field_bytes or budget_bytes(),
        keep_counts=options.ray_range is not None)
    acoustics = engine.Acoustics(arrays["absorption"], arrays["scattering"])
    bands_hz = np.asarray(scene.settings.bands_hz, float)
    sources = [engine.SoundSource(tuple(s.position_m), s.power_w, _directivity(s, bands_hz))
               for s in src]
    receivers = engine.Receivers(np.ascontiguousarray(scene.receivers.positions_m, float),
                                 scene.receivers.radius_m)
    started = time.perf_counter()
    early, arrivals = None, None
    if scene.early is not None:
        early = early_sound.early_settings(scene, scene.early, arrays["air"], log)
        found = engine.early_arrivals(scene.geometry, acoustics, sources, receivers, early,
                                      settings)
        arrivals = early_sound.arrival_table(found)
        early_stats = dict(found["stats"], seconds=time.perf_counter() - started)
    out = engine.trace_sound(scene.geometry, acoustics, sources, receivers, settings, callback,
                             early)
    seconds = time.perf_counter() - started
    stats = dict(out["stats"])
    stats.update(seconds=seconds, rays_per_second=stats["rays"] / seconds if seconds > 0 else None,
                 segments_per_second=stats["segments"] / seconds if seconds > 0 else None,
                 mean_free_path_theory_m=4 * scene.volume_m3 / scene.area_m2,
                 saturated=bool(out["saturated"]), cancelled=bool(out["cancelled"]))
    energy = out["energy"]
    if arrivals is not None:
        stats["early"] = early_stats
        energy = early_sound.add_arrivals(energy, arrivals)
    if out["saturated"]:
        raise SonoluxError("the sound field overflowed its fixed-point range (a bug: please report "
                           "the scene)")
    record = {
        "rays": rays, "ray_range": [first, end], "estimator": options.estimator,
        "seed": scene.settings.seed, "speed_of_sound_m_s": scene.settings.speed_of_sound_m_s,
        "sample_rate_hz": scene.settings.sample_rate_hz, "energy_drop_db": scene.settings.energy_drop_db,
        "max_time_s": max_time_s, "early_bins": int(out["early_bins"]),
        "late_bin_s": options.late_bin_s, "azimuth_bands": options.azimuth_bands,
        "elevation_bands": options.elevation_bands, "air_attenuation_per_m": arrays["air"].tolist(),
        "volume_m3": scene.volume_m3, "area_m2": scene.area_m2,
        "early": None if early is None else {
            "max_order": early.max_order, "transition_s": early.max_time_s,
            "diffraction": scene.early.diffraction, "level_of_detail": scene.early.level_of_detail,
            "diffraction_piece_m": scene.early.diffraction_piece_m},
        "air": {"temperature_c": scene.settings.air.temperature_c,
                "humidity_percent": scene.settings.air.humidity_percent,
                "pressure_kpa": scene.settings.air.pressure_kpa},
    }
    return SoundField(
        energy=energy, bin_start_s=out["bin_start_s"], bin_width_s=out["bin_width_s"],
        bands_hz=np.asarray(scene.settings.bands_hz, float),
        positions_m=np.asarray(scene.receivers.positions_m, float), radius_m=scene.receivers.radius_m,
        grid_index=scene.receivers.grid_index, grid_spacing_m=scene.receivers.spacing_m,
        source_positions_m=np.array([s.position_m for s in src], float),
        source_powers_w=np.array([s.power_w for s in src], float),
        settings=record, stats=stats, scene_name=scene.name, scene_origin=scene.origin,
        counts=out.get("counts"), quantum=float(out["quantum"]), theory=theory(scene),
        early=arrivals)


def _directivity(source: Any, bands_hz: np.ndarray) -> Any:
    """The engine's directivity of a scene's source, tabulated for the bake's bands."""
    if source.directivity == "cone":
        return engine.Directivity.cone(tuple(float(v) for v in source.axis),
                                       float(source.cone_half_angle_deg))
    if source.directivity == "omni":
        return engine.Directivity.omni()
    gains = (sofa_gains(source.sofa, bands_hz) if source.directivity == "sofa"
             else builtin_gains(source.directivity, bands_hz))
    return engine.Directivity.pattern(np.ascontiguousarray(gains, float),
                                      tuple(source.forward), tuple(source.up))
