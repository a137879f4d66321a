"""What a scene contains and what theory expects of it, before any tracing (``sonolux check``).

:func:`summarize` turns a loaded :class:`~sonolux.scene.Scene` into a plain dict (the
``--json`` output); :func:`format_summary` renders that dict for people. :func:`theory` is the
part a bake stores in its field file for the analysis: reverberation times of Sabine and
Eyring per simulated band, including the absorption of the scene's air (ISO 9613-1 at the
scene's temperature, humidity and pressure). A time that is infinite (nothing absorbs) is
``None`` in the dict (``null`` in JSON).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sonolux.acoustics.bands import BandSet
from sonolux.acoustics.theory import air_energy_attenuation_per_m, eyring_t60, sabine_t60
from sonolux.scene.schema import Air, Scene


def _finite_or_none(values: np.ndarray) -> list[float | None]:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(values, dtype=float)]


def _round(v: np.ndarray | float, digits: int = 9) -> Any:
    if isinstance(v, np.ndarray):
        return [round(float(x), digits) for x in v]
    return round(float(v), digits)


def band_air_attenuation_per_m(bands: BandSet, air: Air) -> np.ndarray:
    """float64[band]: the air's energy attenuation m (1/m) of each band, the pure-tone value at
    the band's exact mid-band frequency, as ISO 9613-1:1993, clause 8, computes the attenuation
    of a fractional-octave band of wideband sound. Within a band the pure-tone value grows about
    as f² (from 0.5 to 2 times the centre's across an octave); one band keeps one exponential,
    and a third-octave bake summed into octaves (``acoustics.bands.octave_energies``) integrates
    the spectrum over the octave in three steps instead (docs/bands.md)."""
    return np.asarray(air_energy_attenuation_per_m(bands.exact_hz, air.temperature_c,
                                                   air.humidity_percent, air.pressure_kpa),
                      dtype=np.float64)


def theory(scene: Scene) -> dict[str, Any]:
    """The room's measures and the reverberation that theory expects, per simulated band:
    volume_m3, area_m2, mean_free_path_m (4V/S, None without surfaces), bands_hz,
    mean_absorption, air_attenuation_per_m, speed_of_sound_m_s, sabine_t60_s and eyring_t60_s
    (None where infinite); min_absorption (the least absorbing surface's coefficient per band)
    and max_chord_m (the bounding box's diagonal, no path between two reflections is longer):
    the slowest decay the room allows (``analysis.decay.slowest_decay_time_s``). JSON-ready;
    the bake writes it into the field file."""
    settings, air = scene.settings, scene.settings.air
    volume_m3, area_m2 = scene.volume_m3, scene.area_m2
    by_material = scene.area_by_material_m2()
    bands = settings.band_set
    # Absorption area per band: sum over materials of area x absorption coefficient.
    absorption_area = np.zeros(bands.n_bands)
    min_absorption = np.ones(bands.n_bands)
    for m in scene.materials:
        alpha = m.absorption_in(bands)
        absorption_area += by_material[m.name] * alpha
        if by_material[m.name] > 0:
            min_absorption = np.minimum(min_absorption, alpha)
    corners = (scene.vertices_m.min(axis=0), scene.vertices_m.max(axis=0)) \
        if scene.vertices_m.size else (np.zeros(3), np.zeros(3))
    mean_absorption = absorption_area / area_m2 if area_m2 > 0 else np.zeros_like(absorption_area)
    m_air = band_air_attenuation_per_m(bands, air)
    c = settings.speed_of_sound_m_s
    return {
        "volume_m3": volume_m3,
        "area_m2": area_m2,
        "mean_free_path_m": 4.0 * volume_m3 / area_m2 if area_m2 > 0 else None,
        "bands_hz": list(settings.bands_hz),
        "bands": bands.kind,
        "mean_absorption": _round(mean_absorption),
        "air_attenuation_per_m": _round(m_air, 12),
        "min_absorption": _round(min_absorption),
        "max_chord_m": float(np.linalg.norm(corners[1] - corners[0])),
        "speed_of_sound_m_s": c,
        "sabine_t60_s": _finite_or_none(sabine_t60(volume_m3, absorption_area, m_air, c)),
        "eyring_t60_s": _finite_or_none(eyring_t60(volume_m3, area_m2, mean_absorption, m_air, c)),
    }


def summarize(scene: Scene) -> dict[str, Any]:
    """The check's content as a JSON-ready dict (see the module docstring)."""
    air = scene.settings.air
    expected = theory(scene)
    r = scene.receivers
    report = scene.mesh_report
    return {
        "name": scene.name,
        "origin": scene.origin,
        "triangles": int(scene.triangles.shape[0]),
        "volume_m3": expected["volume_m3"],
        "area_m2": expected["area_m2"],
        "area_by_material_m2": scene.area_by_material_m2(),
        "mean_free_path_m": expected["mean_free_path_m"],
        "bbox_min_m": report["bbox_min"].tolist(),
        "bbox_max_m": report["bbox_max"].tolist(),
        "bands_hz": expected["bands_hz"],
        "bands": expected["bands"],
        "mean_absorption": expected["mean_absorption"],
        "sabine_t60_s": expected["sabine_t60_s"],
        "eyring_t60_s": expected["eyring_t60_s"],
        "air": {"temperature_c": air.temperature_c, "humidity_percent": air.humidity_percent,
                "pressure_kpa": air.pressure_kpa,
                "speed_of_sound_m_s": expected["speed_of_sound_m_s"],
                "attenuation_per_m": expected["air_attenuation_per_m"],
                "included_in_t60": True},
        "receivers": {"kind": r.kind, "kept": r.count, "candidates": r.candidates,
                      "dropped_outside": r.dropped_outside,
                      "dropped_inside_obstacle": r.dropped_inside_obstacle,
                      "dropped_near_surface": r.dropped_near_surface, "radius_m": r.radius_m,
                      "height_m": r.height_m, "spacing_m": r.spacing_m},
        "sources": [{"name": s.name, "position_m": s.position_m.tolist(), "power_w": s.power_w,
                     "directivity": s.directivity,
                     **({"cone_half_angle_deg": s.cone_half_angle_deg,
                         "axis": s.axis.tolist()} if s.directivity == "cone" else {}),
                     **({"forward": s.forward.tolist(), "up": s.up.tolist()}
                        if s.forward is not None else {}),
                     **({"sofa": str(s.sofa.path)} if s.sofa is not None else {})}
                    for s in scene.sources],
        "lights": [{"name": li.name, "type": li.kind, "power_w": li.power_w,
                    "area_m2": li.area_m2, "triangles": int(li.triangles_m.shape[0]),
                    "color_rgb": li.color_rgb.tolist()} for li in scene.lights],
        "daylight": daylight_summary(scene),
        "warnings": list(scene.warnings),
    }


def daylight_summary(scene: Scene) -> dict[str, Any]:
    """Glazing (triangles of a material with transmittance > 0), floor and the
    window-to-floor ratio. The floor is every triangle facing up (normal within 8° of +z)
    within 1 cm of the scene's lowest point; the work plane's cells, when the scene has one."""
    tris = scene.vertices_m[scene.triangles]
    cross = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    nz = np.divide(cross[:, 2], 2 * area, out=np.zeros_like(area), where=area > 0)
    tau = np.array([m.transmittance for m in scene.materials])[scene.material_index]
    floor = (nz > math.cos(math.radians(8))) & (tris[:, :, 2].max(axis=1)
                                                 <= scene.vertices_m[:, 2].min() + 0.01)
    glazing_m2, floor_m2 = float(area[tau > 0].sum()), float(area[floor & (tau == 0)].sum())
    d = scene.daylight
    w = scene.workplane
    return {"glazing_area_m2": glazing_m2, "floor_area_m2": floor_m2,
            "window_to_floor_ratio": glazing_m2 / floor_m2 if floor_m2 > 0 else None,
            "sky": None if d is None else d.sky,
            "workplane": None if w is None else {
                "height_m": w.height_m, "spacing_m": w.spacing_m,
                "cells": int(w.positions_m.shape[0])}}


def _xyz(v: list[float]) -> str:
    return "(" + ", ".join(f"{x:g}" for x in v) + ")"


def _seconds(v: float | None) -> str:
    return "inf" if v is None else f"{v:.2f}"


def format_summary(s: dict[str, Any]) -> str:
    """The summary for a terminal: one topic per block, numbers with their units."""
    out = [f"scene {s['name']}  ({s['origin']})"]
    mfp = s["mean_free_path_m"]
    out.append(f"  geometry    {s['triangles']} triangles, volume {s['volume_m3']:.4g} m³, "
               f"surface {s['area_m2']:.4g} m², mean free path 4V/S = "
               f"{'-' if mfp is None else f'{mfp:.3g} m'}")
    out.append(f"              bounding box {_xyz(s['bbox_min_m'])} to {_xyz(s['bbox_max_m'])} m")
    width = max(len(n) for n in s["area_by_material_m2"])
    for i, (name, area) in enumerate(s["area_by_material_m2"].items()):
        out.append(f"  {'materials' if i == 0 else '':<10}  {name:<{width}}  {area:9.4g} m²")
    if not s["sources"]:
        out.append("  sources     none")
    for i, src in enumerate(s["sources"]):
        kind = (f"cone {src['cone_half_angle_deg']:g}° around {_xyz(src['axis'])}"
                if src["directivity"] == "cone" else src.get("sofa", src["directivity"]))
        if "forward" in src:
            kind += f" facing {_xyz(src['forward'])}, up {_xyz(src['up'])}"
        out.append(f"  {'sources' if i == 0 else '':<10}  {src['name']}: {kind}, "
                   f"{src['power_w']:g} W at {_xyz(src['position_m'])} m")
    if not s["lights"]:
        out.append("  lights      none")
    for i, li in enumerate(s["lights"]):
        out.append(f"  {'lights' if i == 0 else '':<10}  {li['name']}: {li['type']}, "
                   f"{li['power_w']:g} W over {li['area_m2']:.4g} m² ({li['triangles']} "
                   "triangles)")
    r = s["receivers"]
    layout = (f"grid every {r['spacing_m']:g} m at {r['height_m']:g} m" if r["kind"] == "grid"
              else "points")
    out.append(f"  receivers   {layout}, radius {r['radius_m']:g} m: {r['kept']} kept of "
               f"{r['candidates']}; dropped {r['dropped_outside']} outside the room, "
               f"{r['dropped_inside_obstacle']} inside obstacles, {r['dropped_near_surface']} "
               "nearer to a surface than their radius")
    a = s["air"]
    out.append(f"  reverberation, with air absorption at {a['temperature_c']:g} °C, "
               f"{a['humidity_percent']:g} % RH, {a['pressure_kpa']:g} kPa "
               f"(c = {a['speed_of_sound_m_s']:.1f} m/s):")
    rows = [("band Hz", [f"{b:g}" for b in s["bands_hz"]]),
            ("mean absorption", [f"{x:.3f}" for x in s["mean_absorption"]]),
            ("air m (1/km)", [f"{1000 * x:.2f}" for x in a["attenuation_per_m"]]),
            ("Sabine T60 s", [_seconds(x) for x in s["sabine_t60_s"]]),
            ("Eyring T60 s", [_seconds(x) for x in s["eyring_t60_s"]])]
    for label, cells in rows:
        out.append(f"    {label:<16}" + "".join(f"{c:>8}" for c in cells))
    dl = s["daylight"]
    wfr = dl["window_to_floor_ratio"]
    out.append(f"  daylight    glazing {dl['glazing_area_m2']:.4g} m², floor "
               f"{dl['floor_area_m2']:.4g} m², window-to-floor ratio "
               f"{'-' if wfr is None else f'{wfr:.1%}'}; sky: {dl['sky'] or 'none'}")
    if dl["workplane"]:
        wp = dl["workplane"]
        out.append(f"  work plane  {wp['cells']} cells every {wp['spacing_m']:.3g} m at "
                   f"{wp['height_m']:g} m")
    if s["warnings"]:
        out.append(f"  warnings    {len(s['warnings'])}:")
        out += [f"    - {w}" for w in s["warnings"]]
    else:
        out.append("  warnings    none")
    return "\n".join(out)
