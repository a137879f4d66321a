"""A pattern's spherical-harmonic parts on the fit's quadrature (:mod:`sonolux.sound.wave_sources`).

The quadrature (:func:`fit_directions`), then orders 0 to 4 of a pattern A(u) [direction, band]
from the addition theorem, each order's part written in Cartesian form as a symmetric traceless
tensor contracted with u (the forms, their normalisation and their sources are in
``wave_sources``' module doc and :func:`fourth_order`), and their truncation to each band's
order, scaled to radiate the pattern's power.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sonolux.sound.wave_stencils import MAX_ORDER, PAIRS, QUADS, TRIPLES

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
    ``weight``): (c₀, c [axis, band], M, D, T, Q, each order's share of the energy [order, band],
    the energy [band]) as :func:`fit` uses them."""
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
    shares = np.stack([np.abs(c0) ** 2, (np.abs(c) ** 2).sum(axis=0) / 3.0,
                       2.0 / 15.0 * np.einsum("bij,bij->b", d, d.conj()).real,
                       2.0 / 35.0 * np.einsum("bijk,bijk->b", t, t.conj()).real,
                       8.0 / 315.0 * np.einsum("bijkl,bijkl->b", q, q.conj()).real])
    return c0, c, m, d, t, q, shares, total


def truncated(c0: np.ndarray, c: np.ndarray, d: np.ndarray, t: np.ndarray, q: np.ndarray,
              shares: np.ndarray, orders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(components [band, 35], power [band]): a pattern's parts (:func:`moments`) up to each
    band's order, in :attr:`SourceFit.components`' layout, scaled to radiate the pattern's
    power; the power those orders held before the scaling."""
    c = np.where(orders[None] >= 1, c, 0.0)
    d = np.where((orders >= 2)[:, None, None], d, 0.0)
    t = np.where((orders >= 3)[:, None, None, None], t, 0.0)
    q = np.where((orders >= 4)[:, None, None, None, None], q, 0.0)
    power = shares[0] + sum(np.where(orders >= L, shares[L], 0.0) for L in range(1, MAX_ORDER + 1))
    norm = np.sqrt(np.maximum(power, 1e-300))
    second = np.column_stack([d[:, i, j] * (1.0 if i == j else 2.0) for i, j in PAIRS])
    third = np.column_stack([t[:, i, j, k] * len(set(itertools.permutations((i, j, k))))
                             for i, j, k in TRIPLES])
    fourth = np.column_stack([q[(slice(None), *ix)] * len(set(itertools.permutations(ix)))
                              for ix in QUADS])
    return np.column_stack([c0, c.T, second, third, fourth]) / norm[:, None], power


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
