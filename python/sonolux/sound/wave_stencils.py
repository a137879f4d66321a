"""The cluster's stencils (:mod:`sonolux.sound.wave_sources`): the components of a fit (the
monomials of orders 0 to :data:`HIGHEST_ORDER`), their node stencils (fourth-order centred
differences, Fornberg, "Generation of finite difference formulas on arbitrarily spaced grids",
Math. Comp. 51, 1988, and products of them), the stencils' amplitude errors in closed form, and
the rule for which orders a band radiates (the stencils' error at the band's upper edge and the
float32 floor of the signals fed below it, :func:`resolved_orders`, said in the log by
:func:`orders_note`)."""

from __future__ import annotations

import itertools
import math

import numpy as np

#: The highest spherical-harmonic order the components, stencils and moments carry (orders 5
#: and 6 since session 13: a 30° cone keeps 22.2 / 16.8 / 15.8% of its energy above orders
#: 4 / 5 / 6, the Legendre series of a hard edge converging slowly). Order 6 is radiated only
#: when a caller asks for it (``wave_sources.fit``'s ``orders``): see :data:`MAX_ORDER`.
HIGHEST_ORDER = 6
#: The highest order radiated by default and by the order rule (:func:`resolved_orders`): 5.
#: Order 6's float32 floor is not what the rule's bound predicts (measured by linearity on the
#: 137 mm grid, a 177 Hz hybrid's: 3.8·10⁻⁶ of the 125 Hz band where one rounding says 6.7·10⁻⁸;
#: order 5 there 3.0·10⁻⁷), so the rule cannot say where it is safe (docs/waves-sources.md).
MAX_ORDER = 5
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
#: Orders 4 to 6 are radiated in a band above the lowest only where one rounding of their largest
#: signal, (2⁻²⁴·G)² (:func:`feed_growth`), is at most this share of a band's energy: 60 dB
#: down, the range over which the tracer follows a ray (its default ``energy_drop_db``).
NOISE_FLOOR = 1e-6

#: Fourth-order centred differences (Fornberg 1988, table 1), × Δx^L: the L-th derivative on the
#: nodes −2..2 (L = 1, 2), −3..3 (L = 3, 4) and −4..4 (L = 5, 6: the fewest nodes for fourth-order
#: accuracy, L + 4 rounded up to odd; their weights are exact on the monomials mᵖ, p ≤ L + 3, and
#: give Σ w·m^{L+4} ≠ 0, the θ⁴ error of :func:`difference_response`); index = the derivative's
#: order.
DIFFERENCES = (
    (np.array([0]), np.array([1.0])),
    (np.arange(-2, 3), np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0),
    (np.arange(-2, 3), np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / 12.0),
    (np.arange(-3, 4), np.array([1.0, -8.0, 13.0, 0.0, -13.0, 8.0, -1.0]) / 8.0),
    (np.arange(-3, 4), np.array([-1.0, 12.0, -39.0, 56.0, -39.0, 12.0, -1.0]) / 6.0),
    (np.arange(-4, 5), np.array([1.0, -9.0, 26.0, -29.0, 0.0, 29.0, -26.0, 9.0, -1.0]) / 6.0),
    (np.arange(-4, 5),
     np.array([-1.0, 12.0, -52.0, 116.0, -150.0, 116.0, -52.0, 12.0, -1.0]) / 4.0),
)
FIRST_DIFFERENCE = DIFFERENCES[1][1]
SECOND_DIFFERENCE = DIFFERENCES[2][1]
THIRD_DIFFERENCE = DIFFERENCES[3][1]
FOURTH_DIFFERENCE = DIFFERENCES[4][1]
FIFTH_DIFFERENCE = DIFFERENCES[5][1]
SIXTH_DIFFERENCE = DIFFERENCES[6][1]
OFFSETS = np.arange(-2, 3)
#: The components of a fit, in the columns of :attr:`SourceFit.components`: order 0, order 1
#: along x, y, z, then order 2's monomials u_i·u_j (i ≤ j) with their coefficient (D_ii, 2·D_ij),
#: then order 3's u_i·u_j·u_k (i ≤ j ≤ k) with theirs (T_iii, 3·T_iij, 6·T_xyz), then order 4's
#: u_i·u_j·u_k·u_l (i ≤ j ≤ k ≤ l) with theirs (Q_iiii, 4·Q_iiij, 6·Q_iijj, 12·Q_iijk), then
#: orders 5 and 6's monomials (21 and 28, :data:`QUINTS`, :data:`SEXTS`, ordered as :data:`QUADS`),
#: each with its coefficient in the order's polynomial (``wave_moments.higher_order``).
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
TRIPLES = ((0, 0, 0), (1, 1, 1), (2, 2, 2), (0, 0, 1), (0, 0, 2), (0, 1, 1), (1, 1, 2),
           (0, 2, 2), (1, 2, 2), (0, 1, 2))
QUADS = tuple(sorted(itertools.combinations_with_replacement(range(3), 4),
                     key=lambda q: (len(set(q)), q)))
QUINTS = tuple(sorted(itertools.combinations_with_replacement(range(3), 5),
                      key=lambda q: (len(set(q)), q)))
SEXTS = tuple(sorted(itertools.combinations_with_replacement(range(3), 6),
                     key=lambda q: (len(set(q)), q)))
#: The monomials' index tuples, component by component (order 0 is the empty tuple).
MONOMIALS: tuple[tuple[int, ...], ...] = ((), (0,), (1,), (2,), *PAIRS, *TRIPLES, *QUADS,
                                          *QUINTS, *SEXTS)
#: The number of components (orders 0-6: 1 + 3 + 6 + 10 + 15 + 21 + 28 = 84; the first 35, orders
#: 0-4, are laid out as before session 13, so a fit of orders ≤ 4 has the same bits).
N_COMPONENTS = len(MONOMIALS)


def component_order(component: int) -> int:
    """The spherical-harmonic order (the derivative's) of a component of :data:`MONOMIALS`."""
    return len(MONOMIALS[component])



def monomials(u: np.ndarray) -> np.ndarray:
    """float64[direction, 84]: the monomials of :data:`MONOMIALS`: 1, u_x, u_y, u_z, u_i·u_j for
    :data:`PAIRS`, u_i·u_j·u_k for :data:`TRIPLES`, u_i·u_j·u_k·u_l for :data:`QUADS`, then those
    of orders 5 and 6."""
    return np.column_stack([np.prod(u[:, list(m)], axis=1) if m else np.ones(len(u))
                            for m in MONOMIALS])


def difference_response(derivative: int, kh: float) -> float:
    """R(θ): the response of the fourth-order difference of ``derivative`` (1 to 6) to a plane
    wave along its axis at θ = kΔx, over the exact derivative's (iθ)^L: (8 sin θ − sin 2θ)/(6θ)
    (1 − θ⁴/30), (30 − 32 cos θ + 2 cos 2θ)/(12θ²) (1 − θ⁴/90), (26 sin θ − 16 sin 2θ +
    2 sin 3θ)/(8θ³) (1 − 7θ⁴/120), (56 − 78 cos θ + 24 cos 2θ − 2 cos 3θ)/(6θ⁴)
    (1 − 7θ⁴/240), (29 sin θ − 26 sin 2θ + 9 sin 3θ − sin 4θ)/(3θ⁵) (1 − 13θ⁴/144 +
    67θ⁶/3024) and (75 − 116 cos θ + 52 cos 2θ − 12 cos 3θ + cos 4θ)/(2θ⁶) (1 − 13θ⁴/240 +
    67θ⁶/6048): Σ w_m e^{imθ} of the weights of :data:`DIFFERENCES`. Below θ = 0.1 (order 4)
    or 0.3 (orders 5 and 6) the closed forms cancel to rounding (10⁻¹⁶/θ^L), so their series is
    used there, :func:`difference_series`."""
    th = max(float(kh), 1e-12)
    if derivative == 1:
        return (8.0 * math.sin(th) - math.sin(2.0 * th)) / (6.0 * th)
    if derivative == 2:
        return (30.0 - 32.0 * math.cos(th) + 2.0 * math.cos(2.0 * th)) / (12.0 * th * th)
    if derivative == 3:
        return (26.0 * math.sin(th) - 16.0 * math.sin(2.0 * th) + 2.0 * math.sin(3.0 * th)) / (
            8.0 * th ** 3)
    if derivative == 4:
        if th < 0.1:  # the closed form cancels to rounding there (10⁻¹⁶/θ⁴): its series, to θ⁸
            return 1.0 - 7.0 * th ** 4 / 240.0 + 13.0 * th ** 6 / 3024.0
        return (56.0 - 78.0 * math.cos(th) + 24.0 * math.cos(2.0 * th)
                - 2.0 * math.cos(3.0 * th)) / (6.0 * th ** 4)
    if th < 0.3:
        return difference_series(derivative, th)
    if derivative == 5:
        return (29.0 * math.sin(th) - 26.0 * math.sin(2.0 * th) + 9.0 * math.sin(3.0 * th)
                - math.sin(4.0 * th)) / (3.0 * th ** 5)
    return (75.0 - 116.0 * math.cos(th) + 52.0 * math.cos(2.0 * th) - 12.0 * math.cos(3.0 * th)
            + math.cos(4.0 * th)) / (2.0 * th ** 6)


def difference_series(derivative: int, kh: float, terms: int = 8) -> float:
    """R(θ) of :func:`difference_response` as its Taylor series, Σ_n (Σ_m w_m·mⁿ)·i^{n−L}·θ^{n−L}/n!
    over n = L, L + 2, … (``terms`` of them; the weights' moments Σ w_m·mⁿ vanish for n < L and
    for n = L + 2, which is what fourth-order accuracy means; n of L's parity only, as the
    weights are even or odd): 1 − 13θ⁴/144 + 67θ⁶/3024 for the fifth difference."""
    offsets, weights = DIFFERENCES[derivative]
    out = 0.0
    for j in range(terms):
        n = derivative + 2 * j
        moment = float(np.dot(weights, offsets.astype(float) ** n))
        out += moment * (-1.0) ** j * kh ** (2 * j) / math.factorial(n)
    return out


def stencil_error(order: int, kh: float) -> float:
    """The worst amplitude error, over all directions, of the cluster's terms of ``order`` at
    kΔx = ``kh``: the worst |1 − R| (:func:`difference_response`) of the one-axis differences
    the order's terms are products of (order 1: first differences; order 2: second and first;
    order 3: third, second and first; order L: the first to the L-th: order 6's ∂ᵢ⁵∂ⱼ holds a
    fifth difference, whose 13θ⁴/144 is the worst of all). A product term's error is worst
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
    :data:`RESOLVED_AMPLITUDE` in every direction at the band's upper edge (0 where none is)
    (:func:`stencil_orders`); orders 4 and 5 only above the lowest band
    (:data:`LOWEST_BAND_MAX_ORDER`) and where one rounding of their largest signal,
    (2⁻²⁴·G)² with G = :func:`feed_growth`, is at most :data:`NOISE_FLOOR` (:func:`floor_orders`).

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
    1.4·10⁻⁵), hence the bound, applied alike to order 5 (session 13): measured on the 137,
    97 and 69 mm grids (the 177, 250 and 354 Hz hybrids'), the orders it chooses leave
    ≤ 3.0·10⁻⁷, 8.6·10⁻⁷ and 2.6·10⁻⁷ of a wave band, and order 5 where it withholds it
    (125 Hz on 69 mm, one rounding 3.9·10⁻⁶) 1.8·10⁻⁶ (tests/sound/test_wave_sources_order6_grid.py).
    The bound does not predict order 6 (measured/one rounding 3.7-57×, both sides of the line),
    so :data:`MAX_ORDER` is 5. As G grows with L (kΔx < 1 below the band), the bound passes
    an order only if it passes every order below it: the rule takes the highest that passes,
    and for ``max_order`` 4 it is session 10's rule, the same orders."""
    return np.minimum(stencil_orders(bands_hz, spacing_m, speed_of_sound_m_s, max_order),
                      floor_orders(bands_hz, spacing_m, speed_of_sound_m_s, max_order))


def stencil_orders(bands_hz: np.ndarray, spacing_m: float, speed_of_sound_m_s: float,
                   max_order: int = MAX_ORDER) -> np.ndarray:
    """int[band]: the highest order ≤ ``max_order`` whose stencils are within
    :data:`RESOLVED_AMPLITUDE` in every direction at the band's upper edge (0 where none is):
    what the grid resolves, :func:`stencil_error`."""
    out = []
    for f in band_upper_edges_hz(bands_hz):
        kh = 2.0 * math.pi * f * spacing_m / speed_of_sound_m_s
        out.append(max(L for L in range(max_order + 1)
                       if stencil_error(L, kh) <= RESOLVED_AMPLITUDE))
    return np.array(out, dtype=int)


def floor_orders(bands_hz: np.ndarray, spacing_m: float, speed_of_sound_m_s: float,
                 max_order: int = MAX_ORDER) -> np.ndarray:
    """int[band]: the highest order ≤ ``max_order`` the float32 floor allows: 3
    (:data:`LOWEST_BAND_MAX_ORDER`) in the lowest band; above it, the highest L whose one
    rounding (2⁻²⁴·G_L)² (:func:`feed_growth`) is at most :data:`NOISE_FLOOR`, at least 3
    (orders 0-3 are not bounded by it: measured below it on every grid tried)."""
    out = []
    for b in range(np.asarray(bands_hz).size):
        top = min(max_order, LOWEST_BAND_MAX_ORDER)
        if b > 0:
            for L in range(LOWEST_BAND_MAX_ORDER + 1, max_order + 1):
                if floor_share(bands_hz, b, spacing_m, speed_of_sound_m_s, L) > NOISE_FLOOR:
                    break
                top = L
        out.append(top)
    return np.array(out, dtype=int)


def floor_share(bands_hz: np.ndarray, band: int, spacing_m: float, speed_of_sound_m_s: float,
                order: int) -> float:
    """(2⁻²⁴·G)²: one float32 rounding of an order-``order`` term's largest signal below
    ``band`` (:func:`feed_growth`), as a share of the band's energy."""
    return (FLOAT32_ROUNDING * feed_growth(bands_hz, band, spacing_m, speed_of_sound_m_s,
                                           order)) ** 2


def orders_note(bands_hz: np.ndarray, spacing_m: float, speed_of_sound_m_s: float,
                n_bands: int | None = None) -> str:
    """The log's words for why each of the first ``n_bands`` bands radiates up to the order it
    does: what the stencils resolve at its upper edge and what the float32 floor allows, with
    the floor's one rounding for the first order it withholds (e.g. "the grid's stencils
    resolve orders up to 6/6/6 (…), the float32 floor allows 3/4/6 (one float32 rounding of the
    next order's signal: order 5 at 125 Hz 3.9e-06 of the band, above 1e-06)")."""
    b = np.asarray(bands_hz, float)
    n = b.size if n_bands is None else max(1, min(int(n_bands), b.size))
    grid = stencil_orders(b, spacing_m, speed_of_sound_m_s)[:n]
    floor = floor_orders(b, spacing_m, speed_of_sound_m_s)[:n]
    words = (f"the {1e3 * spacing_m:.0f} mm grid's stencils resolve orders up to "
             f"{'/'.join(str(int(L)) for L in grid)} (within {100 * RESOLVED_AMPLITUDE:.0f}% at "
             f"each band's upper edge), the float32 floor allows "
             f"{'/'.join(str(int(L)) for L in floor)}")
    why = [f"order {int(floor[k]) + 1} at {b[k]:g} Hz "
           f"{floor_share(b, k, spacing_m, speed_of_sound_m_s, int(floor[k]) + 1):.1e}"
           for k in range(1, n) if floor[k] < min(grid[k], MAX_ORDER)]
    if why:
        words += (f" (one float32 rounding of the next order's signal: {', '.join(why)} of the "
                  f"band, above {NOISE_FLOOR:.0e})")
    return words


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
    """float64[frequency]: the fade of orders 2 to 6, 0 below half of :func:`lowest_filter_hz`, 1 above
    it, a raised sine in log frequency across that octave."""
    top = lowest_filter_hz(bands_hz)
    with np.errstate(divide="ignore"):
        x = 2.0 * np.log2(np.maximum(f_hz, 1e-300) / top) + 1.0  # −1 at top/2, 1 at top
    return 0.5 * (1.0 + np.sin(0.5 * np.pi * np.clip(x, -1.0, 1.0)))



def stencil(component: int) -> list[tuple[tuple[int, int, int], float]]:
    """The node offsets (in cells) and weights (× Δx^L) of a component's term (see
    :data:`MONOMIALS`): the product over the axes of the one-axis difference of each axis'
    power in the monomial (:data:`DIFFERENCES`): the monopole; a first to fourth difference
    along an axis; or a product of them (∂ᵢ∂ⱼ, ∂ᵢ²∂ⱼ, ∂ₓ∂ᵧ∂𝓏, ∂ᵢ³∂ⱼ, ∂ᵢ²∂ⱼ², ∂ᵢ²∂ⱼ∂ₖ, and
    orders 5 and 6's, up to ∂ᵢ⁵∂ⱼ, whose farthest node is √20 cells away). Nodes of weight 0 are
    left out."""
    powers = [MONOMIALS[component].count(axis) for axis in range(3)]
    (ox, wx), (oy, wy), (oz, wz) = (DIFFERENCES[p] for p in powers)
    return [((int(a), int(b), int(e)), float(u * v * w))
            for a, u in zip(ox, wx) if u != 0.0
            for b, v in zip(oy, wy) if v != 0.0
            for e, w in zip(oz, wz) if w != 0.0]
