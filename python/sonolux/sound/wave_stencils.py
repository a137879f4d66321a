"""The cluster's stencils (:mod:`sonolux.sound.wave_sources`): the components of a fit (the
monomials of orders 0 to :data:`MAX_ORDER`), their node stencils (fourth-order centred
differences, Fornberg, "Generation of finite difference formulas on arbitrarily spaced grids",
Math. Comp. 51, 1988, and products of them), the stencils' amplitude errors in closed form, and
the rule for which orders a band radiates."""

from __future__ import annotations

import itertools
import math

import numpy as np

#: The highest spherical-harmonic order radiated.
MAX_ORDER = 4
#: An order is radiated in a band where its stencils' amplitude error is at most this (0.17 dB)
#: at the band's upper edge, in every direction.
RESOLVED_AMPLITUDE = 0.02
#: The highest order radiated in the lowest band, whose coefficients are fed below its lower
#: edge down to half of :func:`lowest_filter_hz` (:func:`order2_fade`), where every other band's
#: are fed only a quarter band below theirs (the blend from the band below): session 9's highest
#: order; order 4 is withheld there for its measured float32 floor (:func:`resolved_orders`).
LOWEST_BAND_MAX_ORDER = 3
#: The relative rounding of the grid's float32 fields, 2⁻²⁴.
FLOAT32_ROUNDING = 2.0 ** -24
#: Order 4 is radiated in a band above the lowest only where one rounding of its largest
#: signal, (2⁻²⁴·G)² (:func:`feed_growth`), is at most this share of a band's energy: 60 dB
#: down, the range over which the tracer follows a ray (its default ``energy_drop_db``).
NOISE_FLOOR = 1e-6

#: Fourth-order centred differences (Fornberg 1988, table 1), × Δx^L: the L-th derivative on the
#: nodes −2..2 (L = 1, 2) and −3..3 (L = 3, 4); index = the derivative's order.
DIFFERENCES = (
    (np.array([0]), np.array([1.0])),
    (np.arange(-2, 3), np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0),
    (np.arange(-2, 3), np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / 12.0),
    (np.arange(-3, 4), np.array([1.0, -8.0, 13.0, 0.0, -13.0, 8.0, -1.0]) / 8.0),
    (np.arange(-3, 4), np.array([-1.0, 12.0, -39.0, 56.0, -39.0, 12.0, -1.0]) / 6.0),
)
FIRST_DIFFERENCE = DIFFERENCES[1][1]
SECOND_DIFFERENCE = DIFFERENCES[2][1]
THIRD_DIFFERENCE = DIFFERENCES[3][1]
FOURTH_DIFFERENCE = DIFFERENCES[4][1]
OFFSETS = np.arange(-2, 3)
#: The components of a fit, in the columns of :attr:`SourceFit.components`: order 0, order 1
#: along x, y, z, then order 2's monomials u_i·u_j (i ≤ j) with their coefficient (D_ii, 2·D_ij),
#: then order 3's u_i·u_j·u_k (i ≤ j ≤ k) with theirs (T_iii, 3·T_iij, 6·T_xyz), then order 4's
#: u_i·u_j·u_k·u_l (i ≤ j ≤ k ≤ l) with theirs (Q_iiii, 4·Q_iiij, 6·Q_iijj, 12·Q_iijk).
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
TRIPLES = ((0, 0, 0), (1, 1, 1), (2, 2, 2), (0, 0, 1), (0, 0, 2), (0, 1, 1), (1, 1, 2),
           (0, 2, 2), (1, 2, 2), (0, 1, 2))
QUADS = tuple(sorted(itertools.combinations_with_replacement(range(3), 4),
                     key=lambda q: (len(set(q)), q)))
#: The monomials' index tuples, component by component (order 0 is the empty tuple).
MONOMIALS: tuple[tuple[int, ...], ...] = ((), (0,), (1,), (2,), *PAIRS, *TRIPLES, *QUADS)
#: The number of components (orders 0-4: 1 + 3 + 6 + 10 + 15).
N_COMPONENTS = len(MONOMIALS)


def component_order(component: int) -> int:
    """The spherical-harmonic order (the derivative's) of a component of :data:`MONOMIALS`."""
    return len(MONOMIALS[component])



def monomials(u: np.ndarray) -> np.ndarray:
    """float64[direction, 35]: the monomials of :data:`MONOMIALS`: 1, u_x, u_y, u_z, u_i·u_j for
    :data:`PAIRS`, u_i·u_j·u_k for :data:`TRIPLES` and u_i·u_j·u_k·u_l for :data:`QUADS`."""
    return np.column_stack([np.prod(u[:, list(m)], axis=1) if m else np.ones(len(u))
                            for m in MONOMIALS])


def difference_response(derivative: int, kh: float) -> float:
    """R(θ): the response of the fourth-order difference of ``derivative`` (1 to 4) to a plane
    wave along its axis at θ = kΔx, over the exact derivative's (iθ)^L: (8 sin θ − sin 2θ)/(6θ)
    (1 − θ⁴/30), (30 − 32 cos θ + 2 cos 2θ)/(12θ²) (1 − θ⁴/90), (26 sin θ − 16 sin 2θ +
    2 sin 3θ)/(8θ³) (1 − 7θ⁴/120) and (56 − 78 cos θ + 24 cos 2θ − 2 cos 3θ)/(6θ⁴)
    (1 − 7θ⁴/240): Σ w_m e^{imθ} of the weights of :data:`DIFFERENCES`."""
    th = max(float(kh), 1e-12)
    if derivative == 1:
        return (8.0 * math.sin(th) - math.sin(2.0 * th)) / (6.0 * th)
    if derivative == 2:
        return (30.0 - 32.0 * math.cos(th) + 2.0 * math.cos(2.0 * th)) / (12.0 * th * th)
    if derivative == 3:
        return (26.0 * math.sin(th) - 16.0 * math.sin(2.0 * th) + 2.0 * math.sin(3.0 * th)) / (
            8.0 * th ** 3)
    if th < 0.1:  # the closed form cancels to rounding there (10⁻¹⁶/θ⁴): its series, to θ⁸
        return 1.0 - 7.0 * th ** 4 / 240.0 + 13.0 * th ** 6 / 3024.0
    return (56.0 - 78.0 * math.cos(th) + 24.0 * math.cos(2.0 * th) - 2.0 * math.cos(3.0 * th)) / (
        6.0 * th ** 4)


def stencil_error(order: int, kh: float) -> float:
    """The worst amplitude error, over all directions, of the cluster's terms of ``order`` at
    kΔx = ``kh``: the worst |1 − R| (:func:`difference_response`) of the one-axis differences
    the order's terms are products of (order 1: first differences; order 2: second and first;
    order 3: third, second and first; order 4: all four). A product term's error is worst
    where one factor has the whole kΔx: its factors' errors grow as θ⁴, and θᵢ⁴ + θⱼ⁴ ≤
    (θᵢ² + θⱼ²)². 0 for order 0 (the monopole itself)."""
    if order <= 0:
        return 0.0
    return max(abs(1.0 - difference_response(L, kh)) for L in range(1, order + 1))


def band_upper_edges_hz(bands_hz: np.ndarray) -> np.ndarray:
    """float64[band]: each band's upper edge (the geometric mean with the next centre; the
    last band as wide as the one below it, as ``admittance::band_edges``)."""
    b = np.asarray(bands_hz, float)
    if b.size < 2:
        return b * math.sqrt(2.0)
    return np.append(np.sqrt(b[:-1] * b[1:]), b[-1] * math.sqrt(b[-1] / b[-2]))


def resolved_orders(bands_hz: np.ndarray, spacing_m: float, speed_of_sound_m_s: float,
                    max_order: int = MAX_ORDER) -> np.ndarray:
    """int[band]: the highest order ≤ ``max_order`` whose stencils are within
    :data:`RESOLVED_AMPLITUDE` in every direction at the band's upper edge (0 where none is);
    order 4 only above the lowest band (:data:`LOWEST_BAND_MAX_ORDER`) and where one rounding of
    its largest signal, (2⁻²⁴·G)² with G = :func:`feed_growth`, is at most :data:`NOISE_FLOOR`.

    Why (the mechanism measured; its grid dependence not derived): an order-L term is fed the
    pulse integrated L − 1 times over (kΔx)^L, so below its band its signal grows as 1/(kΔx)^L,
    and the grid's float32 fields round the field near the cluster, a noise that reaches every
    band. The lowest band's coefficients are fed down through the fade of orders ≥ 2, to half of
    :func:`lowest_filter_hz` (19 Hz for a 63 Hz band, 1.75 octaves below its centre); every other
    band's only a quarter band below its lower edge. Measured by linearity for a 30° cone
    directional at 63 Hz (tests/sound/test_wave_sources_order3.py and docs/waves-sources.md): orders 0-3
    as session 9 chose them leave ≤ 6.2·10⁻⁸ of a band on the 137 mm and 69 mm grids; order 4 in
    the lowest band 2.1·10⁻⁵ and 1.5·10⁻⁵, which one rounding does not predict (2.2·10⁻⁶ and
    5.7·10⁻⁴), hence the cap; order 4 above it agrees with one rounding where that is above the
    grid's other floors (69 mm: 3·10⁻⁸ measured, 5.5·10⁻⁸ one rounding; 34 mm: 2.2·10⁻⁵ and
    1.4·10⁻⁵), hence the bound."""
    out = []
    for b, f in enumerate(band_upper_edges_hz(bands_hz)):
        kh = 2.0 * math.pi * f * spacing_m / speed_of_sound_m_s
        top = max(L for L in range(max_order + 1) if stencil_error(L, kh) <= RESOLVED_AMPLITUDE)
        if top >= 4 and (b == 0 or (FLOAT32_ROUNDING * feed_growth(
                bands_hz, b, spacing_m, speed_of_sound_m_s, 4)) ** 2 > NOISE_FLOOR):
            top = LOWEST_BAND_MAX_ORDER
        out.append(top)
    return np.array(out, dtype=int)


def feed_growth(bands_hz: np.ndarray, band: int, spacing_m: float, speed_of_sound_m_s: float,
                order: int) -> float:
    """G: the largest w(f)/(kΔx)^L below ``band``'s centre, w(f) the weight its coefficient is
    fed with at f: for the lowest band, the fade of orders ≥ 2 (:func:`order2_fade`: 0 at half of
    where its filter starts, 1 from there); for the others, the blend from the band below (a
    raised sine over a quarter band either side of the edge, ``wave_sources.edge_blends``)."""
    b = np.asarray(bands_hz, float)
    top = b[band]
    if band == 0:
        f = np.geomspace(0.5 * lowest_filter_hz(b), top, 400)
        w = order2_fade(f, b)
    else:
        edge, width = math.sqrt(b[band - 1] * top), 0.25 * math.log2(top / b[band - 1])
        f = np.geomspace(edge * 2.0 ** -width, top, 400)
        w = 0.5 * (1.0 + np.sin(0.5 * np.pi * np.clip(np.log2(f / edge) / width, -1.0, 1.0)))
    kh = 2.0 * np.pi * f * spacing_m / speed_of_sound_m_s
    return float(np.max(w / kh ** order))


def lowest_filter_hz(bands_hz: np.ndarray) -> float:
    """Where the lowest band's filter starts: its lower edge less a quarter of its width (the
    energy bands' crossover, ``bands.rs``). Below it no band looks."""
    b = np.asarray(bands_hz, float)
    ratio = b[1] / b[0] if b.size > 1 else 2.0
    return float(b[0] / math.sqrt(ratio) * ratio ** (-0.25))


def order2_fade(f_hz: np.ndarray, bands_hz: np.ndarray) -> np.ndarray:
    """float64[frequency]: the fade of orders 2 to 4, 0 below half of :func:`lowest_filter_hz`, 1 above
    it, a raised sine in log frequency across that octave."""
    top = lowest_filter_hz(bands_hz)
    with np.errstate(divide="ignore"):
        x = 2.0 * np.log2(np.maximum(f_hz, 1e-300) / top) + 1.0  # −1 at top/2, 1 at top
    return 0.5 * (1.0 + np.sin(0.5 * np.pi * np.clip(x, -1.0, 1.0)))



def stencil(component: int) -> list[tuple[tuple[int, int, int], float]]:
    """The node offsets (in cells) and weights (× Δx^L) of a component's term (see
    :data:`MONOMIALS`): the product over the axes of the one-axis difference of each axis'
    power in the monomial (:data:`DIFFERENCES`): the monopole; a first to fourth difference
    along an axis; or a product of them (∂ᵢ∂ⱼ, ∂ᵢ²∂ⱼ, ∂ₓ∂ᵧ∂𝓏, ∂ᵢ³∂ⱼ, ∂ᵢ²∂ⱼ², ∂ᵢ²∂ⱼ∂ₖ). Nodes
    of weight 0 are left out."""
    powers = [MONOMIALS[component].count(axis) for axis in range(3)]
    (ox, wx), (oy, wy), (oz, wz) = (DIFFERENCES[p] for p in powers)
    return [((int(a), int(b), int(e)), float(u * v * w))
            for a, u in zip(ox, wx) if u != 0.0
            for b, v in zip(oy, wy) if v != 0.0
            for e, w in zip(oz, wz) if w != 0.0]
