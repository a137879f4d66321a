"""Directional sources in the waves: a cluster of monopoles fitted to the source's pattern per band.

The wave solver's source is a point monopole. A directional source is a cluster of them, each
fed its own signal, whose far field is the pattern's low-order spherical-harmonic part (Bilbao
and Hamilton, "Directional sources in wave-based acoustic simulation", IEEE/ACM TASLP 27(2),
2019: a source as a weighted sum of spatial derivatives of the delta, the derivative of order L
radiating the pattern u^α of degree L; on the grid, the derivatives become finite differences,
monopoles at neighbouring nodes). Here:

- **Fit, per band.** The pattern's amplitude A_b(u) (the square root of the engine's energy
  gain towards u, normalised over the sphere; signed for the first-order family, whose pressure
  a + (1 − a)·cos θ changes sign behind the hypercardioid, supercardioid and figure-of-eight)
  is projected on the spherical harmonics of orders 0 to 6 by a product Gauss quadrature
  (:func:`fit_directions`): c₀ = ⟨A⟩; c = 3⟨A·u⟩ (order 1, c·u);
  order 2 as uᵀDu with D = (15/2)(M − tr M·I/3), M = ⟨A·uuᵀ⟩, the addition theorem's
  5·⟨A(v)·P₂(u·v)⟩ written in Cartesian form (D symmetric and traceless); order 3 as
  T_ijk·u_i u_j u_k, the addition theorem's 7·⟨A(v)·P₃(u·v)⟩ in the same form (T symmetric and
  traceless, :func:`fit`); order 4 as Q_ijkl·u_i u_j u_k u_l, the addition theorem's
  9·⟨A(v)·P₄(u·v)⟩ (:func:`fourth_order`); orders 5 and 6 as their monomials' coefficients,
  the same theorem in general form (``wave_moments.higher_order``). Each band keeps the orders
  the grid resolves there (:func:`resolved_orders`); the fit is scaled to radiate the source's
  power, c₀² + |c|²/3 + (2/15)·tr D² + (2/35)·ΣT² + (8/315)·ΣQ² + ⟨part₅²⟩ + ⟨part₆²⟩ = 1 (the
  means of the harmonics' squares; the tracer's convention), and the share of the pattern's
  energy above the band's order is reported (:attr:`SourceFit.residual`). Orders a band's
  pattern hardly carries are left out, and the bands above the waves' hold the last wave band's
  fit (:func:`fit`, :func:`fit_on_grid`). *Phase*: a SOFA file's measured relative phase at each
  band centre (:func:`measured_phase`); the builtin talker's model phase (a point on a rigid
  sphere, Morse & Ingard's series referred to the mouth) is, in the wave bands, that of a point
  a/2 in front of the mouth (within 0.6% of the energy at 500 Hz), so its zero-phase pattern is
  radiated from there (:func:`acoustic_centre_offset_m`); none for the dodecahedron, whose
  harmonics of orders 1-5 vanish by its symmetry, so that a phase could only be common to every
  direction (docs/waves-sources.md: why neither zero nor minimum phase).
- **Cluster.** Every term sits at a whole number of cells from the source, x_s + m·Δx, so that
  each term's trilinear spread over the 8 nodes around it has the same fractional offset: the
  cluster is then exactly a node stencil convolved with the omni source's own spread, and its
  far field is the stencil's (this is why the terms are not at ±Δx/2: a half-cell term spread
  over two nodes loses cos(kΔx/2) that the centre term does not, and breaks the differences).
  A SOFA source's band whose own acoustic centre the fit flags (``wave_centre.centres_differ``)
  gets a cluster of its own there, weighted by the edge blends' partition of unity
  (:meth:`SourceFit.clusters`, :func:`terms`; docs/waves-sources.md).
  The stencils are the fourth-order centred differences (Fornberg, "Generation of finite
  difference formulas on arbitrarily spaced grids", Math. Comp. 51, 1988): ∂ ≈ (δ₋₂ − 8δ₋₁ +
  8δ₁ − δ₂)/(12Δx), ∂² ≈ (−δ₋₂ + 16δ₋₁ − 30δ₀ + 16δ₁ − δ₂)/(12Δx²), ∂³ ≈ (δ₋₃ − 8δ₋₂ +
  13δ₋₁ − 13δ₁ + 8δ₂ − δ₃)/(8Δx³), ∂⁴ on −3..3, ∂⁵ and ∂⁶ on −4..4, and a mixed term as the
  product of one-axis differences (``wave_stencils.py``, with each difference's response R(θ) in
  closed form: 1 − θ⁴/30 for a first difference, … 1 − 13θ⁴/144 for a fifth).
- **Signals.** A monopole fed q̇ radiates ρq̇(τ)/(4πr). A term f(t)·∂^α δ of order L radiates
  (−1/c)^L·u^α·f^{(L)}(τ)·ρ/(4πr) in the far field, so order 1 is fed c·c_k·q, order 2 c²·(its
  coefficient)·∫q, and so on to order 6, c⁶·∫⁵q: the coefficient times the pulse integrated
  L − 1 times. ∫q has a DC part (a step), which a soft source must not be fed (Sheaffer, van
  Walstijn and Fazenda, JASA 135(1), 2014): orders 2 to 6 are faded out below the lowest band's
  filter (a raised sine in log frequency over the octave below where that band's filter starts,
  :func:`order2_fade`), where no band looks. On the grid each order's gains are pre-compensated
  for the 7-point scheme's dispersion, which an order-L term carries L times and along its
  group direction (``wave_dispersion``; residual stated there). The coefficients are each
  band's within the band and blend across a quarter band on either side of each band edge (the
  width of the energy bands' own crossovers in ``bands.rs``), flat beyond the outer bands,
  applied to the pulse by FFT; the pulse is delayed (:func:`pulse_delay_s`) so that the filters'
  non-causal half fits before it.
- **Which orders, per band** (:func:`resolved_orders`): the highest L ≤ :data:`MAX_ORDER` (5)
  whose stencils err by at most :data:`RESOLVED_AMPLITUDE` (2%) in every direction at the
  band's upper edge (every wave band of the hybrid's grid resolves 5: 0.34% at the crossover),
  and, above order 3, only above the lowest band and where one float32 rounding of its largest
  signal below the band is at most 10⁻⁶ of it (measured by linearity; order 6, whose floor that
  bound does not predict, only when asked). The log says both limits and the energy left.
- **Direct sound.** The terms' direct sound is taken out of the responses in the core (each a
  monopole with its own signal) and the exact pattern's direct sound is added back by the bake
  (the tracer's gain towards each receiver), so the direct sound is the target's exactly and only
  the room's part carries the fit.
- **Room around the source.** The terms reach :func:`reach_m` from the source (2 cells for
  order 1 up to √17 for order 5's ∂ᵢ³∂ⱼ∂ₖ and √20 for order 6's ∂ᵢ⁵∂ⱼ,
  :meth:`SourceFit.reach_cells`). Near a wall the orders are capped to the highest whose cluster
  fits in the air around the source (:func:`fit_on_grid`, said in the log); a directional source
  nearer a wall than even order 1 reaches is refused before anything is traced
  (:func:`check_clearance`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import fft as sfft

from sonolux.errors import SettingError
from sonolux.scene.directivity import FIRST_ORDER, TALKER_HEAD_RADIUS_M
from sonolux.sound.wave_centre import band_centres_m, centres_differ, refer_to_centre
from sonolux.sound.wave_dispersion import compensated
from sonolux.sound.wave_moments import FIT_AZIMUTHS, FIT_RINGS, fit_directions, moments, truncated
from sonolux.sound.wave_moments import fibonacci_directions as fibonacci_directions
from sonolux.sound.wave_moments import fourth_order as fourth_order
from sonolux.sound.wave_stencils import DIFFERENCES as DIFFERENCES
from sonolux.sound.wave_stencils import FIRST_DIFFERENCE as FIRST_DIFFERENCE
from sonolux.sound.wave_stencils import FOURTH_DIFFERENCE as FOURTH_DIFFERENCE
from sonolux.sound.wave_stencils import (
    HIGHEST_ORDER,
    MAX_ORDER,
    RESOLVED_AMPLITUDE,
    component_order,
    lowest_filter_hz,
    monomials,
    order2_fade,
    orders_note,
    resolved_orders,
    stencil,
)
from sonolux.sound.wave_stencils import N_COMPONENTS as N_COMPONENTS
from sonolux.sound.wave_stencils import OFFSETS as OFFSETS
from sonolux.sound.wave_stencils import SECOND_DIFFERENCE as SECOND_DIFFERENCE
from sonolux.sound.wave_stencils import THIRD_DIFFERENCE as THIRD_DIFFERENCE
from sonolux.sound.wave_stencils import band_upper_edges_hz as band_upper_edges_hz
from sonolux.sound.wave_stencils import difference_response as difference_response
from sonolux.sound.wave_stencils import stencil_error as stencil_error

#: The pulse of a directional source is delayed by this many periods of the lowest frequency its
#: filters pass (the lowest band centre; with orders 2-4, where their fade starts), plus its
#: own 6σ: room for the non-causal half of the coefficient filters.
PRE_PERIODS = 4.0
#: The air density the wave settings use (the core's WaveSettings default): the terms' signals
#: are volume accelerations scaled as the core's reference pulse.
AIR_DENSITY_KG_M3 = 1.2
#: A fitted component below this in every band is left out (ten times the fit lattice's
#: quadrature error; < 0.02% of the pattern's energy).
NEGLIGIBLE = 1e-4


@dataclass(frozen=True)
class SourceFit:
    """A pattern's spherical-harmonic fit per band, orders 0 to :attr:`orders`."""

    #: float64[band, 84] (complex128 with a measured phase): c₀; c_x, c_y, c_z; then the
    #: coefficients of u_i·u_j for the pairs :data:`PAIRS` (D_xx, D_yy, D_zz, 2D_xy, 2D_xz,
    #: 2D_yz); then of u_i·u_j·u_k for :data:`TRIPLES` (T_xxx, T_yyy, T_zzz, 3T_xxy, …,
    #: 6T_xyz); then of u_i·u_j·u_k·u_l for :data:`QUADS` (Q_xxxx, …, 12Q_xxyz); then orders 5
    #: and 6's monomials' coefficients (``wave_moments.higher_order``); world frame, scaled so
    #: that the fitted pattern radiates the source's power; zero above the band's order.
    components: np.ndarray
    #: int[band]: the highest order radiated in each band.
    orders: np.ndarray
    #: float64[band]: the share of the pattern's energy above the band's order (0 for the
    #: first-order family).
    residual: np.ndarray
    #: Why orders were left out that the grid resolves (a wall too near, :func:`fit_on_grid`),
    #: for the log; empty otherwise.
    note: str = ""
    #: What the grid resolves and the float32 floor allows per wave band, the order rule's
    #: reasons (``wave_stencils.orders_note``; set by :func:`fit_on_grid`), for the log.
    grid_note: str = ""
    #: float64[3]: the cluster's centre from the source's position (:func:`acoustic_centre_offset_m`).
    centre_offset_m: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    #: float64[band, 3]: each centred band's own acoustic centre from the measured phase
    #: (``wave_centre.band_centres_m``; no rows without a measured phase), for
    #: :func:`centred`'s check that the bands share one.
    band_centres_m: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    #: bool[band] of those: whether the band's own centre differs measurably from the shared
    #: one (``wave_centre.centres_differ``).
    centres_differ: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, bool))
    #: bool[band] (empty: none): whether the band is radiated from its own acoustic centre, by a
    #: cluster of its own (:func:`terms`), instead of from the shared one: the bands
    #: :attr:`centres_differ` flags (and, held above the waves, the rows that copy such a band).
    apart: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, bool))
    #: float64[band, 84] (complex128 with a measured phase): where :attr:`apart`, the band's
    #: components with its pattern referred to its own centre (same orders and power
    #: normalisation as :attr:`components`); zero elsewhere.
    own_components: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, N_COMPONENTS)))
    #: float64[band, 3]: where :attr:`apart`, its own cluster's centre from the source's; else 0.
    own_centres_m: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def coefficients(self) -> np.ndarray:
        """float64[band, 4]: c₀, c_x, c_y, c_z."""
        return self.components[:, :4]

    def amplitude(self, directions: np.ndarray) -> np.ndarray:
        """float64[direction, band]: the fitted pattern's amplitude towards unit directions."""
        return monomials(np.asarray(directions, float)) @ self.components.T

    def energy_gain(self, directions: np.ndarray) -> np.ndarray:
        """float64[direction, band]: the fitted pattern's energy gain towards unit directions."""
        return np.abs(self.amplitude(directions)) ** 2

    def reach_cells(self) -> float:
        """How far from the source the cluster's terms reach, in cells: the farthest node of
        any component it uses (:func:`stencil`): 0 (omni), 2 (orders 1 and 2 along the axes),
        2√2 (order 2's mixed terms, order 3's ∂ᵢ²∂ⱼ, order 4's ∂ᵢ²∂ⱼ²), 3 (orders 3 and 4
        along an axis), 2√3 (order 3's ∂ₓ∂ᵧ∂𝓏, order 4's ∂ᵢ²∂ⱼ∂ₖ), √13 (order 4's ∂ᵢ³∂ⱼ),
        √17 (order 5's ∂ᵢ³∂ⱼ∂ₖ; its ∂⁵ along an axis reaches 4) or √20 (order 6's ∂ᵢ⁵∂ⱼ)."""
        return components_reach_cells(self.components)

    def clusters(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The clusters the source is radiated by, each (its centre float64[3] from the source's
        position, its components [band, 84] with zero rows for the bands it does not carry):
        the shared centre's for every band not :attr:`apart`, then one for each own centre
        (bands in order; rows held above the waves go with the band they copy). Without such
        bands, the one cluster is :attr:`components` itself."""
        apart = np.asarray(self.apart, bool)
        if not np.any(apart):
            return [(self.centre_offset_m, self.components)]
        zero = np.zeros_like(self.components[:1])
        out = [(self.centre_offset_m, np.where(apart[:, None], zero, self.components))]
        seen: list[tuple[float, ...]] = []
        for b in np.flatnonzero(apart):
            key = tuple(float(v) for v in self.own_centres_m[b])
            if key in seen:
                continue
            seen.append(key)
            rows = apart & np.all(self.own_centres_m == self.own_centres_m[b][None], axis=1)
            out.append((self.own_centres_m[b].copy(),
                        np.where(rows[:, None], self.own_components, zero)))
        return out


def components_reach_cells(components: np.ndarray) -> float:
    """How far the terms of ``components`` [band, 84] reach from their cluster's centre, in
    cells (:meth:`SourceFit.reach_cells`)."""
    used = np.flatnonzero(np.any(components != 0.0, axis=0))
    return max((math.sqrt(sum(o * o for o in offset)) for k in used
                for offset, _ in stencil(int(k))), default=0.0)


def amplitude(source: Any, directivity: Any, directions: np.ndarray, n_bands: int,
              bands_hz: np.ndarray | None = None) -> np.ndarray:
    """float64[direction, band] (complex128 with a measured phase): the source's pressure
    pattern, √(energy gain); signed where the first-order family's a + (1 − a)·cos θ is
    negative; times the measured relative phase at each band centre for a SOFA directivity that
    carries one (:func:`measured_phase`, given ``bands_hz``). The builtin talker's model phase
    is radiated by moving its cluster instead (:func:`acoustic_centre_offset_m`)."""
    a = np.sqrt(np.maximum(np.asarray(directivity.gains(directions, n_bands), float), 0.0))
    if source.directivity in FIRST_ORDER:
        f = np.asarray(source.forward, float)
        f = f / np.linalg.norm(f)
        first = FIRST_ORDER[source.directivity]
        a = a * np.where(first + (1.0 - first) * (directions @ f) < 0.0, -1.0, 1.0)[:, None]
    if bands_hz is not None:
        phase = measured_phase(source, directions, bands_hz)
        if phase is not None:
            return a * phase
    return a


def acoustic_centre_offset_m(source: Any) -> np.ndarray:
    """float64[3]: where a source's cluster is centred, from its position. The builtin talker
    (a point mouth on a rigid sphere of radius a, the source's position being the mouth) has a
    far field whose phase in the wave bands is that of a point a/2 in front of the mouth (the
    series' first terms, 1 − (3/2)·i·ka·cos θ from the head's centre; ``talker_phase``), so
    its zero-phase pattern is radiated from there: exact for that translation at every
    frequency, and the phase left is ≤ 0.06% of the energy up to 354 Hz, 0.57% at 500 Hz
    (docs/waves-sources.md). Every other source: its position."""
    if source.directivity == "talker":
        return 0.5 * TALKER_HEAD_RADIUS_M * unit(source.forward)
    return np.zeros(3)


def unit(v: Any) -> np.ndarray:
    """float64[3]: ``v`` over its length."""
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def measured_phase(source: Any, directions: np.ndarray, bands_hz: np.ndarray) -> np.ndarray | None:
    """complex128[direction, band]: a SOFA source's relative phase (its file's complex transfer
    functions, ``SofaDirectivity.relative_phase``) at each band centre, towards world
    ``directions``; None for any other source. Per measured direction, the phasor is
    interpolated linearly in frequency to the centre; over the sphere, on the measured
    directions' triangulation as the energy is (real and imaginary parts, then made unit).
    Band energy stays the tracer's; only the phase is added."""
    from sonolux.scene.sofa_directivity import sphere_interpolate

    sofa = getattr(source, "sofa", None) if source.directivity == "sofa" else None
    phase = getattr(sofa, "relative_phase", None)
    if sofa is None or phase is None:
        return None
    f = np.asarray(sofa.frequencies_hz, float)
    centres = np.clip(np.asarray(bands_hz, float), f[0], f[-1])
    at = np.stack([np.interp(centres, f, p.real) + 1j * np.interp(centres, f, p.imag)
                   for p in phase])  # [measured direction, band]
    forward = np.asarray(source.forward, float)
    up = np.asarray(source.up, float)
    forward, up = forward / np.linalg.norm(forward), up / np.linalg.norm(up)
    local = np.asarray(directions, float) @ np.column_stack([forward, np.cross(up, forward), up])
    parts = sphere_interpolate(sofa.directions, np.hstack([at.real, at.imag]), local)
    z = parts[:, :len(centres)] + 1j * parts[:, len(centres):]
    magnitude = np.abs(z)
    return np.where(magnitude > 0, z / np.where(magnitude > 0, magnitude, 1.0), 1.0)


def fit(source: Any, directivity: Any, n_bands: int, orders: np.ndarray | None = None,
        bands_hz: np.ndarray | None = None, *, centre_bands: int | None = None,
        speed_of_sound_m_s: float = 343.0, own_centres: bool = True) -> SourceFit:
    """The source's fit per band (see the module's doc), of orders ``orders`` (int[band]; None:
    :data:`MAX_ORDER` in every band); with ``bands_hz``, a SOFA source's measured phase is
    fitted too (complex coefficients), referred to its acoustic centre found from that phase
    in the first ``centre_bands`` bands (all if None; ``wave_centre.refer_to_centre``),
    where its cluster is then centred; a band whose own centre differs measurably
    (``wave_centre.centres_differ``) is fitted about its own centre too and radiated from there
    (:attr:`SourceFit.apart`) unless ``own_centres`` is False. The first-order family is order 1
    exactly and is fitted to order 1 only (its higher part is the lattice's quadrature error). In each band,
    orders above the highest that carries :data:`RESOLVED_AMPLITUDE`² (4·10⁻⁴) of the pattern's
    energy are left out (:attr:`SourceFit.orders` says which are radiated): such an order's
    amplitude is below the error allowed to the stencils of the orders that are radiated, and
    leaving it out spares its terms and the room they need around the source (a talker's
    order 3 below 500 Hz: ≤ 0.004% of its energy, 70 more monopoles, 43 mm more clearance at a
    354 Hz crossover).

    Order 3 is u·T·u·u with T = (35/2)·N − (7/2)·(m_i δ_jk + m_j δ_ik + m_k δ_ij),
    N = ⟨A·v_i v_j v_k⟩ and m = ⟨A·v⟩: the addition theorem's 7⟨A(v)·P₃(u·v)⟩, P₃(x) =
    (5x³ − 3x)/2, with u·v written as (u·v)(u·u) on the sphere. T is symmetric and traceless
    (its trace is 35/2·m − 7/2·5m = 0), so it is order 3 only, and the mean of its square over
    the sphere is (2/35)·Σ T_ijk² (of the 15 pairings in ⟨u⁶⟩ = (1/105)·Σ δδδ only the 6
    that pair each index of one T with the other's survive a trace-free T)."""
    orders = np.full(n_bands, MAX_ORDER, int) if orders is None else np.asarray(orders, int)
    if source.directivity in FIRST_ORDER:
        orders = np.minimum(orders, 1)
    u, weight = fit_directions()
    a = amplitude(source, directivity, u, n_bands, bands_hz)  # [direction, band]
    centre = acoustic_centre_offset_m(source)
    own = np.zeros((0, 3))
    if np.iscomplexobj(a) and bands_hz is not None:  # a measured phase: its acoustic centre
        k = 2.0 * math.pi * np.asarray(bands_hz, float) / speed_of_sound_m_s
        rings = np.polynomial.legendre.leggauss(FIT_RINGS)[0]
        n_centre = k.size if centre_bands is None else max(1, min(int(centre_bands), k.size))
        own = band_centres_m(a[:, :n_centre], u, weight, rings, FIT_AZIMUTHS, k[:n_centre])
        measured = a
        a, centre = refer_to_centre(a, u, weight, rings, FIT_AZIMUTHS, k, centre_bands)
    c0, c, m, d, t, q, higher, shares, total = moments(a, u, weight)
    carried = shares >= RESOLVED_AMPLITUDE ** 2 * np.maximum(total, 1e-300)[None]
    # The highest carried order the band may radiate: among 0-4 as before session 13, and up to
    # the band's order above that (the dodecahedron's order 6, 0.18%, is not radiated at 5).
    looked = np.arange(HIGHEST_ORDER + 1)[:, None] <= np.maximum(orders, 4)[None]
    highest = np.max(np.where(carried & looked, np.arange(HIGHEST_ORDER + 1)[:, None], 0), axis=0)
    orders = np.minimum(orders, highest)
    components, power = truncated(c0, c, d, t, q, higher, shares, orders)
    # A component the pattern lacks comes out at the lattice's quadrature error (1e-5 for a
    # cardioid on an axis): left out, it would only add terms and reach.
    components[:, np.max(np.abs(components), axis=0) < NEGLIGIBLE] = 0.0
    residual = np.clip(1.0 - power / np.maximum(total, 1e-300), 0.0, 1.0)
    differ = np.zeros(len(own), bool)
    apart = np.zeros(0, bool)
    own_components, own_at = np.zeros((0, components.shape[1])), np.zeros((0, 3))
    if len(own):
        # Each centred band referred to its own centre instead, with the same orders: what the
        # fit would leave out there, against what the shared centre leaves.
        n_own = len(own)
        k_own = 2.0 * math.pi * np.asarray(bands_hz, float)[:n_own] / speed_of_sound_m_s
        at_own = measured[:, :n_own] * np.exp(-1j * (u @ own.T) * k_own[None])
        c0_o, c_o, _, d_o, t_o, q_o, h_o, shares_own, total_own = moments(at_own, u, weight)
        own_fit, power_own = truncated(c0_o, c_o, d_o, t_o, q_o, h_o, shares_own,
                                       orders[:n_own])
        residual_own = np.clip(1.0 - power_own / np.maximum(total_own, 1e-300), 0.0, 1.0)
        differ = centres_differ(centre, own, k_own, orders[:n_own], residual[:n_own],
                                residual_own)
        if own_centres and np.any(differ):
            # A flagged band is radiated from its own centre (its own cluster, :func:`terms`),
            # its pattern referred there; what the fit leaves out is then what it leaves there.
            apart = np.zeros(n_bands, bool)
            apart[:n_own] = differ
            own_fit[np.abs(own_fit) < NEGLIGIBLE] = 0.0
            own_components = np.zeros_like(components, dtype=own_fit.dtype)
            own_components[:n_own][differ] = own_fit[differ]
            own_at = np.zeros((n_bands, 3))
            own_at[:n_own][differ] = own[differ]
            residual = residual.copy()
            residual[:n_own][differ] = residual_own[differ]
    return SourceFit(components, orders, residual, centre_offset_m=centre, band_centres_m=own,
                     centres_differ=differ, apart=apart, own_components=own_components,
                     own_centres_m=own_at)


def pulse_delay_s(bands_hz: np.ndarray, max_frequency_hz: float,
                  source_fit: SourceFit | None = None) -> float:
    """The delay of a directional source's pulse: its own 6σ plus :data:`PRE_PERIODS` periods of
    the lowest band centre, or, when ``source_fit`` radiates order 2 or more, of the frequency
    where their fade starts (its filter is as long as that fade is narrow)."""
    lowest = float(np.min(bands_hz))
    if source_fit is not None and np.any(source_fit.orders >= 2):
        lowest = 0.5 * lowest_filter_hz(bands_hz)
    return 6.0 / (math.pi * max_frequency_hz) + PRE_PERIODS / lowest


def longest_pulse_delay_s(bands_hz: np.ndarray, max_frequency_hz: float) -> float:
    """The longest delay :func:`pulse_delay_s` can give for these bands (a fit radiating order 2
    or more): what a plan made before the fit (the memory check at the edge) must assume."""
    return 6.0 / (math.pi * max_frequency_hz) + PRE_PERIODS / (0.5 * lowest_filter_hz(bands_hz))


def edge_blends(f_hz: np.ndarray, bands_hz: np.ndarray) -> np.ndarray:
    """float64[edge, frequency]: how much of the band above each edge (between centres i and
    i + 1, at their geometric mean) a frequency takes: 0 below a quarter band under the edge, 1
    above a quarter band over it, (1 + sin(πx/2))/2 between, x the log-frequency
    distance from the edge in those quarters."""
    b = np.asarray(bands_hz, float)
    edges = np.sqrt(b[:-1] * b[1:])
    width = 0.25 * np.log2(b[1:] / b[:-1])  # a quarter band, in octaves
    with np.errstate(divide="ignore"):
        x = np.log2(np.maximum(f_hz, 1e-300)[None] / edges[:, None]) / width[:, None]
    return 0.5 * (1.0 + np.sin(0.5 * np.pi * np.clip(x, -1.0, 1.0)))


def terms(position_m: np.ndarray, source_fit: SourceFit, bands_hz: np.ndarray,
          max_frequency_hz: float, spacing_m: float, sample_rate_hz: float, steps: int,
          speed_of_sound_m_s: float,
          courant: float | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The cluster of a directional source at ``position_m``: (positions float64[term, 3],
    volume accelerations float64[term, step] at n/fs, pulse delay s), for
    ``engine.simulate_waves(terms=...)``. Bands are those of ``source_fit``, centred at
    ``bands_hz``. One term per node offset, its signal the sum of every component's there, in
    a fixed order (same bits on any machine). Given the grid's ``courant`` number, each order's
    gains are pre-compensated for its dispersion (``wave_dispersion.compensated``); without, the
    terms radiate the fit as free-field monopoles (the closed-form checks)."""
    sigma = 1.0 / (math.pi * max_frequency_hz)
    delay = pulse_delay_s(bands_hz, max_frequency_hz, source_fit)
    q0 = 4.0 * math.pi * sigma * math.exp(0.5) / AIR_DENSITY_KG_M3  # as the core's SourcePulse
    t = np.arange(steps) / sample_rate_hz
    x = (t - delay) / sigma
    q = q0 * np.exp(-0.5 * x * x)
    q_dot = -q0 * x / sigma * np.exp(-0.5 * x * x)
    n_fft = sfft.next_fast_len(2 * steps, real=True)
    f = sfft.rfftfreq(n_fft, 1.0 / sample_rate_hz)
    b = np.asarray(bands_hz, float)
    blends = edge_blends(f, b)  # [edge, frequency]
    c, h = speed_of_sound_m_s, spacing_m
    # The signals of each order before its coefficient: q̇, c·q, c²·∫q, c³·∬q, c⁴·∭q (orders 2
    # to 4 faded out below the bands).
    spectra = [sfft.rfft(q_dot, n_fft), c * sfft.rfft(q, n_fft)]
    fade = order2_fade(f, b)  # 0 at DC, so 1/(iω) is never reached there
    per_integral = c / (2j * np.pi * np.where(fade > 0.0, f, 1.0))
    integrated = spectra[1] * fade * per_integral
    spectra.append(np.where(fade > 0.0, integrated, 0.0))
    spectra.append(np.where(fade > 0.0, integrated * per_integral, 0.0))
    spectra.append(np.where(fade > 0.0, integrated * per_integral ** 2, 0.0))
    # Orders 5 and 6: c⁵·∫⁴q and c⁶·∫⁵q, with the same fade.
    spectra.extend(np.where(fade > 0.0, integrated * per_integral ** (L - 2), 0.0)
                   for L in range(5, HIGHEST_ORDER + 1))
    positions: list[np.ndarray] = []
    signals: list[np.ndarray] = []
    # One cluster per centre (SourceFit.clusters): the shared one, and one for each band
    # radiated from its own. A cluster's coefficients are zero in the bands it does not carry,
    # so its gain c₀ + Σ_e (c_{e+1} − c_e)·blend_e = Σ_b c_b·w_b weighs band b by the blends'
    # partition of unity w_b = blend_{b−1} − blend_b (blend_{−1} = 1, blend_last = 0): the
    # clusters' weights sum to 1 at every frequency, and a band's cluster fades in and out
    # across its edges as its coefficients would.
    for offset_m, components in source_fit.clusters():
        by_offset: dict[tuple[int, int, int], np.ndarray] = {}
        gains = {k: components[0, k] + np.diff(components[:, k]) @ blends
                 for k in range(components.shape[1]) if np.any(components[:, k] != 0.0)}
        if courant is not None:
            gains = compensated(gains, 2.0 * np.pi * f * h / c, courant)
        for k, gain in gains.items():
            order = component_order(k)
            signal = sfft.irfft(spectra[order] * gain, n_fft)[:steps] / h ** order
            for offset, w in stencil(k):
                if offset in by_offset:
                    by_offset[offset] = by_offset[offset] + w * signal
                else:
                    by_offset[offset] = w * signal
        centre = np.asarray(position_m, float) + offset_m
        keys = sorted(by_offset)
        positions.extend(centre + h * np.asarray(o, float) for o in keys)
        signals.extend(by_offset[o] for o in keys)
    return np.array(positions), np.ascontiguousarray(signals), delay


def reach_m(source_fit: SourceFit, spacing_m: float) -> float:
    """How far from the source's position its cluster's terms reach (the cluster's centre may
    be moved from it, :attr:`SourceFit.centre_offset_m`)."""
    return max(components_reach_cells(components) * spacing_m + float(np.linalg.norm(offset_m))
               for offset_m, components in source_fit.clusters())


def check_clearance(scene: Any, max_frequency_hz: float, directivities: list[Any],
                    wave_bands: int | None = None) -> None:
    """Refuses a directional source nearer a wall than even its order-1 cluster reaches on the
    grid of ``max_frequency_hz`` (its terms would be outside the room's air), naming the
    source, its distance, the clearance it needs and what to do; a source with room for order
    1 but not for all the orders the grid resolves radiates the highest that fit
    (:func:`fit_on_grid`). ``directivities``: each source's engine directivity; ``wave_bands``:
    how many bands the waves give (None: those centred below the crossover, f_max/√2, the
    hybrid's rule in ``waves.choose_crossover``). Called by the bake once the crossover is
    known, before any ray is traced."""
    from sonolux import engine

    c = float(scene.settings.speed_of_sound_m_s)
    spacing_m = engine.WaveSettings(max_frequency_hz=float(max_frequency_hz), duration_s=1.0,
                                    speed_of_sound_m_s=c).spacing_m
    bands = np.asarray(scene.settings.bands_hz, float)
    if wave_bands is None:
        wave_bands = int(np.sum(bands < max_frequency_hz / math.sqrt(2.0)))
    positions = np.array([s.position_m for s in scene.sources], float)
    distance = np.asarray(scene.geometry.distance_to_surface(np.ascontiguousarray(positions)),
                          float)
    for i, (src, d) in enumerate(zip(scene.sources, directivities)):
        if src.directivity == "omni":
            continue
        fitted = fit_on_grid(src, d, bands, spacing_m, c, clearance_m=float(distance[i]),
                             wave_bands=wave_bands)
        need = reach_m(fitted, spacing_m)
        if distance[i] <= need:
            raise SettingError(
                f"waves: source {src.name or i + 1} ({src.directivity}) at "
                f"{tuple(round(float(v), 3) for v in src.position_m)} m is "
                f"{1e3 * distance[i]:.0f} mm from a wall; its cluster of monopoles (spherical "
                f"harmonics of order 0-{int(fitted.orders.max())} on the {1e3 * spacing_m:.0f} mm "
                f"grid) reaches {1e3 * need:.0f} mm, so it needs more than that much air on every "
                "side: move it into the room or make it omni")


def fit_on_grid(source: Any, directivity: Any, bands_hz: np.ndarray, spacing_m: float,
                speed_of_sound_m_s: float, clearance_m: float = math.inf,
                wave_bands: int | None = None) -> SourceFit:
    """The source's fit with, in each band, the highest order the grid of ``spacing_m``
    resolves (:func:`resolved_orders`); with ``wave_bands``, the bands above the waves' take
    the last wave band's fit (its pattern is held across the crossover, as the tracer's band
    holds it; the waves' result above is not used, and fitting those bands would only add
    terms and reach); and, when the source is ``clearance_m`` from the nearest wall, whose
    cluster fits inside that: each order's terms reach farther (2, 2√2, 3
    or 2√3 cells, :meth:`SourceFit.reach_cells`), so near a wall the orders are capped, the
    highest first, down to 1 (a cluster that does not fit even then is the caller's to refuse,
    :func:`check_clearance`); the fit's :attr:`SourceFit.note` says so, for the log. Bands
    radiated from their own centres (:attr:`SourceFit.apart`) count every centre's reach
    (:func:`reach_m`); where those clusters do not fit but the shared one would, the bands are
    radiated from the shared centre instead (said in the note)."""
    b = np.asarray(bands_hz, float)
    orders = resolved_orders(b, spacing_m, speed_of_sound_m_s)
    grid_note = orders_note(b, spacing_m, speed_of_sound_m_s, wave_bands)

    def held(f: SourceFit) -> SourceFit:
        if wave_bands is None or not 0 < wave_bands < b.size:
            return f
        keep = np.minimum(np.arange(b.size), wave_bands - 1)
        f = dataclasses.replace(f, components=f.components[keep], orders=f.orders[keep],
                                residual=f.residual[keep])
        if len(f.apart):
            f = dataclasses.replace(f, apart=f.apart[keep], own_components=f.own_components[keep],
                                    own_centres_m=f.own_centres_m[keep])
        return f

    def placed(radiated: np.ndarray) -> SourceFit:
        # Bands radiated from their own centres (wave_centre.centres_differ) whose clusters
        # would not fit in the air around the source fall back to the shared centre, which
        # costs them what the log's "own centres" words say, rather than refusing the source.
        f = held(fit(source, directivity, b.size, radiated, b, centre_bands=wave_bands,
                     speed_of_sound_m_s=speed_of_sound_m_s))
        if np.any(f.apart) and reach_m(f, spacing_m) >= clearance_m:
            shared = held(fit(source, directivity, b.size, radiated, b, centre_bands=wave_bands,
                              speed_of_sound_m_s=speed_of_sound_m_s, own_centres=False))
            if reach_m(shared, spacing_m) < clearance_m:
                return dataclasses.replace(shared, note=(
                    f"; radiated from the shared centre: the bands' own clusters would reach "
                    f"{1e3 * reach_m(f, spacing_m):.0f} mm, a wall {1e3 * clearance_m:.0f} mm "
                    "away"))
        return f

    fitted = dataclasses.replace(placed(orders), grid_note=grid_note)
    cap = int(fitted.orders.max())
    while cap > 1 and reach_m(fitted, spacing_m) >= clearance_m:
        wanted = reach_m(fitted, spacing_m)
        cap -= 1
        fitted = placed(np.minimum(orders, cap))
        fitted = dataclasses.replace(fitted, note=(
            f"; orders above {cap} left out: a wall {1e3 * clearance_m:.0f} mm away, and order "
            f"{cap + 1}'s cluster reaches {1e3 * wanted:.0f} mm" + fitted.note),
            grid_note=grid_note)
    return fitted


def describe(label: str, source_fit: SourceFit, n_terms: int, wave_bands: int) -> str:
    """The bake's log line for a directional source: its cluster, the orders per wave band and
    the pattern's energy above them."""
    orders = source_fit.orders[:wave_bands]
    return (f"waves: source {label} as {n_terms} monopoles, spherical harmonics of order "
            f"{'/'.join(f'0-{int(L)}' if L else '0' for L in orders)} per wave band; the pattern's "
            "energy above "
            f"them: {', '.join(f'{100 * r:.1f}%' for r in source_fit.residual[:wave_bands])}"
            + (f"; {source_fit.grid_note}" if source_fit.grid_note else "")
            + centred(source_fit) + source_fit.note)


def centred(source_fit: SourceFit) -> str:
    """The log's words for a cluster centred off the source's position (its acoustic centre)."""
    d = source_fit.centre_offset_m
    if not np.any(d != 0.0):
        return ""
    every = len(source_fit.apart) > 0 and bool(np.all(source_fit.apart))
    words = (f"; {'its shared' if every else 'radiated from its'} acoustic centre, "
             f"({', '.join(f'{1e3 * v:+.0f}' for v in d)}) mm from its position")
    if np.any(source_fit.centres_differ):
        apart = np.linalg.norm(source_fit.band_centres_m - d[None], axis=1)
        words += (f"; its bands' own centres lie {'/'.join(f'{1e3 * x:.0f}' for x in apart)} mm "
                  "from it (measured phase): one centre costs them more than the fit leaves out")
        if np.any(source_fit.apart):
            flagged = np.flatnonzero(source_fit.centres_differ) + 1
            words += (f", so wave band{'s' if len(flagged) > 1 else ''} "
                      f"{'/'.join(str(b) for b in flagged)} "
                      f"{'each radiate' if len(flagged) > 1 else 'radiates'} from its own centre "
                      "(a cluster of its own)")
    return words
