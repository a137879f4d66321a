"""Directional sources in the waves, orders 5 and 6 (session 13; ``sonolux.sound.wave_sources``,
``wave_stencils``, ``wave_moments``): the fifth and sixth differences and their closed-form
errors, the general-order moments against the explicit ones and a pure harmonic, the 30° cone's
energy above orders 4 to 6 against its Legendre series, the order rule and its log, and the bits
of a fit whose orders stay at 4 or below. The grid's far field and float32 floor of orders 5 and
6 are in ``test_wave_sources_order6_grid``. Each check states its tolerance and why."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import eval_legendre

from sonolux import engine
from sonolux.scene.directivity import node_directions
from sonolux.sound import wave_moments, wave_sources, wave_stencils
from tests.sound.test_wave_sources_order2 import (
    BANDS,
    FORWARD,
    UP,
    C,
    assert_causal_and_without_dc,
    assert_far_field,
    custom,
)
from tests.sound.test_wave_sources_order3 import cone

pytestmark = pytest.mark.usefixtures("core")


@pytest.mark.parametrize("derivative", [5, 6])
def test_the_fifth_and_sixth_differences_are_fourth_order_with_their_closed_form_errors(
        derivative):
    """Fornberg's (Math. Comp. 51, 1988) centred differences on the nodes −4..4: Σ w_m·mᵖ is
    L! for p = L and 0 for every other p ≤ L + 3 (fourth-order accurate: exact on polynomials
    of degree L + 3), to rounding. Their response to a plane wave along the axis, over the
    exact (iθ)^L, is the closed form of ``difference_response`` (checked against the weights
    summed as plane waves, 10⁻¹²), s12's scoping numbers (∂⁵: 0.9947 at θ = 0.5, 0.951 at 0.9;
    ∂⁶: 0.9968 and 0.970, to their 4 digits), and for small θ its series 1 − 13θ⁴/144 (∂⁵) or
    1 − 13θ⁴/240 (∂⁶) within 2% of the θ⁴ term (the next, 67θ⁶/3024, is 1% of it at θ = 0.2);
    the closed form and the series (used below θ = 0.3, where the closed form cancels to
    10⁻¹⁶/θ^L) meet there within 10⁻¹¹."""
    offsets, weights = wave_stencils.DIFFERENCES[derivative]
    assert list(offsets) == list(range(-4, 5))
    for p in range(derivative + 4):
        moment = float(np.dot(weights, offsets.astype(float) ** p))
        np.testing.assert_allclose(moment, math.factorial(derivative) if p == derivative else 0.0,
                                   atol=1e-9, err_msg=str(p))
    assert abs(float(np.dot(weights, offsets.astype(float) ** (derivative + 4)))) > 1.0
    for th in (0.3, 0.5, 0.9, 1.2):
        summed = np.dot(weights, np.exp(1j * offsets * th)) / (1j * th) ** derivative
        np.testing.assert_allclose(wave_stencils.difference_response(derivative, th),
                                   summed.real, atol=1e-12)
        assert abs(summed.imag) < 1e-12
    scoped = {5: (0.9947, 0.951), 6: (0.9968, 0.970)}[derivative]
    np.testing.assert_allclose([wave_stencils.difference_response(derivative, 0.5),
                                wave_stencils.difference_response(derivative, 0.9)], scoped,
                               atol=6e-4)
    lead = {5: 13.0 / 144.0, 6: 13.0 / 240.0}[derivative]
    np.testing.assert_allclose(1.0 - wave_stencils.difference_response(derivative, 0.2),
                               lead * 0.2 ** 4, rtol=0.02)
    np.testing.assert_allclose(wave_stencils.difference_response(derivative, 0.2999999),
                               wave_stencils.difference_response(derivative, 0.3), atol=1e-11)


def test_orders_5_and_6_hold_to_a_smaller_grid_step_than_order_3():
    """Orders 5 and 6's worst error is the fifth difference's 13θ⁴/144 (order 6's ∂ᵢ⁵∂ⱼ holds
    one), so they are resolved together, to kΔx = 0.707 at a band's upper edge (order 3 to
    0.787); at the hybrid's crossover (kΔx = 2π/(10√2) = 0.444) they err by 0.34%, so every
    wave band's stencils resolve order 6 there."""
    assert wave_sources.stencil_error(5, 0.70) < 0.02 < wave_sources.stencil_error(5, 0.71)
    assert wave_sources.stencil_error(6, 0.6) == wave_sources.stencil_error(5, 0.6)
    assert wave_sources.stencil_error(6, 2 * math.pi / (10 * math.sqrt(2))) < 0.0034


def test_the_general_order_moments_are_the_explicit_ones_and_a_pure_harmonic():
    """``wave_moments.higher_order`` (the addition theorem in general form, monomial by
    monomial) gives for L = 2, 3, 4 the same polynomials as D, T, Q (to 10⁻¹² of the pattern,
    rounding over 4,608 quadrature points), and of A = 1 + P₅(u·a) + ½·P₆(u·b) (a, b oblique)
    it keeps exactly P₅(u·a) at order 5 and ½·P₆(u·b) at order 6 (10⁻¹²: the quadrature is
    exact to degree 95), with shares ⟨P_L²⟩ = 1/(2L + 1): 1/11 and 1/52, and nothing above:
    the shares sum to the energy."""
    u, w = wave_moments.fit_directions()
    a_axis, b_axis = np.array([0.6, 0.64, 0.48]), np.array([-0.36, 0.48, 0.8])
    pattern = 1.0 + eval_legendre(5, u @ a_axis) + 0.5 * eval_legendre(6, u @ b_axis)
    beamed = ((1.0 + u @ a_axis) / 2.0) ** 6  # of every order to 6
    a = np.column_stack([pattern, beamed])
    c0, c, m, d, t, q, higher, shares, total = wave_moments.moments(a, u, w)
    explicit = {2: np.einsum("di,dj,bij->db", u, u, d),
                3: np.einsum("di,dj,dk,bijk->db", u, u, u, t),
                4: np.einsum("di,dj,dk,dl,bijkl->db", u, u, u, u, q)}
    for order, part in explicit.items():
        general = wave_moments.order_monomials(u, order) @ wave_moments.higher_order(
            u, w[:, None] * a, order).T
        np.testing.assert_allclose(general, part, atol=1e-12 * np.abs(a).max(), err_msg=order)
    fifth = wave_moments.order_monomials(u, 5) @ higher[0, :21]
    sixth = wave_moments.order_monomials(u, 6) @ higher[0, 21:]
    np.testing.assert_allclose(fifth, eval_legendre(5, u @ a_axis), atol=1e-12)
    np.testing.assert_allclose(sixth, 0.5 * eval_legendre(6, u @ b_axis), atol=1e-12)
    np.testing.assert_allclose(shares[:, 0], [1, 0, 0, 0, 0, 1 / 11, 0.25 / 13], atol=1e-12)
    np.testing.assert_allclose(shares.sum(axis=0), total, rtol=1e-12)


def cone_share_above(order, half_angle_deg):
    """The share of a hard-edged cone's energy above ``order``, in closed form: its amplitude
    (1 inside, 0 outside) has the Legendre coefficients f_n = (P_{n−1}(cos α) − P_{n+1}(cos α))/2
    (f₀ = (1 − cos α)/2), order n holds f_n²/(2n + 1) of the mean square, which is
    (1 − cos α)/2."""
    x = math.cos(math.radians(half_angle_deg))
    f = [(1.0 - x) / 2.0] + [(eval_legendre(n - 1, x) - eval_legendre(n + 1, x)) / 2.0
                             for n in range(1, order + 1)]
    kept = sum(fn * fn / (2 * n + 1) for n, fn in enumerate(f))
    return 1.0 - kept / ((1.0 - x) / 2.0)


def test_the_30_degree_cone_leaves_its_closed_form_energy_above_orders_4_to_6():
    """A 30° cone (hard-edged: of every order) keeps 22.2 / 16.8 / 15.8% of its energy above
    orders 4 / 5 / 6 (its Legendre series, :func:`cone_share_above`; notes/s12/i18src.md §3);
    the fit's residual (its amplitude's mean squared error, the pressure's) meets each within
    0.01 (the cone's edge is a step, which the 48-ring Gauss quadrature does not integrate
    exactly: the same tolerance as orders 2-4 in test_wave_sources_order3). **The energy gain's
    mean squared error over the sphere does not fall with them**: the power-normalised truncated
    series (Gibbs' overshoot at the edge, squared) gives 2.75 / 4.12 / 5.36 at orders 4 / 5 / 6
    in closed form (the Legendre series on 2,000 Gauss points in cos θ, :func:`cone_gain_error`),
    and the fit meets those within 3% (measured 2.71 / 4.08 / 5.34; the same quadrature
    error). The orders are chosen for the pressure field (what the grid radiates), not for the
    energy gain's error: docs/waves-sources.md."""
    source, pattern = cone(30.0)
    closed = [cone_share_above(L, 30.0) for L in (4, 5, 6)]
    np.testing.assert_allclose(closed, [0.2219, 0.1683, 0.1583], atol=5e-4)
    fits = [wave_sources.fit(source, pattern, len(BANDS), np.full(len(BANDS), L))
            for L in (4, 5, 6)]
    for fitted, share in zip(fits, closed):
        np.testing.assert_allclose(fitted.residual, share, atol=0.01)
    u = wave_sources.fibonacci_directions(4000)
    target = np.asarray(pattern.gains(u, len(BANDS)))
    errors = [((f.energy_gain(u) - target) ** 2).mean(axis=0) for f in fits]
    expected = [cone_gain_error(L, 30.0) for L in (4, 5, 6)]
    np.testing.assert_allclose(expected, [2.75, 4.12, 5.36], atol=0.01)
    for error, closed_error in zip(errors, expected):
        np.testing.assert_allclose(error, closed_error, rtol=0.03)


def cone_gain_error(order, half_angle_deg):
    """The mean squared error of the energy gain of a hard-edged cone's Legendre series to
    ``order``, scaled to the cone's power (as the fit is): on 2,000 Gauss-Legendre points in
    cos θ, with the closed-form coefficients of :func:`cone_share_above`."""
    x, w = np.polynomial.legendre.leggauss(2000)
    w = w / 2.0
    ca = math.cos(math.radians(half_angle_deg))
    mean_square = (1.0 - ca) / 2.0
    f = [mean_square] + [(eval_legendre(n - 1, ca) - eval_legendre(n + 1, ca)) / 2.0
                         for n in range(1, order + 1)]
    kept = sum(fn * fn / (2 * n + 1) for n, fn in enumerate(f))
    series = sum(fn * eval_legendre(n, x) for n, fn in enumerate(f)) / math.sqrt(kept)
    target = np.where(x > ca, 1.0, 0.0) / mean_square
    return float(w @ (series ** 2 - target) ** 2)


def test_the_rule_radiates_order_5_where_the_grid_and_the_float32_floor_allow():
    """The order rule per band (``wave_stencils.resolved_orders``): the stencils' orders at each
    band's upper edge, capped by one float32 rounding of the next order's largest signal below
    the band, (2⁻²⁴·G)² ≤ 10⁻⁶ (G = feed_growth, growing as 1/(kΔx)^L), and at 3 in the lowest
    band; order 6 is never chosen (MAX_ORDER = 5: its floor is not what the bound predicts,
    test_wave_sources_order6_grid). On the 354 Hz hybrid's 69 mm grid (63-500 Hz): 3/4/5/2
    (order 5 at 125 Hz would round at 3.9·10⁻⁶, s12's 3.8·10⁻⁶); on the 250 Hz hybrid's 97 mm:
    3/5/5/0; on the 177 Hz hybrid's 137 mm 3/5/2/0 (250 Hz: the first difference's 2% reached);
    on 34 mm 3/3/4/5. With ``max_order=4`` the rule is session 10's (3/4/4/2, 3/4/4/0, 3/4/2/0,
    3/3/4/4), so a fit made there is what it was. The log's words say both limits and the
    floor's number."""
    hybrid = C / (10 * 354.0 * math.sqrt(2))
    cases = {hybrid: ([3, 4, 5, 2], [3, 4, 4, 2]), C / 3540: ([3, 5, 5, 0], [3, 4, 4, 0]),
             C / 2500: ([3, 5, 2, 0], [3, 4, 2, 0]),
             C / (10 * 707 * math.sqrt(2)): ([3, 3, 4, 5], [3, 3, 4, 4])}
    for spacing, (orders, session10) in cases.items():
        assert list(wave_sources.resolved_orders(BANDS, spacing, C)) == orders, spacing
        assert list(wave_sources.resolved_orders(BANDS, spacing, C, max_order=4)) == session10
    np.testing.assert_allclose(
        [wave_stencils.floor_share(BANDS, 1, hybrid, C, 5),
         wave_stencils.floor_share(BANDS, 1, hybrid, C, 6),
         wave_stencils.floor_share(BANDS, 2, hybrid, C, 6)], [3.9e-6, 2.8e-4, 7.1e-8], rtol=0.05)
    note = wave_stencils.orders_note(BANDS, hybrid, C, 3)
    assert "stencils resolve orders up to 5/5/5" in note and "floor allows 3/4/5" in note, note
    assert "order 5 at 125 Hz 3.9e-06 of the band, above 1e-06" in note, note
    fitted = wave_sources.fit_on_grid(*cone(30.0), BANDS, hybrid, C, wave_bands=3)
    assert list(fitted.orders) == [3, 4, 5, 5] and fitted.grid_note == note
    assert note in wave_sources.describe("cone", fitted, 100, 3)
    assert list(wave_sources.fit(*cone(30.0), len(BANDS)).orders) == [5, 5, 5, 5]


def test_a_fit_whose_orders_stay_at_4_keeps_its_terms():
    """Orders 0-4 are computed as before session 13, in the same layout (the first 35
    components), and orders 5-6's columns are 0 where a band does not radiate them, so a source
    whose orders do not change has the same components and terms (compared bit for bit against
    main's code, 00f5faf, by notes/s13/i18sh_scripts/same_bits.py: a cardioid, the talker, a
    displaced SOFA cardioid, the 30° cone at orders 3/4/4/4). Here, structurally: that cone has
    0 in every column of orders 5-6 and the 179 monopoles it had (docs/waves-sources.md), and
    the oblique :func:`harmonic` of order 6 uses every one of order 6's 28 monomials (and
    none of order 5's: it has none), reaches √20 cells and
    adds monopoles (the nine-node stencils)."""
    source, pattern = cone(30.0)
    fitted = wave_sources.fit(source, pattern, len(BANDS), np.array([3, 4, 4, 4]))
    assert fitted.components.shape == (len(BANDS), 84)
    assert np.all(fitted.components[:, 35:] == 0.0)
    spacing, fs, steps = C / 2500, 2500 * math.sqrt(3.0), 2000
    pos, _, _ = wave_sources.terms(np.zeros(3), fitted, BANDS, 250.0, spacing, fs, steps, C)
    assert len(pos) == 179
    beam6 = wave_sources.fit(custom(), harmonic(6), len(BANDS), np.full(len(BANDS), 6))
    assert np.all(beam6.components[1:, 56:] != 0.0) and np.all(beam6.components[:, 35:56] == 0)
    assert list(beam6.orders) == [0, 6, 6, 6]
    np.testing.assert_allclose(wave_sources.components_reach_cells(beam6.components),
                               math.sqrt(20.0))
    pos6, _, _ = wave_sources.terms(np.zeros(3), beam6, BANDS, 250.0, spacing, fs, steps, C)
    assert len(pos6) > len(pos)


def harmonic(order, forward=FORWARD):
    """A synthetic source of orders 0 and ``order`` only: amplitude 1 + P_L(cos θ) about the
    oblique ``forward`` (≥ 0: P₅ ≥ −1, P₆ > −1), so its tabulated energy gain (1 + P_L)² carries
    it without a sign; order L holds 1/(2L + 2) of its energy (8.3% for L = 5, 7.1% for 6); omni
    in the 63 Hz band. About an oblique axis every monomial of order L carries part of it."""
    th = np.arccos(node_directions(symmetric=True)[:, 0, 0])
    g = (1.0 + eval_legendre(order, np.cos(th))) ** 2
    gains = np.column_stack([np.ones_like(th), g, g, g])
    return engine.Directivity.pattern(np.ascontiguousarray(gains[:, None, :]), forward, UP)


@pytest.mark.parametrize("order", [5, 6])
def test_a_synthetic_order_5_or_6_source_is_fitted_and_its_clusters_far_field_is_its_pattern(
        order):
    """:func:`harmonic` of order 5 or 6 is fitted with orders 0 and L (nothing between carries
    4·10⁻⁴), leaving < 2·10⁻⁴ above L (the table's bilinear interpolation in θ, 2.5° steps, of a
    pattern that swings L times), order L's share 1/(2L + 2) within 10⁻³. Its terms as
    free-field monopoles, summed as plane waves over the reference pulse's spectrum (the far
    field), give the fitted pattern at the 125 and 250 Hz band centres in 2,000 directions within
    the stencils' own error (stencil_error at the centre: the fifth difference's 13θ⁴/144, 1.4%
    at 250 Hz on this 137 mm grid) of the largest amplitude plus 10⁻³ (the coefficient blends'
    tails, as for orders 2-4); that fit is the exact pattern within √(2·10⁻⁴)."""
    f_max, fs, steps = 250.0, 250.0 * 10 * math.sqrt(3.0), 8000
    spacing = C / (f_max * 10)
    pattern = harmonic(order)
    fit = wave_sources.fit(custom(), pattern, len(BANDS), np.full(len(BANDS), order))
    assert list(fit.orders) == [0, order, order, order]
    assert np.all(fit.residual < 2e-4), fit.residual
    u = wave_sources.fibonacci_directions(2000)
    exact = 1.0 + eval_legendre(order, u @ np.asarray(FORWARD))
    exact = exact / math.sqrt(1.0 + 1.0 / (2 * order + 1))  # the source's power
    np.testing.assert_allclose(fit.amplitude(u)[:, 1], exact, atol=math.sqrt(2e-4) * exact.max())
    pos, sig, delay = wave_sources.terms(np.zeros(3), fit, BANDS, f_max, spacing, fs, steps, C)
    assert len(pos) == len({tuple(np.round(p / spacing).astype(int)) for p in pos})
    assert_far_field(fit, pos, sig, delay, order, f_max, fs, steps, spacing)


@pytest.mark.parametrize("order", [5, 6])
def test_what_the_filters_of_orders_5_and_6_put_before_the_pulse_is_negligible(order):
    """Orders 5 and 6 are fed c⁵·∫⁴q and c⁶·∫⁵q, faded out below the lowest band as orders 2-4
    are; their zero-phase filters' part before the pulse (cut at the run's start) is below
    10⁻⁶ of the signal's energy, as for orders 2-4 (test_wave_sources_order2), and the signal
    has no DC. Measured on the harmonic's u_x⁵ or u_x⁶ coefficient."""
    f_max, fs, steps = 250.0, 250.0 * 10 * math.sqrt(3.0), 20000
    fit = wave_sources.fit(custom(), harmonic(order), len(BANDS), np.full(len(BANDS), order))
    component = 35 if order == 5 else 56  # u_x⁵, u_x⁶
    assert wave_sources.component_order(component) == order
    delay = wave_sources.pulse_delay_s(BANDS, f_max, fit)
    assert_causal_and_without_dc(fit, component, order, delay, f_max, fs, steps)
