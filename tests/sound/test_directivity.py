"""Source directivity end to end: SOFA files written here, built-in patterns, scene keys.

The direct sound is the rain estimator's exact one, in a fully absorbing room (nothing else
arrives), so each receiver's energy is power × gain_b(direction) × the sphere mean of
1/(4πd²): the pattern itself, read back through file, band integration, interpolation on the
sphere and the engine's grid.
"""

from __future__ import annotations

import numpy as np
import pytest
import sofar

import sonolux
from sonolux.acoustics.bands import band_set_of
from sonolux.errors import SonoluxError
from sonolux.scene.directivity import (
    FIRST_ORDER,
    builtin_gains,
    caps_on_sphere,
    node_directions,
    theta_nodes_rad,
)
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")

BANDS_HZ = [63, 125, 250, 500, 1000, 2000, 4000, 8000]
CENTRE = np.array([5.0, 5.0, 5.0])
DISTANCE_M = 3.0
RADIUS_M = 0.1


def cardioid(f_hz, local):
    """|H|² of a cardioid: band-independent."""
    return np.broadcast_to(((1 + local[..., 0]) / 2) ** 2, np.broadcast(f_hz, local[..., 0]).shape)


def irregular(f_hz, local):
    """A measured-like |H|²: narrowing with frequency, a lobe turning with φ, a rear floor."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    order = np.log2(np.asarray(f_hz) / 15.0) / 2.0
    return (0.08 + ((1 + x) / 2) ** order) * (1 + 0.5 * y * z + 0.3 * z) * (1 + 0.2 * np.sin(
        np.asarray(f_hz) / 700.0))


def write_sofa(path, pattern, convention="FreeFieldDirectivityTF", elevations=None):
    """A SOFA file on a 5° azimuth × 5° elevation grid, 300 frequencies: spherical receiver
    positions (FreeFieldDirectivityTF) or cartesian ones 2 m away (GeneralTF)."""
    el_deg = np.arange(-90, 91, 5.0) if elevations is None else np.asarray(elevations, float)
    az, el = np.meshgrid(np.arange(0, 360, 5.0), el_deg)
    a, e = np.radians(az.ravel()), np.radians(el.ravel())
    local = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1)
    f = np.geomspace(20, 20000, 300)
    s = sofar.Sofa(convention)
    if convention == "FreeFieldDirectivityTF":
        s.delete("EmitterDescriptions")
        s.delete("Description")
        s.ReceiverPosition = np.stack([az.ravel(), el.ravel(), np.ones(az.size)], axis=1)
    else:
        s.ReceiverPosition = 2.0 * local
    s.N = f
    power = pattern(f[None, :], local[:, None, :])
    s.Data_Real = np.sqrt(power)[None]
    s.Data_Imag = np.zeros((1, az.size, len(f)))
    sofar.write_sofa(str(path), s)


def band_truth(pattern, local):
    """Exact band energies of a pattern at local directions [n, 3]: float64[n, band], each band
    normalised to mean 1 over the sphere (a 200 × 200 equal-area quadrature)."""
    def energy(dirs):
        out = []
        for lo, hi in band_set_of(BANDS_HZ).edges_hz:
            f = np.geomspace(lo, hi, 101)
            v = pattern(f[None, :], dirs[:, None, :])
            out.append(np.trapezoid(v, f, axis=1))
        return np.stack(out, axis=1)
    z = 1 - 2 * (np.arange(200) + 0.5) / 200
    phi = 2 * np.pi * (np.arange(200) + 0.5) / 200
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    s = np.sqrt(1 - zz ** 2)
    sphere = np.stack([zz, s * np.sin(pp), s * np.cos(pp)], axis=-1).reshape(-1, 3)
    return energy(local) / energy(sphere).mean(axis=0)


def receivers_around(forward, up, max_angle_deg):
    """20 directions (a Fibonacci spiral) within max_angle_deg of forward: world [20, 3] and
    local (x forward, y left, z up) [20, 3]."""
    k = np.arange(20)
    cos_max = np.cos(np.radians(max_angle_deg))
    x = 1 - (1 - cos_max) * (k + 0.5) / 20
    phi = k * np.pi * (3 - np.sqrt(5))
    s = np.sqrt(1 - x ** 2)
    local = np.stack([x, s * np.sin(phi), s * np.cos(phi)], axis=1)
    f = forward / np.linalg.norm(forward)
    u = up - f * (up @ f)
    u /= np.linalg.norm(u)
    left = np.cross(u, f)
    world = local[:, :1] * f + local[:, 1:2] * left + local[:, 2:] * u
    return world, local


def scene(directivity, positions, forward, up, base_dir=None, power_w=1.0):
    return sonolux.load_scene({
        "name": "anechoic", "settings": {"bands_hz": BANDS_HZ, "seed": 2},
        "materials": {"black": {"absorption": 1.0, "scattering": 0.0}},
        "geometry": [{"type": "shoebox", "size_m": [10, 10, 10], "materials": {"default": "black"}}],
        "sources": [{"position_m": CENTRE.tolist(), "power_w": power_w, "directivity": directivity,
                     "forward": list(forward), "up": list(up)}],
        "receivers": {"type": "points", "positions_m": positions.tolist(), "radius_m": RADIUS_M},
    }, base_dir=base_dir)


def direct_db(sc):
    field = bake(sc, rays=200, estimator="rain", air_absorption=False, max_time_s=0.05)
    per_band = np.stack([field.omni_energy(r).sum(axis=-1) for r in range(field.n_receivers)])
    spread = _ball(DISTANCE_M, RADIUS_M)
    return 10 * np.log10(per_band / (sc.sources[0].power_w * spread))


def _ball(d, r):
    """Mean of 1/(4π|x|²) over a ball of radius r centred d away, by quadrature in (ρ, cos)
    (independent of the engine's closed form)."""
    rho = np.linspace(0, r, 801)[1:]
    mu = np.linspace(-1, 1, 801)
    R, M = np.meshgrid(rho, mu, indexing="ij")
    dist2 = d ** 2 + R ** 2 - 2 * d * R * M
    f = 1 / (4 * np.pi * dist2) * 2 * np.pi * R ** 2
    return np.trapezoid(np.trapezoid(f, mu, axis=1), rho) / (4 / 3 * np.pi * r ** 3)


@pytest.mark.parametrize("pattern, max_angle_deg, convention", [
    (cardioid, 120.0, "FreeFieldDirectivityTF"), (irregular, 180.0, "FreeFieldDirectivityTF"),
    (irregular, 180.0, "GeneralTF")])
def test_sofa_direct_sound_within_0_2_db_at_20_directions_per_band(tmp_path, pattern,
                                                                   max_angle_deg, convention):
    # 0.2 dB (the bound) covers the linear interpolation on the 5° measured grid and the
    # engine's 2.5° × 5° grid; the cardioid is checked within 120° of its axis (≥ −12 dB),
    # where its energy (1 + cos θ)²/4 is smooth on that scale; nearer its null the relative
    # interpolation error grows without bound.
    write_sofa(tmp_path / "p.sofa", pattern, convention)
    forward, up = np.array([0.3, 1.0, -0.2]), np.array([0.0, 0.0, 1.0])
    world, local = receivers_around(forward, up, max_angle_deg)
    sc = scene({"sofa": "p.sofa"}, CENTRE + DISTANCE_M * world, forward, up, base_dir=tmp_path)
    got = direct_db(sc)
    want = 10 * np.log10(band_truth(pattern, local))
    print("max |error| dB per band", np.abs(got - want).max(axis=0).round(3))
    assert np.abs(got - want).max() < 0.2, np.abs(got - want).max(axis=0)


def test_a_rotated_source_rotates_the_field():
    # Turning the source (forward +x → +y, up +z) moves what receiver k heard to the receiver
    # turned with it: equal to the field's fixed-point precision.
    angles = np.radians(np.arange(0, 360, 30.0))
    ring = np.stack([np.cos(angles), np.sin(angles), 0.3 * np.ones_like(angles)], axis=1)
    a = direct_db(scene("supercardioid", CENTRE + DISTANCE_M * ring / np.linalg.norm(ring, axis=1)[:, None],
                        [1, 0, 0], [0, 0, 1]))
    b = direct_db(scene("supercardioid", CENTRE + DISTANCE_M * ring / np.linalg.norm(ring, axis=1)[:, None],
                        [0, 1, 0], [0, 0, 1]))
    assert np.allclose(np.roll(a, 3, axis=0), b, atol=1e-6)
    assert a[0, 0] - a[6, 0] > 10  # and the pattern is really directional


def test_first_order_family_directivity_factors():
    # Q = 1 / mean(g) over the sphere for g = (a + (1 − a) cos θ)², closed form
    # 1 / (a² + (1 − a)²/3): cardioid 3, hypercardioid 4 (the largest), figure-of-eight 3.
    th = np.radians(np.linspace(0, 180, 73))
    for name, q in [("cardioid", 3.0), ("hypercardioid", 4.0), ("figure-of-eight", 3.0)]:
        g = builtin_gains(name, np.array([[707.0, 1414.0]]))[:, 0, 0]
        mean = np.trapezoid(g * np.sin(th), th) / 2
        assert g[0] / mean == pytest.approx(q, rel=2e-3), name
    a = FIRST_ORDER["supercardioid"]
    assert a == pytest.approx((np.sqrt(3) - 1) / 2)


def test_dodecahedron_is_omni_at_low_and_lobed_at_high_frequency():
    # ka ≪ 1: a pulsating sphere, omni within 0.1 dB; at 8 kHz (ka ≈ 29) the 12 pistons
    # interfere: several dB between directions (ISO 3382-1 allows up to ±6 dB at 4 kHz).
    octaves = band_set_of([125, 250, 500, 1000, 2000, 4000, 8000]).edges_hz
    g = builtin_gains("dodecahedron", octaves)[..., [0, -1]]
    spread = 10 * np.log10(g.max(axis=(0, 1)) / g.min(axis=(0, 1)))
    assert spread[0] < 0.1 and spread[1] > 3, spread


def talker_db(edges_hz):
    """The talker's octave gains in dB relative to an omni source of the same power (each band
    normalised to mean 1 over the sphere by the trapezoid rule in θ): float64[theta, band]."""
    g = builtin_gains("talker", edges_hz)[:, 0, :]
    th = theta_nodes_rad()
    return 10 * np.log10(g / (np.trapezoid(g * np.sin(th)[:, None], th, axis=0) / 2))


def test_talker_is_omni_at_low_frequency_and_turns_forward_as_frequency_rises():
    # Flanagan (1960): a small piston on a 9 cm sphere. At 125 Hz (ka = 0.21) the sphere is
    # small against the wavelength: omni within 0.25 dB (measured 0.17 dB spread). The front
    # (0°) to back (180°) difference grows with every octave (measured 0.04, 0.48, 2.25, 3.22,
    # 3.97, 4.89, 6.47 dB), and at 8 kHz the front is more than 5 dB above the back.
    g = talker_db(band_set_of([125, 250, 500, 1000, 2000, 4000, 8000]).edges_hz)
    assert np.ptp(g[:, 0]) < 0.25, np.ptp(g[:, 0])
    front_back = g[0] - g[-1]
    assert np.all(np.diff(front_back) > 0), front_back
    assert front_back[-1] > 5.0, front_back
    assert np.all(g[0] > 0.0)  # the mouth axis is louder than an omni source of equal power


def test_talker_tends_to_a_baffled_point_source_at_high_frequency():
    # As ka grows the head becomes a plane baffle to the mouth: a point source on a rigid
    # plane radiates its power into the half-space, energy gain 2 (+3.01 dB) over an omni
    # source (its image in the plane; Morse & Ingard 1968, ch. 7), and nothing behind. The sphere
    # approaches this: on axis within 0.2 dB of 10 lg 2 from 2 kHz up (measured 3.06 to
    # 3.17 dB to 32 kHz), and the share of the power behind the head (θ > 90°) falls with
    # every octave (measured 0.25, 0.21, 0.17, 0.14, 0.115 at 2 to 32 kHz).
    edges = np.vstack([band_set_of([2000, 4000, 8000, 16000]).edges_hz, [[22627.0, 45255.0]]])
    g = builtin_gains("talker", edges)[:, 0, :]
    th = theta_nodes_rad()
    g = g / (np.trapezoid(g * np.sin(th)[:, None], th, axis=0) / 2)
    assert np.all(np.abs(10 * np.log10(g[0]) - 10 * np.log10(2.0)) < 0.2), 10 * np.log10(g[0])
    back = th >= np.pi / 2
    behind = np.trapezoid((g * np.sin(th)[:, None])[back], th[back], axis=0) / 2
    assert np.all(np.diff(behind) < 0) and behind[-1] < 0.15, behind


def test_talker_point_mouth_is_the_small_cap_limit():
    # The point mouth (v_n = (2n + 1)/2) is the limit of Morse & Ingard's cap coefficients
    # (P_{n−1} − P_{n+1})(cos α)/2 as α → 0, at 8 kHz where a cap's own size matters most:
    # the pattern's difference from a cap's shrinks as α² (measured 0.022 dB at α = 0.5°,
    # 0.0055 dB at 0.25°; asserted: at least 3× smaller on halving, and < 0.01 dB).
    edges = band_set_of([8000]).edges_hz
    dirs = node_directions(symmetric=True).reshape(-1, 3)
    axis = np.array([[1.0, 0.0, 0.0]])
    point = caps_on_sphere(dirs, axis, edges, 0.09, 0.0)
    spread = [np.ptp(10 * np.log10(point / caps_on_sphere(dirs, axis, edges, 0.09, a)))
              for a in (0.5, 0.25)]
    assert spread[1] < spread[0] / 3 and spread[1] < 0.01, spread


def test_talker_radiates_its_power_in_every_band():
    # The engine normalises the talker to mean gain 1 per band: the rain estimator's exact
    # direct sound on a ring of receivers at θ = 0°, 30°, …, 180° from forward equals the
    # tabulated pattern normalised here (measured 0.001 dB; allowed 0.02 dB: the receivers sit
    # on grid nodes, their spheres span ±1.9° of a pattern whose slope is < 0.2 dB/° and whose
    # curvature averages out, plus the trapezoid normalisation's error).
    deg = np.arange(0, 181, 30.0)
    th = np.radians(deg)
    forward, up = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    left = np.cross(up, forward)
    world = np.cos(th)[:, None] * forward + np.sin(th)[:, None] * left
    got = direct_db(scene("talker", CENTRE + DISTANCE_M * world, forward, up))
    want = talker_db(band_set_of(BANDS_HZ).edges_hz)[np.round(deg / 2.5).astype(int)]
    print("max |error| dB per band", np.abs(got - want).max(axis=0).round(3))
    assert np.abs(got - want).max() < 0.02, np.abs(got - want).max(axis=0)


def test_directivity_keys_are_checked(tmp_path):
    pos = CENTRE + np.array([[2.0, 0, 0]])
    with pytest.raises(SonoluxError, match="directivity.*one of"):
        scene("kardioid", pos, [1, 0, 0], [0, 0, 1])
    with pytest.raises(SonoluxError, match="up.*parallel"):
        scene("cardioid", pos, [1, 0, 0], [2, 0, 0])
    with pytest.raises(SonoluxError, match="sofa.*readable"):
        scene({"sofa": "missing.sofa"}, pos, [1, 0, 0], [0, 0, 1], base_dir=tmp_path)
    with pytest.raises(SonoluxError, match="unknown key"):
        scene({"sofa": "x.sofa", "gain": 2}, pos, [1, 0, 0], [0, 0, 1], base_dir=tmp_path)


def test_a_sofa_measured_on_one_plane_is_refused(tmp_path):
    write_sofa(tmp_path / "plane.sofa", cardioid, elevations=[0.0])
    with pytest.raises(SonoluxError, match="plane.sofa.*do not surround the source"):
        scene({"sofa": "plane.sofa"}, CENTRE + np.array([[2.0, 0, 0]]), [1, 0, 0], [0, 0, 1],
              base_dir=tmp_path)


def test_grid_directions_are_the_documented_frame():
    d = node_directions()
    assert np.allclose(d[0, 0], [1, 0, 0]) and np.allclose(d[-1, 0], [-1, 0, 0])
    assert np.allclose(d[36, 0], [0, 0, 1]) and np.allclose(d[36, 18], [0, 1, 0])  # θ 90°, φ 90°
