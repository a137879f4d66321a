"""STI with the source's own directivity: a talker facing the listener or away.

The field carries the source's directivity (direct sound and reflections); STI refers the
talker's level to its own axis (IEC 60268-16:2020 A.2.3: the speech level 1 m in front of the
mouth), so a directional talker is as loud on its axis as an omnidirectional one of the same
speech level, and quieter elsewhere. In the room the talker is the built-in ``"talker"``
(Flanagan 1960: a small piston on a 9 cm rigid sphere, docs/directivity.md); the free-field
check uses a cardioid, whose null makes "facing away" unmistakable.
"""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux.acoustics.bands import band_set_of
from sonolux.analysis.sti import (
    MODULATION_HZ,
    field_sti,
    level_factors,
    speech_levels_db,
    sti_from_mtf,
)
from sonolux.scene.directivity import builtin_gains, theta_nodes_rad
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")

OCTAVES = [125, 250, 500, 1000, 2000, 4000, 8000]
SOURCE = np.array([3.0, 4.5, 1.5])
LISTENERS = np.array([[9.0, 4.5, 1.2], [7.0, 3.0, 1.2]])


def room(directivity, forward_x, absorption=0.15, scattering=0.9):
    source = {"position_m": SOURCE.tolist(), "directivity": directivity}
    if directivity != "omni":
        source["forward"] = [forward_x, 0.0, 0.0]
    return sonolux.load_scene({
        "name": "talk", "settings": {"bands_hz": OCTAVES, "seed": 5},
        "materials": {"m": {"absorption": absorption, "scattering": scattering}},
        "geometry": [{"type": "shoebox", "size_m": [12, 9, 3.5], "materials": {"default": "m"}}],
        "sources": [source],
        "receivers": {"type": "points", "positions_m": LISTENERS.tolist(), "radius_m": 0.3}})


def sti_of(field):
    return field_sti(field, np.arange(field.n_receivers))[0]


def test_in_the_free_field_a_talker_facing_the_listener_equals_an_omni_talker():
    # Anechoic: only the direct sound, m = 1; the speech level decides through masking and
    # the reception threshold. On the talker's axis its level is the standard's, as the omni
    # talker's everywhere: the same STI (measured 3e-5 apart: the tabulated pattern's
    # bilinear surface against its axis value; allowed 1e-4, a JND of STI is 0.03). Off axis
    # (the second listener, 40° off) it is lower by the pattern, and in the cardioid's null
    # (the first listener, the talker facing away) nothing arrives.
    kw = dict(absorption=1.0, scattering=0.0)
    omni = bake(room("omni", 1.0, **kw), rays=100, estimator="rain", max_time_s=0.1)
    facing = bake(room("cardioid", 1.0, **kw), rays=100, estimator="rain", max_time_s=0.1)
    away = bake(room("cardioid", -1.0, **kw), rays=100, estimator="rain", max_time_s=0.1)
    s_omni, s_facing, s_away = sti_of(omni), sti_of(facing), sti_of(away)
    assert abs(s_facing[0] - s_omni[0]) < 1e-4
    assert s_facing[1] < s_omni[1]
    assert s_away[0] < 0.05 and s_away[1] < s_facing[1]
    # The field's G includes the on-axis gain of 3 (4.77 dB): the correction removes it.
    g = [10 * np.log10(np.asarray(f.energy[0], float).sum()) for f in (omni, facing)]
    np.testing.assert_allclose(g[1] - g[0], 10 * np.log10(3.0), atol=0.01)


def test_in_the_free_field_the_built_in_talker_facing_the_listener_equals_an_omni_talker():
    # The same with Flanagan's talker (docs/directivity.md): on its axis (the first listener,
    # 2.9° off) as loud as the standard's talker, so the same STI as an omni talker (measured
    # 7e-6 apart; allowed 1e-4); turned away, both listeners lose (measured 0.951 → 0.906 and
    # 0.966 → 0.867: −0.5 to −3.3 dB behind the head from 1 to 8 kHz).
    kw = dict(absorption=1.0, scattering=0.0)
    s_omni, s_facing, s_away = (
        sti_of(bake(room(d, x, **kw), rays=100, estimator="rain", max_time_s=0.1))
        for d, x in (("omni", 1.0), ("talker", 1.0), ("talker", -1.0)))
    assert abs(s_facing[0] - s_omni[0]) < 1e-4
    assert np.all(s_away < s_facing - 0.02), (s_away, s_facing)


def diffuse_theory_sti(field, gain_of, axis_gain):
    """STI of the direct sound (gain_of(u) × 1/(4πd²), air) plus a diffuse field of Eyring's
    T from t = 0 (energy 4(1 − ᾱ)/A, A = −S ln(1 − ᾱ) + 4mV; Houtgast and Steeneken 1985's
    m(F) = |E_d + E_r / (1 + j2πFT/13.8)| / (E_d + E_r)), the level referred to the axis."""
    th = field.theory
    v, s = th["volume_m3"], th["area_m2"]
    a, m = np.asarray(th["mean_absorption"]), np.asarray(th["air_attenuation_per_m"])
    t60 = np.asarray(th["eyring_t60_s"])
    e_r = 4 * (1 - a) / (-s * np.log(1 - a) + 4 * m * v)
    f = np.asarray(MODULATION_HZ)
    out = []
    for p in field.positions_m:
        to = p - SOURCE
        d = np.linalg.norm(to)
        e_d = gain_of(to / d) / (4 * np.pi * d * d) * np.exp(-m * d)
        mtf = np.abs(e_d[:, None] + e_r[:, None] / (1 + 2j * np.pi * f * t60[:, None] / 13.8))
        mtf /= (e_d + e_r)[:, None]
        g = 10 * np.log10((e_d + e_r) * 4 * np.pi * 100)
        levels = speech_levels_db(g) - 10 * np.log10(axis_gain)
        out.append(float(sti_from_mtf(mtf * level_factors(levels, None)[:, None])))
    return np.array(out)


def talker_gains():
    """The built-in talker's energy gains per octave, normalised to mean 1 over the sphere as
    the engine does (trapezoid rule in θ): float64[theta, band] on ``theta_nodes_rad()``."""
    g = builtin_gains("talker", band_set_of(OCTAVES).edges_hz)[:, 0, :]
    th = theta_nodes_rad()
    return g / (np.trapezoid(g * np.sin(th)[:, None], th, axis=0) / 2)


def test_a_talker_facing_the_listener_is_understood_better_than_one_facing_away():
    # Flanagan's talker facing +x (towards both listeners) or −x. Order: facing > omni >
    # facing away, at both listeners (measured: 0.582/0.594, 0.571/0.585, 0.564/0.573).
    # Magnitude: the change from the omni talker against diffuse-field theory (direct sound by
    # the pattern + Eyring's reverberation from t = 0), within 0.03 (a JND of STI): the theory
    # leaves out that the talker's early reflections (floor, the wall it faces) follow its
    # pattern too (measured: +0.011/+0.008 baked vs +0.001/+0.005 in theory facing;
    # −0.007/−0.013 vs −0.002/−0.004 facing away). A talker whose directivity were ignored
    # (or applied twice in the level) misses the ordering or the magnitude.
    fields = {k: bake(room(d, x), rays=40000, estimator="rain") for k, d, x in
              (("omni", "omni", 1.0), ("facing", "talker", 1.0), ("away", "talker", -1.0))}
    sti = {k: sti_of(f) for k, f in fields.items()}
    assert np.all(sti["facing"] > sti["omni"]) and np.all(sti["omni"] > sti["away"]), sti
    g, th = talker_gains(), theta_nodes_rad()

    def gain_of(u, sign):
        angle = np.arccos(np.clip(sign * u[0], -1.0, 1.0))
        return np.array([np.interp(angle, th, g[:, b]) for b in range(g.shape[1])])

    omni_theory = diffuse_theory_sti(fields["omni"], lambda u: 1.0, 1.0)
    for k, sign in (("facing", 1.0), ("away", -1.0)):
        theory = diffuse_theory_sti(fields[k], lambda u, s=sign: gain_of(u, s), g[0])
        np.testing.assert_allclose(sti[k] - sti["omni"], theory - omni_theory, atol=0.03)
