"""Directional sources in the waves, orders 5 and 6 on the grid (session 13): the far field of an
injected order-5 cluster against the exact directivity of a synthetic order-5 source and against
the 30° cone's order-5 fit, and the float32 floor of orders 5 and 6 measured by linearity, which
is why the order rule radiates order 5 and not 6. Each check states its tolerance and why."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.sound import wave_sources, wave_stencils
from tests.sound.test_wave_sources import band_gains, cluster_runs
from tests.sound.test_wave_sources_order2 import BANDS, C
from tests.sound.test_wave_sources_order3 import DIRECTIONS, cone, rounding_shares
from tests.sound.test_wave_sources_order6 import custom, harmonic

pytestmark = pytest.mark.usefixtures("core")

#: Receivers 4 m from the source (40 Fibonacci directions): at 125 Hz kr = 9.2, where an
#: order-5 term's near field is within a factor 1.4 of its far field (at 2 m, 2.6), so the
#: ±30 ms window's 33 Hz resolution mixes less of the near field's steep low end into the band.
FAR_M = 4.0


def big_box():
    """A 20 m box of absorbing walls (α 0.9), the source near its centre, off the nodes: the first
    reflection at a receiver 4 m away comes ≥ 35 ms after the direct sound, outside the ±30 ms
    window: (scene, source position)."""
    src = np.array([10.03, 9.97, 10.01])
    return sonolux.load_scene({
        "name": "big-box", "settings": {"bands_hz": BANDS.tolist()},
        "materials": {"m": {"absorption": 0.9}},
        "geometry": [{"type": "shoebox", "size_m": [20.0] * 3, "materials": {"default": "m"}}],
        "sources": [{"position_m": src.tolist()}],
        "receivers": {"type": "points", "positions_m": [[1.0, 1.0, 1.0]]},
    }), src


@pytest.fixture(scope="module")
def far_field():
    """One omni run and two cluster runs on the 137 mm grid (to 250 Hz; the 177 Hz hybrid's,
    whose rule radiates order 5 at 125 Hz), 40 receivers at 4 m: the synthetic order-5 source
    (:func:`harmonic`, omni at 63 Hz) and the 30° cone fitted to orders 3/5/5/5, their terms
    pre-compensated for the grid's dispersion as the bake's are (``wave_dispersion``). Per run:
    (measured, expected) gains (``band_gains``: the fit's own field at 4 m, each order with its
    near-field factor), the fit, the number of monopoles."""
    scene, src = big_box()
    source, pattern = cone(30.0)
    fits = [wave_sources.fit(custom(), harmonic(5), len(BANDS), np.array([0, 5, 5, 5])),
            wave_sources.fit(source, pattern, len(BANDS), np.array([3, 5, 5, 5]))]
    omni, runs = cluster_runs(scene, src, src + FAR_M * DIRECTIONS, fits, compensated=True)
    return [(band_gains(omni, run, fit, DIRECTIONS, FAR_M), fit, n)
            for fit, (run, n) in zip(fits, runs)]


def test_the_injected_order_5_cluster_radiates_the_exact_directivity(far_field):
    """The synthetic source 1 + P₅(cos θ) about an oblique axis (orders 0 and 5 only, so its fit
    is the exact directivity, residual < 2·10⁻⁴; 281 monopoles) on the grid: energy gain over
    the omni run at 40 receivers against its exact field at 4 m, at 125 Hz, the band the rule
    radiates order 5 in on this grid, within 2% of the peak gain ((1 + 1)²/(1 + 1/11) = 3.67),
    the tolerance of orders 2-4 (measured 0.60% pre-compensated, 0.65% with the terms of before:
    the window's resolution; the fifth difference errs by 0.09% at the band centre, the scheme's
    dispersion by (kΔx)²/36 = 0.27% along the axes, times 5 for an order-5 term). Not asserted:
    63 Hz (omni there: the order-5 terms' near field below 125 Hz leaks through the window; 1.1%
    in this session's runs, with and without the compensation) and 250 Hz (beyond what the rule
    radiates on this grid, its upper edge at kΔx = 0.89: 0.56%, 1.9% before, the next test)."""
    (measured, expected), fit, n_terms = far_field[0]
    assert n_terms == 281 and np.all(fit.residual < 2e-4)
    peak = 4.0 / (1.0 + 1.0 / 11.0)
    worst = np.abs(measured - expected).max(axis=0)
    print("1 + P5, worst of the peak per band:", worst / peak)
    assert worst[1] < 0.02 * peak, worst


def test_pre_compensated_the_order_5_source_is_within_1_percent_at_the_grid_s_f_max(far_field):
    """The same source at 250 Hz (the grid's f_max; its band's upper edge at kΔx = 0.89, where
    the 7-point scheme's dispersion, carried five times by an order-5 term and along its group
    direction, is what the stencils' 2% rule does not count): 1.88% of the peak with the terms
    of before (measured, session 13), **0.56%** pre-compensated (``wave_dispersion``: the
    closed-form residual at the band centre, kΔx = 0.63, is 3.4% of an order-5 part's peak, 1/11
    of this pattern's energy). Asserted: below 1% of the peak (the stencils' own error at the
    centre, 1.3%, is what the rule allows)."""
    (measured, expected), _, _ = far_field[0]
    peak = 4.0 / (1.0 + 1.0 / 11.0)
    assert np.abs(measured - expected).max(axis=0)[2] < 0.01 * peak


def test_the_30_degree_cone_at_order_5_on_the_grid(far_field):
    """The 30° cone fitted to order 5 (16.8% of its energy above it, the closed form) radiated on
    the grid: its field at 4 m against the fit's own within 2% of the cone's peak gain (14.9) at
    125 Hz (measured 0.50% pre-compensated, 0.15% with the terms of before: at 4 m an order-5
    part is in its near field, where the lower-degree content the far-field compensation adds
    radiates with its own near field; 250 Hz 1.32%, 1.7% before); at 63 Hz order 3 is radiated,
    whose near field below the band leaks through the window (4.9% measured, as
    test_wave_sources_order3 says), so not asserted."""
    (measured, expected), fit, n_terms = far_field[1]
    assert n_terms == 281
    np.testing.assert_allclose(fit.residual[1:], 0.1683, atol=0.01)
    peak = 1.0 / math.sin(math.radians(15.0)) ** 2
    worst = np.abs(measured - expected).max(axis=0)
    print("cone, worst of the peak per band:", worst / peak)
    assert worst[1] < 0.02 * peak, worst


#: The share of a band's energy a float32 floor may hold: 60 dB down (wave_stencils).
NOISE_FLOOR = wave_stencils.NOISE_FLOOR


def test_order_5_stays_below_60_db_of_float32_floor_and_order_6_does_not():
    """On the 137 mm grid (the 177 Hz hybrid's: wave bands 63 and 125 Hz) the rule radiates
    3/5 (order 5 at 125 Hz: one float32 rounding of its largest signal 3.7·10⁻⁹ of the band),
    and the floor measured by linearity is below 10⁻⁶ in both wave bands (measured 8.7·10⁻⁸ /
    3.0·10⁻⁷: 80× one rounding, which does not predict it here either, as session 10 found for
    order 3 and the lowest band). Order 6 there, which one rounding would allow (6.7·10⁻⁸),
    measures above 10⁻⁶ (1.1·10⁻⁶ / 3.8·10⁻⁶): the bound cannot tell where order 6 is safe,
    so the rule stops at 5 (MAX_ORDER). Tolerance: 10⁻⁶ (60 dB), the standard; order 5's margin
    3.3×, order 6's excess 3.8×."""
    spacing = engine.WaveSettings(max_frequency_hz=250.0, duration_s=0.1).spacing_m
    assert list(wave_sources.resolved_orders(BANDS, spacing, C)) == [3, 5, 2, 0]
    assert wave_stencils.floor_share(BANDS, 1, spacing, C, 6) < NOISE_FLOOR
    assert np.all(rounding_shares([3, 5, 2, 0], 250.0, 2) < NOISE_FLOOR)
    assert rounding_shares([3, 6, 2, 0], 250.0, 2).max() > NOISE_FLOOR


@pytest.mark.slow
def test_on_the_354_hz_hybrid_s_grid_the_rule_s_order_5_stays_below_60_db():
    """On the 69 mm grid (the 354 Hz hybrid's: wave bands 63, 125, 250 Hz) the rule radiates
    3/4/5 (order 5 at 250 Hz), measured 3.8 / 5.6 / 6.2·10⁻⁸ of the wave bands; order 5 at
    125 Hz too, which the rule withholds (one rounding 3.9·10⁻⁶), measures 1.8 / 1.2 / 4.5·10⁻⁶.
    Tolerance 10⁻⁶, the standard."""
    spacing = engine.WaveSettings(max_frequency_hz=500.0, duration_s=0.1).spacing_m
    assert list(wave_sources.resolved_orders(BANDS, spacing, C)) == [3, 4, 5, 2]
    assert np.all(rounding_shares([3, 4, 5, 2], 500.0, 3) < NOISE_FLOOR)
    assert rounding_shares([3, 5, 5, 2], 500.0, 3).max() > NOISE_FLOOR


@pytest.mark.slow
def test_an_order_5_term_carries_the_scheme_s_dispersion_five_times():
    """The grid's far field of a stencil is its symbol at the scheme's wavenumber k_g, so an
    order-L part is scaled by (k_g/k)^L: for the 7-point scheme at the Courant limit
    k_g/k − 1 = (kΔx)²/36 along the axes (sin(ωΔt/2) = λ·sin(k_gΔx/2), λ = 1/√3, to second
    order) and 0 along the diagonals. The order-5 part of 1 + P₅ alone, about the x axis and
    about the diagonal, receivers at ±its axis 4 m away (20 m box, 137 mm grid): its energy over
    the exact order-5 field's, per band core, is (1 + θ²/36)^10 along the axis (θ = kΔx at the
    centre: 2.8% at 125 Hz, 11.5% at 250 Hz; measured 3.7-4.1% and 11.9-12.1%, the band core
    reaching above the centre) and within 1% of 1 on the diagonal (measured 0.2-1.0%).
    Tolerance: the closed form within 2% of energy (the stencils' own error, −0.2 / −2.8% along
    the axis, and the window's). Not in the order rule (docs/waves-sources.md).
    **Pre-compensated** (``wave_dispersion``, the bake's terms): 1.012-1.015 / 0.967-0.970 along
    the axis and 1.001 / 1.042-1.045 on the diagonal (the least squares over the sphere spread
    the axis' error: far-field closed form 0.98 / 0.92 and 1.01 / 1.05; at 4 m an order-5 part
    is not yet in its far field, and the lower-degree content the compensation adds radiates
    with its own, weaker near field). Asserted within 5% of 1 in energy (was 12%)."""
    scene, src = big_box()
    order = np.array([wave_sources.component_order(k) for k in range(84)])
    fits, towards = [], []
    for axis in ((1.0, 0.0, 0.0), tuple(np.ones(3) / math.sqrt(3.0))):
        fit = wave_sources.fit(custom(), harmonic(5, forward=axis), len(BANDS),
                               np.array([0, 5, 5, 5]))
        fits.append(dataclasses.replace(
            fit, components=np.where((order == 5)[None], fit.components, 0.0)))
        towards.append(np.array([axis, np.negative(axis)], float))
    u = np.vstack(towards)
    omni, runs = cluster_runs(scene, src, src + FAR_M * u, fits)
    _, compensated = cluster_runs(scene, src, src + FAR_M * u, fits, compensated=True)
    theta = 2.0 * math.pi * BANDS[1:3] * (C / 2500.0) / C
    for i, ((run, _), (run_c, _), fit) in enumerate(zip(runs, compensated, fits)):
        measured, expected = band_gains(omni, run, fit, u, FAR_M)
        ratio = measured[2 * i:2 * i + 2, 1:3] / expected[2 * i:2 * i + 2, 1:3]
        closed = (1.0 + theta ** 2 / 36.0) ** 10 if i == 0 else np.ones(2)
        np.testing.assert_allclose(ratio, np.broadcast_to(closed, ratio.shape), atol=0.02,
                                   err_msg=["axis", "diagonal"][i])
        # Pre-compensated (wave_dispersion), as the bake's terms are: see the next docstring.
        measured, expected = band_gains(omni, run_c, fit, u, FAR_M)
        ratio = measured[2 * i:2 * i + 2, 1:3] / expected[2 * i:2 * i + 2, 1:3]
        print(["axis", "diagonal"][i], "pre-compensated:", ratio)
        np.testing.assert_allclose(ratio, 1.0, atol=0.05, err_msg=["axis", "diagonal"][i])
