"""Photometric units and IES LM-63 luminaires: the parser against files written here, the
units against their definitions, and a luminaire's intensity coming back from a bake."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.light.bake import bake_light
from sonolux.light.ies import format_ies, parse_ies, read_ies
from sonolux.light.photometry import channel_flux_from_lumens, photometric

V = np.arange(0.0, 90.1, 5.0)


def pattern(gamma_deg, c_deg):
    """A test distribution in cd: 800 (0.3 + cos²γ)(1 + 0.2 cos 2C)."""
    g, c = np.radians(gamma_deg), np.radians(c_deg)
    return 800 * (0.3 + np.cos(g) ** 2) * (1 + 0.2 * np.cos(2 * c))


def test_white_watt_is_683_lumens_and_lumens_round_trip():
    assert photometric(np.ones(3)) == pytest.approx(683.0)
    for color in ([1, 1, 1], [1.0, 0.5, 0.2], [0.1, 0.9, 0.3]):
        phi = channel_flux_from_lumens(1500.0, color)
        assert photometric(phi) == pytest.approx(1500.0, rel=1e-12)
        assert phi / phi.max() == pytest.approx(np.asarray(color) / max(color))


@pytest.mark.parametrize("horizontal", [np.arange(0.0, 90.1, 15.0), np.arange(0.0, 180.1, 15.0),
                                        np.arange(90.0, 270.1, 15.0), np.arange(0.0, 360.1, 15.0)])
def test_every_symmetry_gives_the_distribution_back_at_20_angles(horizontal):
    cd = pattern(V[None, :], horizontal[:, None])
    p = parse_ies(format_ies(V, horizontal, cd))
    rng = np.random.default_rng(1)
    # 20 directions on the grid's nodes all round the circle: the mirrored table must hold
    # the pattern there exactly (to the 6 digits written).
    gamma = rng.choice(V, 20)
    c = rng.choice(np.arange(0.0, 360.0, 15.0), 20)
    assert p.intensity_cd(gamma, c) == pytest.approx(pattern(gamma, c), rel=1e-5)


def test_axially_symmetric_flux_and_units():
    cd = 1000 * np.cos(np.radians(V))[None, :]
    text = format_ies(V, np.array([0.0]), cd).replace("1 -1 1 19 1 1 2", "1 -1 2 19 1 1 2")
    p = parse_ies(text)
    # Multiplier 2; ∫ 2000 cos γ dω over the lower hemisphere = 2000 π (trapezoid-free: the
    # interpolated table's integral differs by the chord error of cos over 5° steps, < 0.1 %).
    assert p.flux_lm() == pytest.approx(2000 * math.pi, rel=1e-3)


@pytest.mark.parametrize("change, message", [
    (lambda t: t.replace("TILT=NONE", "TILT=lamp.tlt"), "TILT="),
    (lambda t: t.replace(" 1 2 0 0 0", " 2 2 0 0 0"), "photometric type"),
    (lambda t: t.rsplit("\n", 2)[0], "ends before"),
    (lambda t: t.replace("1000", "-1000", 1), "negative"),
    (lambda t: t.replace("TILT=NONE\n", ""), "TILT"),
])
def test_malformed_files_are_named(change, message):
    cd = 1000 * np.cos(np.radians(V))[None, :]
    text = change(format_ies(V, np.array([0.0]), cd))
    with pytest.raises(SonoluxError, match=message):
        parse_ies(text, "lamp.ies")


def luminaire_scene(path, **light):
    return sonolux.load_scene({
        "name": "ies-test",
        "materials": {"black": {"absorption": 0.5, "diffuse_rgb": [0, 0, 0]}},
        "geometry": [{"type": "shoebox", "size_m": [10, 10, 3], "materials": {"default": "black"}}],
        "lights": [{"type": "ies", "file": str(path), "position_m": [5, 5, 2.0], **light}],
        "workplane": {"height_m": 0.8, "spacing_m": 0.5},
    })


def test_file_is_read_relative_and_validated(tmp_path):
    with pytest.raises(SonoluxError, match="lights\\[0\\].file"):
        luminaire_scene(tmp_path / "missing.ies")


def test_a_baked_luminaire_gives_its_intensity_back_at_20_angles(core, tmp_path):
    # The luminaire 1.2 m above the work plane of a black room: every cell's illuminance is the
    # mean of E = I(γ, C) cos γ / d² over the cell (CIE 171:2006 §5.2, a point source over a
    # plane), here by a 16 × 16 midpoint rule of the file's distribution. 20 cells from γ = 0
    # to 57°, within 1 %; 3·10⁷ particles leave the dimmest of them a noise of about 0.3 %.
    horizontal = np.arange(0.0, 360.1, 15.0)
    path = tmp_path / "lum.ies"
    path.write_text(format_ies(V, horizontal, pattern(V[None, :], horizontal[:, None])))
    scene = luminaire_scene(path, flux_lm=3000.0)
    field = bake_light(scene, particles=30_000_000, patch_size_m=2.0)
    wp = field.workplane
    p = read_ies(path)
    scale = 3000.0 / p.flux_lm()
    d = 2.0 - 0.8
    checked = 0
    for k in range(wp.illuminance_lx.size):
        i, j = wp.grid_index[k]
        if not (0 <= i <= 4 and 0 <= j <= 3):
            continue
        u = (np.arange(16) + 0.5) / 16 - 0.5
        x = (i + u[:, None]) * 0.5 + 0 * u[None, :]
        y = (j + u[None, :]) * 0.5 + 0 * u[:, None]
        r2 = x * x + y * y + d * d
        gamma = np.degrees(np.arccos(d / np.sqrt(r2)))
        c = np.degrees(np.arctan2(y, x))
        exact = float(np.mean(scale * p.intensity_cd(gamma, c) * (d / np.sqrt(r2)) / r2))
        assert wp.illuminance_lx[k] == pytest.approx(exact, rel=0.01), (i, j)
        checked += 1
    assert checked == 20
    # Photometric bookkeeping: the emitted flux is the luminaire's 3000 lm.
    assert photometric(np.asarray(field.stats["flux_emitted_w"])) == pytest.approx(3000, rel=2e-3)
