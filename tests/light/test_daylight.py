"""Daylight: the sun's position against NREL's SPA example, the CIE skies against their closed
forms, and a bake of the overcast sky through glazing against the daylight factor computed by
an independent area integral (CIE 171:2006 §5.9–5.13 style: an opening in an otherwise black
room, so that only the sky component is present)."""

from __future__ import annotations

import math
from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

import sonolux
from sonolux.errors import SceneError
from sonolux.light.bake import bake_light
from sonolux.light.daylight import (
    _horizontal,
    clear_relative,
    make_sky,
    overcast_relative,
    sun_direction,
    sun_position,
)
from sonolux.scene.summary import summarize


def test_sun_position_matches_the_spa_worked_example():
    # Reda & Andreas (NREL/TP-560-34302, 2004), Table A5.1: 17 October 2003, 12:30:30 local
    # time (UTC−7), 39.742476° N, 105.1786° W: topocentric zenith 50.11162°, azimuth
    # 194.34024° (from north, eastward). The NOAA equations are good to about 0.01°.
    s = sun_position(datetime(2003, 10, 17, 12, 30, 30, tzinfo=timezone(timedelta(hours=-7))),
                     39.742476, -105.1786)
    assert s.zenith_deg == pytest.approx(50.11162, abs=0.02)
    assert s.azimuth_deg == pytest.approx(194.34024, abs=0.02)
    d = sun_direction(s)
    assert np.linalg.norm(d) == pytest.approx(1.0)
    assert d[1] < 0 and d[0] < 0  # south-south-west, sonolux's +y north and +x east


def test_overcast_sky_horizontal_illuminance_is_seven_ninths_pi_lz():
    # E_h = ∫ Lz (1 + 2 cos Z)/3 cos Z dω = 7π Lz / 9; the table's numerical integral agrees.
    sky = make_sky("overcast", sky_horizontal_lx=10_000.0)
    lz = sky.values[0, -1]
    assert lz == pytest.approx(10_000.0 / (7 * math.pi / 9), rel=1e-12)
    assert _horizontal(sky.values / lz, sky.theta_rad, sky.phi_rad) * lz == pytest.approx(
        10_000.0, rel=1e-4)
    assert overcast_relative(0.0) == pytest.approx(1 / 3)


def test_clear_sky_is_relative_to_its_zenith_and_brightest_near_the_sun():
    sun = np.array([0.0, -math.cos(math.radians(40)), math.sin(math.radians(40))])
    zen = math.radians(50)
    assert clear_relative(1.0, sun[2], zen) == pytest.approx(1.0)
    # Near the sun brighter than at the zenith; 90° from it, at the same altitude, darker.
    near = clear_relative(math.cos(math.radians(52)), math.cos(math.radians(2)), zen)
    side = clear_relative(math.cos(zen), math.cos(math.radians(90)), zen)
    assert near > 5 and side < near
    sky = make_sky("clear", sky_horizontal_lx=15_000, sun=sun, sun_normal_lx=60_000)
    assert _horizontal(sky.values, sky.theta_rad, sky.phi_rad) == pytest.approx(15_000, rel=1e-9)
    # Ground: ρ E_global / π.
    assert sky.ground_luminance_cd_m2 == pytest.approx(
        0.2 * (15_000 + 60_000 * sun[2]) / math.pi)


def skylit_room(tau=0.8, **daylight):
    """A 4 × 4 × 3 m black room whose whole ceiling is glazing of transmittance ``tau``."""
    return sonolux.load_scene({
        "name": "skylight",
        "materials": {"black": {"absorption": 0.5, "diffuse_rgb": [0, 0, 0]},
                      "glass": {"absorption": 0.03, "diffuse_rgb": [0.08, 0.08, 0.08],
                                "transmittance": tau}},
        "geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                      "materials": {"default": "black", "ceiling": "glass"}}],
        "daylight": {"sky": "overcast", **daylight},
        "workplane": {"height_m": 0.8, "spacing_m": 1.0},
    })


def overcast_under_rectangle(px, py, half=2.0, h=2.2, steps=240):
    """E / Lz at (px, py) under a horizontal rectangle [−half, half]², h above: the area integral
    ∫∫ (1 + 2 cos Z)/3 · cos² Z / r² dA with cos Z = h / r (midpoint rule)."""
    u = (np.arange(steps) + 0.5) / steps * 2 * half - half
    x, y = np.meshgrid(u - px, u - py)
    r2 = x * x + y * y + h * h
    cos = h / np.sqrt(r2)
    return float(np.sum((1 + 2 * cos) / 3 * cos * cos / r2) * (2 * half / steps) ** 2)


def test_daylight_factor_through_a_skylight_matches_the_area_integral(core):
    # Sky component only (black room): DF = τ E(cell) / E_h, E by the area integral over the
    # opening averaged over the 1 m cell (5 × 5 points), E_h = 7π Lz / 9, in each of the 9
    # cells. The glazing reflects 8 % back out of the room (the black room returns nothing).
    # Measured spread of the cells at 2·10⁶ particles: 0.4 % (max 0.85 %); at 8·10⁶ here about
    # 0.2 %, so the 1 % tolerance holds by about 5 σ.
    scene = skylit_room(tau=0.8)
    field = bake_light(scene, particles=8_000_000, patch_size_m=1.0)
    wp = field.workplane
    assert wp.daylight_factor_percent is not None and wp.illuminance_lx.size == 9
    for k in range(9):
        cx, cy = wp.positions_m[k, :2] - 2.0
        pts = (np.arange(5) + 0.5) / 5 - 0.5
        e_over_lz = np.mean([overcast_under_rectangle(cx + a, cy + b) for a in pts for b in pts])
        df = 100 * 0.8 * e_over_lz / (7 * math.pi / 9)
        assert wp.daylight_factor_percent[k] == pytest.approx(df, rel=0.01), k
    s = wp.summary()
    assert s["uniformity_min_over_mean"] == pytest.approx(s["min_lx"] / s["mean_lx"])
    # Export per cell.
    csv_text = wp.to_csv().splitlines()
    assert csv_text[0].startswith("i,j,x_m,y_m,z_m,illuminance_lx,daylight_factor_percent")
    assert len(csv_text) == 10


def test_check_reports_glazing_and_window_to_floor_ratio(core):
    d = summarize(skylit_room())["daylight"]
    assert d["glazing_area_m2"] == pytest.approx(16.0)
    assert d["floor_area_m2"] == pytest.approx(16.0)
    assert d["window_to_floor_ratio"] == pytest.approx(1.0)
    assert d["workplane"]["cells"] == 9


def test_daylight_inputs_are_validated(core):
    with pytest.raises(SceneError, match="daylight.date_time"):
        sonolux.load_scene({
            "geometry": [{"type": "shoebox", "size_m": [2, 2, 2],
                          "materials": {"default": "concrete"}}],
            "daylight": {"sky": "clear", "date_time": "noon", "latitude_deg": 50,
                         "longitude_deg": 0, "sky_horizontal_lx": 1e4, "sun_normal_lx": 5e4}})
    with pytest.raises(SceneError, match="sun_normal_lx"):
        skylit_room(sun_normal_lx=5e4)
    with pytest.raises(SceneError, match="transmittance"):
        sonolux.load_scene({
            "materials": {"g": {"absorption": 0.1, "diffuse_rgb": [0.5, 0.5, 0.5],
                                "transmittance": 0.6}},
            "geometry": [{"type": "shoebox", "size_m": [2, 2, 2], "materials": {"default": "g"}}]})


def test_clear_sky_and_sun_bake(core):
    # The sun through the skylight: the directly sunlit cells read τ E_n cos Z_s more than the
    # shaded ones get from the sky alone; checked on the sum over the work plane (the beam
    # through a 4 × 4 m opening at 2.2 m above the plane lands partly on the walls).
    when = datetime(2024, 6, 21, 12, 0, tzinfo=timezone.utc)
    scene = skylit_room(tau=0.8)
    clear = sonolux.load_scene({
        "name": "sunlit", "materials": {
            "black": {"absorption": 0.5, "diffuse_rgb": [0, 0, 0]},
            "glass": {"absorption": 0.03, "diffuse_rgb": [0.08] * 3, "transmittance": 0.8}},
        "geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                      "materials": {"default": "black", "ceiling": "glass"}}],
        "daylight": {"sky": "clear", "date_time": when, "latitude_deg": 0.0,
                     "longitude_deg": 0.0, "sky_horizontal_lx": 12_000.0,
                     "sun_normal_lx": 80_000.0},
        "workplane": {"height_m": 0.8, "spacing_m": 1.0}})
    field = bake_light(clear, particles=400_000, patch_size_m=1.0)
    wp = field.workplane
    assert wp.daylight_factor_percent is None
    # At noon on the equator in June the sun is 23.4° from the zenith, to the north.
    s = sun_position(when, 0.0, 0.0)
    assert s.zenith_deg == pytest.approx(23.4, abs=0.3)
    assert wp.illuminance_lx.max() > 0.8 * 80_000 * math.cos(math.radians(s.zenith_deg)) * 0.9
    assert scene.daylight.sky == "overcast"
