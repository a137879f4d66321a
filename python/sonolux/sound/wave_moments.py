"""A pattern's spherical-harmonic parts on the fit's quadrature (:mod:`sonolux.sound.wave_sources`).

The quadrature (:func:`fit_directions`), then orders 0 to 4 of a pattern A(u) [direction, band]
from the addition theorem, each order's part written in Cartesian form as a symmetric traceless
tensor contracted with u (the forms, their normalisation and their sources are in
``wave_sources``' module doc and :func:`fourth_order`), orders 5 and 6 from the same theorem in
general form, as coefficients of their monomials (:func:`higher_order`), and their truncation to
each band's order, scaled to radiate the pattern's power.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sonolux.sound.wave_stencils import HIGHEST_ORDER, MONOMIALS, PAIRS, QUADS, TRIPLES

#: The fit's quadrature (:func:`fit_directions`): Gauss-Legendre rings in cos θ times equally
#: spaced azimuths, exact for spherical polynomials up to degree 2·rings − 1 in z and
#: azimuths − 1 in φ (Abramowitz and Stegun 25.4.29 in z, the trapezoid rule in φ), and
#: antipodally symmetric, so a symmetric pattern's odd moments are exactly 0. (A Fibonacci
#: lattice of 4,096 points, used before, misses ⟨y·z²⟩ of a constant by 1.4·10⁻⁴, which added
#: order-3 terms to the dodecahedron and the talker that they do not have.)
FIT_RINGS = 48
FIT_AZIMUTHS = 96


def fibonacci_directions(n: int = 4096) -> np.ndarray:
    """float64[n, 3]: unit vectors of the Fibonacci lattice on the sphere."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def fit_directions() -> tuple[np.ndarray, np.ndarray]:
    """The fit's quadrature (:data:`FIT_RINGS`, :data:`FIT_AZIMUTHS`): unit directions
    float64[direction, 3] and weights float64[direction] summing to 1 (a weighted sum is the
    mean over the sphere)."""
    z, wz = np.polynomial.legendre.leggauss(FIT_RINGS)
    phi = 2.0 * math.pi * (np.arange(FIT_AZIMUTHS) + 0.5) / FIT_AZIMUTHS
    s = np.sqrt(1.0 - z * z)
    u = np.stack([np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)),
                  np.repeat(z[:, None], FIT_AZIMUTHS, axis=1)], axis=-1).reshape(-1, 3)
    return u, np.repeat(wz / (2.0 * FIT_AZIMUTHS), FIT_AZIMUTHS)


def moments(a: np.ndarray, u: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, ...]:
    """The spherical-harmonic parts of ``a`` [direction, band] on the quadrature (``u``,
    ``weight``): (c₀, c [axis, band], M, D, T, Q, orders 5 and 6's monomial coefficients
    [band, 49] (:func:`higher_order`), each order's share of the energy [order, band], the
    energy [band]) as :func:`fit` uses them. Orders 0-4 are computed as before session 13
    (same bits)."""
    wa = weight[:, None] * a  # a weighted sum of wa is a mean over the sphere
    c0 = wa.sum(axis=0)
    c = 3.0 * (u.T @ wa)  # [axis, band]
    m = np.einsum("di,dj,db->bij", u, u, wa)
    d = 7.5 * (m - np.einsum("bii->b", m)[:, None, None] * np.eye(3) / 3.0)  # [band, 3, 3]
    n = np.einsum("di,dj,dk,db->bijk", u, u, u, wa)
    m1 = (c / 3.0).T  # [band, axis]: ⟨A·v⟩
    eye = np.eye(3)
    t = 17.5 * n - 3.5 * (np.einsum("bi,jk->bijk", m1, eye) + np.einsum("bj,ik->bijk", m1, eye)
                          + np.einsum("bk,ij->bijk", m1, eye))  # [band, 3, 3, 3]
    q = fourth_order(u, wa, m, c0)  # [band, 3, 3, 3, 3]
    total = weight @ (np.abs(a) ** 2)
    # Each order's share of the pattern's energy (the means of its part's square; :func:`fit`
    # leaves out an order above every one that carries RESOLVED_AMPLITUDE² of it).
    higher, higher_shares = [], []
    for order in range(5, HIGHEST_ORDER + 1):
        coefficients = higher_order(u, wa, order)  # [band, monomial]
        part = order_monomials(u, order) @ coefficients.T  # [direction, band]
        higher.append(coefficients)
        higher_shares.append(weight @ (np.abs(part) ** 2))
    shares = np.stack([np.abs(c0) ** 2, (np.abs(c) ** 2).sum(axis=0) / 3.0,
                       2.0 / 15.0 * np.einsum("bij,bij->b", d, d.conj()).real,
                       2.0 / 35.0 * np.einsum("bijk,bijk->b", t, t.conj()).real,
                       8.0 / 315.0 * np.einsum("bijkl,bijkl->b", q, q.conj()).real,
                       *higher_shares])
    return c0, c, m, d, t, q, np.concatenate(higher, axis=1), shares, total


def order_monomials(u: np.ndarray, order: int) -> np.ndarray:
    """float64[direction, monomial]: the monomials of ``order`` in :data:`MONOMIALS`' order."""
    return np.column_stack([np.prod(u[:, list(m)], axis=1) for m in MONOMIALS
                            if len(m) == order])


def higher_order(u: np.ndarray, wa: np.ndarray, order: int) -> np.ndarray:
    """complex or float [band, monomial]: order L of a pattern as the coefficients of its
    monomials u^α (|α| = L, :data:`MONOMIALS`' order), the addition theorem's
    (2L + 1)·⟨A(v)·P_L(u·v)⟩ (Abramowitz and Stegun 22.3.8 for P_L's coefficients p_k of
    x^{L−2k}) written homogeneous of degree L in u as Σ_k p_k·(u·v)^{L−2k}·(u·u)^k: that is
    |u|^L·P_L(u·v/|u|), a solid harmonic, so the polynomial is of order L only (no lower part
    hides in it on the sphere). Expanding both powers by the multinomial theorem, u^α's
    coefficient is (2L + 1)·⟨A·h_α(v)⟩ with h_α(v) = Σ_k p_k Σ_{γ: |γ| = k, 2γ ≤ α}
    (k!/γ!)·((L − 2k)!/(α − 2γ)!)·v^{α − 2γ}. For L = 2 to 4 this is the same polynomial as
    D, T and Q (test, to rounding); ``wa`` the pattern times the quadrature weights
    [direction, band] (degree ≤ 2·6 + the pattern's: exact for patterns of order ≤ 83)."""
    legendre = np.polynomial.legendre.leg2poly(np.eye(order + 1)[order])  # powers 0..L
    rows = []
    for alpha in (tuple(m.count(axis) for axis in range(3)) for m in MONOMIALS
                  if len(m) == order):
        h = np.zeros(len(u))
        for k in range(order // 2 + 1):
            p_k = legendre[order - 2 * k]
            for gamma in itertools.product(*(range(a // 2 + 1) for a in alpha)):
                if sum(gamma) != k:
                    continue
                beta = [a - 2 * g for a, g in zip(alpha, gamma)]
                multinomial = (math.factorial(k) / math.prod(math.factorial(g) for g in gamma)
                               * math.factorial(order - 2 * k)
                               / math.prod(math.factorial(b) for b in beta))
                h = h + p_k * multinomial * np.prod(u ** np.asarray(beta, float), axis=1)
        rows.append(h)
    return (2 * order + 1) * np.einsum("ad,db->ba", np.array(rows), wa)


def truncated(c0: np.ndarray, c: np.ndarray, d: np.ndarray, t: np.ndarray, q: np.ndarray,
              higher: np.ndarray, shares: np.ndarray,
              orders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(components [band, 84], power [band]): a pattern's parts (:func:`moments`) up to each
    band's order, in :attr:`SourceFit.components`' layout, scaled to radiate the pattern's
    power; the power those orders held before the scaling."""
    c = np.where(orders[None] >= 1, c, 0.0)
    d = np.where((orders >= 2)[:, None, None], d, 0.0)
    t = np.where((orders >= 3)[:, None, None, None], t, 0.0)
    q = np.where((orders >= 4)[:, None, None, None, None], q, 0.0)
    higher_order_of = np.array([len(m) for m in MONOMIALS if len(m) >= 5])
    higher = np.where(orders[:, None] >= higher_order_of[None], higher, 0.0)
    power = shares[0] + sum(np.where(orders >= L, shares[L], 0.0)
                            for L in range(1, HIGHEST_ORDER + 1))
    norm = np.sqrt(np.maximum(power, 1e-300))
    second = np.column_stack([d[:, i, j] * (1.0 if i == j else 2.0) for i, j in PAIRS])
    third = np.column_stack([t[:, i, j, k] * len(set(itertools.permutations((i, j, k))))
                             for i, j, k in TRIPLES])
    fourth = np.column_stack([q[(slice(None), *ix)] * len(set(itertools.permutations(ix)))
                              for ix in QUADS])
    return np.column_stack([c0, c.T, second, third, fourth, higher]) / norm[:, None], power


def fourth_order(u: np.ndarray, wa: np.ndarray, m: np.ndarray, c0: np.ndarray) -> np.ndarray:
    """complex or float [band, 3, 3, 3, 3]: order 4 of a pattern as Q_ijkl·u_i u_j u_k u_l, the
    addition theorem's 9⟨A(v)·P₄(u·v)⟩ with P₄(x) = (35x⁴ − 30x² + 3)/8 in Cartesian form:
    (9/8)·(35·N₄ − 30·M⊗I + 3·⟨A⟩·I⊗I) symmetrised over its indices, N₄ = ⟨A·v_i v_j v_k v_l⟩,
    M = ⟨A·v_i v_j⟩ (``m``), ⟨A⟩ = ``c0``; ``wa`` the pattern times the quadrature weights
    [direction, band]. r⁴P₄(u·v/r) is a solid harmonic, so Q is traceless and order 4 only,
    and the mean of its square over the sphere is (8/315)·ΣQ² (4!/9!!, as 2/15 and 2/35 are
    2!/5!! and 3!/7!! for orders 2 and 3)."""
    eye = np.eye(3)
    n4 = np.einsum("di,dj,dk,dl,db->bijkl", u, u, u, u, wa)
    raw = 9.0 / 8.0 * (35.0 * n4 - 30.0 * np.einsum("bij,kl->bijkl", m, eye)
                       + 3.0 * np.einsum("b,ij,kl->bijkl", c0, eye, eye))
    return sum(np.transpose(raw, (0, *(1 + np.array(p)))) for p in
               itertools.permutations(range(4))) / 24.0
