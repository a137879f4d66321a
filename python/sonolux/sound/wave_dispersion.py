"""The 7-point scheme's dispersion as a directional source's cluster sees it, and its
pre-compensation (:mod:`sonolux.sound.wave_sources`, session 13).

**The grid's far field of a cluster, in closed form.** The scheme is linear and shift-invariant,
so a term at node offset m radiates the grid's Green's function moved by mh. Far from the source
that function is, by stationary phase, a wave e^{i k_g·x}/r whose wavevector k_g(u) is the point
of the dispersion surface sin²(ωΔt/2) = λ² Σᵢ sin²(kᵢΔx/2) (von Neumann; Trefethen, "Group
velocity in finite difference schemes", SIAM Review 24(2), 1982; Bilbao, *Numerical Sound
Synthesis*, Wiley 2009; Kowalczyk and van Walstijn, IEEE TASL 19(1), 2011, the standard
rectilinear scheme) whose normal, the group velocity ∇_k ω, points towards the
receiver u. Its gradient is ∝ (sin k_xΔx, sin k_yΔx, sin k_zΔx), so **k_g(u) is closed form up
to one scalar**: kᵢΔx = arcsin(a·uᵢ), a from Σᵢ (1 − √(1 − a²uᵢ²))/2 = sin²(λθ/2)/λ² (θ = ωΔx/c;
:func:`group_wavenumbers`). The moved Green's function is then G(x)·e^{−i k_g·m Δx}, so the
cluster's far field over an omni source's at the same place is **its stencils' symbol at k_g(u)**,
not at the physical k·u: a component ∂^α (order L = |α|), fed (ik)^{−L}, radiates
Πᵢ Dₚᵢ(kᵍᵢΔx)/(iθ)^{pᵢ} (Dₚ(φ) = Σ w_m e^{imφ}, the weights of ``wave_stencils.DIFFERENCES``)
where the exact source radiates u^α (:func:`grid_monomials`). Two things differ at second order
in θ: the length, |k_g|/k = 1 + θ²(Σvᵢ⁴ − λ²)/24 (v = k_g/|k_g|: θ²/36 along the axes and 0 on
the diagonals at λ = 1/√3, the phase-velocity error of docs/waves.md), which an order-L part
carries L times; and the direction, the phase vector v against the group direction u,
vᵢ = uᵢ(1 + θ²(uᵢ² − Σu⁴)/6), zero on the axes and diagonals, as large elsewhere. So an order-L
part P_L(u·a) errs in amplitude, worst over directions and axes a, by 0.93 / 1.50 / 2.24 / 2.96 /
3.38 / 3.88% of its peak (orders 1-6) at θ = 0.444, the top wave band's upper edge of every hybrid
(crossover f_max/√2), where the stencils alone err by ≤ 0.33% (``notes/s13/i18disp_scripts``).

**Pre-compensation, per frequency, in the same components.** As D_p is known in closed form at
every k_g, the order-L gains fed at each frequency can be chosen so that the grid's far field is
the exact pattern as nearly as the components allow: the least-squares solution over the sphere
(a Gauss product quadrature, :data:`RINGS`), c'(θ) = T(θ)·c with
T = (G_Sᵀ W G_S)⁻¹ G_Sᵀ W U (G_S the grid's far fields of the components the source already has,
U the exact monomials of its order, W the weights): **no new component, term or reach**, exact in
frequency (T tabulated in θ and interpolated, :func:`compensation_table`), and what it leaves is
stated: the error's parts of degree above L, which no order-L stencil can radiate (the group
direction's error of an order-1 term is all there: 0.93 → 0.90%), and for orders 2-6 at θ = 0.444
1.50 → 0.80, 2.24 → 0.99, 2.96 → 1.32, 3.38 → 1.73, 3.88 → 2.01% (about half; all components
of the order present). It is not exact because no finite stencil is: u = s/|s| with s the
central differences' symbol, and |s|² = 4C − 4Σσᵢ² (σᵢ = sin²(kᵢΔx/2), C = Σσᵢ, constant on the
surface) varies over the surface, so 1/|s|^L is a series of ever wider stencils.

Order 0 is the reference (the cluster's pattern is over the grid's own omni source), so it is not
touched; nor are the order rule's choices (``wave_stencils.resolved_orders``): dropping an order
errs by its whole part, radiating it by the residual above.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sonolux.sound.wave_stencils import DIFFERENCES, MONOMIALS

#: The θ = kΔx at which the compensation is tabulated (interpolated linearly between; above the
#: last the last is held: kΔx = 1 is 1.6 f_max on the grid the waves choose, 10 points a
#: wavelength at f_max, where the pulse is 30 dB down, and the 7-point scheme's group direction
#: still covers the sphere, which it does below θ = 1.45 at λ = 1/√3). The linear interpolation's
#: error is ≈ Δθ²/8·|T''| ≈ 10⁻⁴ of a gain (T ≈ I + θ²A, |A| ≲ 0.3).
THETA_TABLE = np.linspace(0.0, 1.0, 21)
#: The least squares' quadrature: Gauss-Legendre rings in cos θ times equally spaced azimuths
#: (as ``wave_moments.fit_directions``), exact for spherical polynomials of degree ≤ 31: the
#: normal equations' integrands, products of two degree-≤ 6 monomials' grid fields, are
#: polynomials of degree ≤ 2(L + 8) ≤ 28 to the θ⁴ of their series (θ² each moves a term by
#: degree 4, :func:`grid_monomials`), and what is left is smaller than the interpolation's.
RINGS, AZIMUTHS = 16, 32


def group_wavenumbers(u: np.ndarray, kh: float, courant: float) -> np.ndarray:
    """float64[direction, 3]: k_g·Δx, the 7-point scheme's wavevector at θ = ``kh`` (= ωΔx/c)
    whose group velocity points along each unit direction u [direction, 3], at Courant number
    ``courant`` = cΔt/Δx: kᵢΔx = arcsin(a·uᵢ), a solved by Newton's method (the residual is
    convex and increasing in a) from Σ (1 − √(1 − a²uᵢ²))/2 = sin²(λθ/2)/λ²."""
    u = np.asarray(u, float)
    target = math.sin(0.5 * courant * kh) ** 2 / courant ** 2
    a = np.full(len(u), 2.0 * math.sqrt(target))  # the small-θ root, from below
    for _ in range(60):
        root = np.sqrt(np.maximum(1.0 - (a[:, None] * u) ** 2, 1e-300))
        g = np.sum(0.5 * (1.0 - root), axis=1) - target
        slope = np.sum(a[:, None] * u * u / (2.0 * root), axis=1)
        step = g / np.where(slope > 0.0, slope, 1.0)
        a = a - step
        if np.all(np.abs(step) <= 1e-15 * np.maximum(a, 1e-300)):
            break
    return np.arcsin(np.clip(a[:, None] * u, -1.0, 1.0))


def grid_monomials(u: np.ndarray, kh: float, courant: float,
                   components: list[int]) -> np.ndarray:
    """float64[direction, component]: the far field on the grid, over an omni source's, of each
    component (of ``wave_stencils.MONOMIALS``) fed with its order's signal, towards each u:
    Πᵢ Dₚᵢ(φᵢ)/(iθ)^{pᵢ} at φ = :func:`group_wavenumbers` (for even p, (−1)^{p/2}·Σ w cos(mφ)/θᵖ;
    for odd p, (−1)^{(p−1)/2}·Σ w sin(mφ)/θᵖ). At θ = 0 the exact monomials u^α."""
    u = np.asarray(u, float)
    if kh <= 0.0:
        return np.column_stack([np.prod(u[:, list(MONOMIALS[k])], axis=1) for k in components])
    phi = group_wavenumbers(u, kh, courant)
    factors = {}
    for p in range(1, len(DIFFERENCES)):
        offsets, weights = DIFFERENCES[p]
        m = offsets.astype(float)
        if p % 2 == 0:
            d = (-1.0) ** (p // 2) * np.cos(phi[..., None] * m) @ weights
        else:
            d = (-1.0) ** ((p - 1) // 2) * np.sin(phi[..., None] * m) @ weights
        factors[p] = d / kh ** p  # [direction, axis]
    cols = []
    for k in components:
        col = np.ones(len(u))
        for axis in range(3):
            p = MONOMIALS[k].count(axis)
            if p:
                col = col * factors[p][:, axis]
        cols.append(col)
    return np.column_stack(cols)


@functools.lru_cache(maxsize=64)
def compensation_table(present: tuple[int, ...], order: int, courant: float) -> np.ndarray:
    """float64[θ, present, order's components]: T(θ) at :data:`THETA_TABLE`, the least-squares
    map from an order's exact coefficients (all its monomials, in ``MONOMIALS`` order) to the
    gains of the ``present`` components that make the grid's far field nearest the exact pattern
    over the sphere (a Gauss product quadrature, :data:`RINGS`). T(0) is the identity on
    ``present``."""
    z, wz = np.polynomial.legendre.leggauss(RINGS)
    phi = 2.0 * math.pi * (np.arange(AZIMUTHS) + 0.5) / AZIMUTHS
    s = np.sqrt(1.0 - z * z)
    u = np.stack([np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)),
                  np.repeat(z[:, None], AZIMUTHS, axis=1)], axis=-1).reshape(-1, 3)
    w = np.repeat(wz / (2.0 * AZIMUTHS), AZIMUTHS)
    root_w = np.sqrt(w)[:, None]
    everyone = [k for k, m in enumerate(MONOMIALS) if len(m) == order]
    exact = grid_monomials(u, 0.0, courant, everyone) * root_w
    tables = []
    for kh in THETA_TABLE:
        grid = grid_monomials(u, float(kh), courant, list(present)) * root_w
        tables.append(np.linalg.solve(grid.T @ grid, grid.T @ exact))  # the normal equations
    return np.array(tables)


def compensated(gains: dict[int, np.ndarray], kh: np.ndarray,
                courant: float) -> dict[int, np.ndarray]:
    """The components' gains [frequency] (keyed by component, as ``wave_sources.terms`` builds
    them) pre-compensated for the scheme's dispersion at θ = ``kh`` [frequency]: each order
    L ≥ 1's gains mapped by T(θ) (:func:`compensation_table`) among the components present.
    Order 0 is returned as it is (the same array)."""
    out = dict(gains)
    kh = np.asarray(kh, float)
    position = np.interp(kh, THETA_TABLE, np.arange(THETA_TABLE.size, dtype=float))
    below = np.minimum(position.astype(int), THETA_TABLE.size - 2)  # the entry below each θ
    above = position - below  # 0 to 1: the share of the entry above
    for order in sorted({len(MONOMIALS[k]) for k in gains} - {0}):
        present = tuple(k for k in sorted(gains) if len(MONOMIALS[k]) == order)
        everyone = [k for k, m in enumerate(MONOMIALS) if len(m) == order]
        table = compensation_table(present, order, float(courant))
        exact = np.array([gains[k] if k in gains else np.zeros_like(kh) for k in everyone])
        mapped = np.zeros((len(present), kh.size), dtype=np.result_type(exact, float))
        for j in np.unique(below):  # T(θ) between entries j and j + 1, linearly
            at = below == j
            mapped[:, at] = (table[j] @ exact[:, at]) * (1.0 - above[at]) + (
                table[j + 1] @ exact[:, at]) * above[at]
        for row, k in enumerate(present):
            out[k] = mapped[row]
    return out
