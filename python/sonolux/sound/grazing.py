"""The grazing modes of parallel surface pairs, for the rays (wall model
"locally-reacting-modes"; sonolux_core::sound::grazing, docs/waves-grazing.md).

Between two parallel locally reacting planes a distance D apart, the field across the gap is one
of the gap's 1D modes, κ solving the boundary conditions at both planes (Morse and Ingard,
*Theoretical Acoustics*, 1968, §9.4). The grazing one (n = 0) is damped, at about half the rate
of the others (Kuttruff, *Room Acoustics*, §3.5: ε₀ = 1), where a specular ray parallel to the
planes is not damped at all. The rays with |cos θ| < π/(kD) to the pair's normal stand for that
mode (each mode of the gap holds the share π/(kD) of the diffuse field's cosines): they lose
its energy along their path, Im κ₀²/k per metre, and nothing at the pair's planes.

The mode's energy is not uniform across the gap: its density is |ψ₀(z)|², ψ₀ = cos κ₀z +
(jkβ_a/κ₀) sin κ₀z with κ₀ complex (:func:`grazing_profile`), lower by the more absorbing plane.
A source at z_s feeds the mode, and a receiver at z_r reads it, in proportion to |ψ₀|² there
(the modal expansion of the Green's function, Morse and Ingard §9.4–9.5, a mode's term
ψ(s)ψ(r)/Λ). The table carries |ψ₀|² over its mean across the gap; the tracer weighs a grazing
ray's deposits by it where they are made, and its energy by it at its source once the ray meets
the pair (sonolux_core::sound::grazing).

Pairs are found from the mesh: along a direction, the two extreme planes form a pair when each
alone is the whole room seen along that direction (its area is half the room's projected
surface, Σ|n·nₜ|Aₜ/2): a flat floor under a flat ceiling, or a shoebox's three pairs. A plane's
admittance is the area-weighted mean of its triangles' (first order in β, the n = 0 mode's
damping is the plane's integral of β, its |ψ|² being uniform there; Kuttruff §3.5, the damping
constant of a mode as the surface integral of Re β |ψ|², Morse and Ingard §9.4). That mean is
the limit of patches small against the wavelength (the mode sees the homogenised admittance);
patches large against it are the other limit, where the mode is locally that of the patches
above and below and its loss the area mean of their exact rates. The two differ at second order
in the spread of β (both are exact for a plane of one material); :func:`mixed_plane_spread`
gives that difference, the bound the bake states when a plane holds several materials.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.acoustics.surface import PARIS_PEAK_G, conductance_from_random, paris_absorption

#: Two planes are one when their offsets differ by less than this share of the room's size, and
#: a plane covers the room's plan when its area is within this share of it.
RELATIVE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Pair:
    """Two parallel planes n·x = offsets[0] and offsets[1] that each cover the room's plan;
    ``triangles`` of each, in that order."""

    normal: np.ndarray
    offsets: tuple[float, float]
    triangles: tuple[np.ndarray, np.ndarray]

    @property
    def spacing_m(self) -> float:
        return abs(self.offsets[1] - self.offsets[0])


def parallel_pairs(vertices_m: np.ndarray, triangles: np.ndarray) -> list[Pair]:
    """The mesh's pairs of parallel planes that each cover the room along their normal."""
    v = np.asarray(vertices_m, float)
    p0, p1, p2 = (v[np.asarray(triangles)[:, i]] for i in range(3))
    cross = np.cross(p1 - p0, p2 - p0)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    ok = area > 0
    normal = np.zeros_like(cross)
    normal[ok] = cross[ok] / (2 * area[ok, None])
    size = float(np.ptp(v, axis=0).max()) or 1.0
    tol = RELATIVE_TOLERANCE * size
    pairs: list[Pair] = []
    seen: list[np.ndarray] = []
    for t in np.flatnonzero(ok):
        n = normal[t] if _first_nonzero(normal[t]) > 0 else -normal[t]
        if any(abs(float(n @ s)) > 1 - 1e-9 for s in seen):
            continue
        seen.append(n)
        along = v @ n
        lo, hi = float(along.min()), float(along.max())
        parallel = ok & (np.abs(np.abs(normal @ n) - 1) < 1e-9)
        offset = np.einsum("ij,j->i", p0, n)
        bottom = np.flatnonzero(parallel & (np.abs(offset - lo) < tol))
        top = np.flatnonzero(parallel & (np.abs(offset - hi) < tol))
        projected = 0.5 * float(np.sum(area * np.abs(normal @ n)))
        covers = [abs(float(area[s].sum()) - projected) <= RELATIVE_TOLERANCE * projected
                  for s in (bottom, top)]
        if hi - lo > tol and all(covers):
            pairs.append(Pair(n, (lo, hi), (bottom, top)))
    return pairs


def _first_nonzero(n: np.ndarray) -> float:
    nz = n[np.abs(n) > 1e-12]
    return float(nz[0]) if nz.size else 1.0


def grazing_wavenumber_squared(k: float, spacing_m: float, beta_a: float, beta_b: float) -> complex:
    """κ₀² of the gap's grazing mode: the root near jk(β_a + β_b)/D of the 1D problem
    p'(0) = jkβ_a p(0), p'(D) = −jkβ_b p(D) (e^{jωt}; Morse and Ingard 1968, §9.4), p = cos κz +
    (jkβ_a/κ) sin κz, by Newton's method on κ from the small-admittance root."""
    d = spacing_m
    ja, jb = 1j * k * beta_a, 1j * k * beta_b

    def f(q: complex) -> complex:
        s, c = np.sin(q * d), np.cos(q * d)
        return -q * q * s + ja * q * c + jb * (q * c + ja * s)

    def df(q: complex) -> complex:
        s, c = np.sin(q * d), np.cos(q * d)
        return (-2 * q * s - q * q * d * c + ja * (c - q * d * s)
                + jb * (c - q * d * s + ja * d * c))

    q = complex(np.sqrt((ja + jb) / d))
    if q == 0:
        return 0j
    for _ in range(100):
        step = f(q) / df(q)
        q -= step
        if abs(step) <= 1e-14 * abs(q):
            break
    return complex(q * q)


def _areas(vertices_m: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    v, tri = np.asarray(vertices_m, float), np.asarray(triangles)
    return 0.5 * np.linalg.norm(np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]]),
                                axis=1)


def interference_length_m(k: float, spacing_m: float) -> float:
    """The distance over which the gap's grazing mode and its first other mode (rigid planes,
    κ₁ = π/D) drift a cycle apart, 2π/(k − √(k² − κ₁²)) (≈ 4kD²/π for kD ≫ π; infinite when
    mode 1 does not propagate). A change of the planes' admittance over a distance much shorter
    than this is seen averaged by the mode; over a much longer one the mode follows it
    adiabatically, locally the mode of the planes there (the adiabatic-mode condition of
    range-dependent waveguides: Jensen, Kuperman, Porter and Schmidt, *Computational Ocean
    Acoustics*, 2nd ed., 2011, §5.10; Milder, JASA 46, 1969)."""
    kappa1 = np.pi / spacing_m
    if k <= kappa1:
        return float("inf")
    return float(2 * np.pi / (k - np.sqrt(k * k - kappa1 * kappa1)))


#: Nodes of a grazing mode's profile across the gap (evenly spaced, plane a to plane b). The
#: profile's curvature is |κ₀|² ≤ (1.4/D)² at a first ray band (paper rooms); at 64 intervals a
#: linear interpolation is off by at most (1.4/64)²/8 ≈ 6·10⁻⁵ of it there.
PROFILE_NODES = 65


def grazing_profile(k: float, spacing_m: float, beta_a: float, beta_b: float,
                    nodes: int = PROFILE_NODES) -> np.ndarray:
    """float64[nodes]: the gap's grazing mode's energy density |ψ₀(z)|² over its mean across the
    gap, at ``nodes`` heights evenly spaced from plane a (z = 0, admittance ``beta_a``) to plane b
    (z = D), ψ₀ = cos κ₀z + (jkβ_a/κ₀) sin κ₀z (the mode :func:`grazing_wavenumber_squared`
    solves; Morse and Ingard 1968, §9.4). The mean is taken by Simpson's rule on 16× the nodes'
    density (exact to 10⁻⁹ here). Rigid planes (κ₀ = 0): 1 everywhere."""
    kappa = np.sqrt(complex(grazing_wavenumber_squared(k, spacing_m, beta_a, beta_b)))
    if kappa == 0:
        return np.ones(nodes)

    def density(z: np.ndarray) -> np.ndarray:
        psi = np.cos(kappa * z) + 1j * k * beta_a / kappa * np.sin(kappa * z)
        return np.abs(psi) ** 2

    fine = np.linspace(0.0, spacing_m, 16 * (nodes - 1) + 1)
    f = density(fine)
    mean = (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum()) / (3 * (fine.size - 1))
    return density(np.linspace(0.0, spacing_m, nodes)) / mean


def _rate(k: float, spacing_m: float, beta_a: float, beta_b: float) -> float:
    """The grazing mode's energy loss per metre, Im κ₀²/k."""
    return max(grazing_wavenumber_squared(k, spacing_m, beta_a, beta_b).imag, 0.0) / k


def _prepared(vertices_m: np.ndarray, triangles: np.ndarray, absorption: np.ndarray,
              centres_hz: np.ndarray, speed_of_sound_m_s: float) -> tuple | None:
    """(pairs, absorption, Paris' peak absorption, conductance [material, band], triangle
    areas, wavenumbers k per band) shared by :func:`mixed_plane_spread` and
    :func:`modes_table`, or None without pairs."""
    pairs = parallel_pairs(vertices_m, triangles)
    if not pairs:
        return None
    absorption = np.asarray(absorption, float)
    peak = float(paris_absorption(PARIS_PEAK_G))
    g = conductance_from_random(np.minimum(absorption, peak))
    k = 2 * np.pi * np.asarray(centres_hz, float) / speed_of_sound_m_s
    return pairs, absorption, peak, g, _areas(vertices_m, triangles), k


def mixed_plane_spread(vertices_m: np.ndarray, triangles: np.ndarray, material_index: np.ndarray,
                       absorption: np.ndarray, centres_hz: np.ndarray, speed_of_sound_m_s: float
                       ) -> np.ndarray | None:
    """float64[pair, band]: how far the grazing mode's rate of :func:`modes_table` (the planes'
    area-weighted admittances, the limit of small patches) lies from the area mean of the exact
    rates of every floor-patch/ceiling-patch combination (the limit of large patches; the two
    planes' patches taken as independent, weight A_i·A_j), relative to the former; 0 for
    planes of one material each. None without pairs; a band above Paris' 0.951 is 0 (the
    table leaves it out)."""
    prepared = _prepared(vertices_m, triangles, absorption, centres_hz, speed_of_sound_m_s)
    if prepared is None:
        return None
    pairs, absorption, peak, g, area, k = prepared
    mat = np.asarray(material_index)
    out = np.zeros((len(pairs), k.size))
    for i, p in enumerate(pairs):
        sides = []
        for side in p.triangles:
            ms = np.unique(mat[side])
            sides.append((ms, np.array([area[side][mat[side] == m].sum() for m in ms])))
        (ma, aa), (mb, ab) = sides
        if ma.size == 1 and mb.size == 1:
            continue
        wa, wb = aa / aa.sum(), ab / ab.sum()
        for b in range(k.size):
            if (absorption[ma, b] > peak).any() or (absorption[mb, b] > peak).any():
                continue
            kb, d = float(k[b]), p.spacing_m
            mean = _rate(kb, d, float(wa @ g[ma, b]), float(wb @ g[mb, b]))
            local = sum(wa[x] * wb[y] * _rate(kb, d, float(g[ma[x], b]), float(g[mb[y], b]))
                        for x in range(ma.size) for y in range(mb.size))
            out[i, b] = abs(local - mean) / mean if mean > 0 else 0.0
    return out


def modes_table(vertices_m: np.ndarray, triangles: np.ndarray, material_index: np.ndarray,
                absorption: np.ndarray, centres_hz: np.ndarray, speed_of_sound_m_s: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """(normals float64[pair, 3], offsets float64[pair, 2], cos_limit float64[pair, band],
    rate_per_m float64[pair, band], profile float64[pair, band, node]) for
    ``Acoustics(grazing=...)``, or None without pairs. ``profile``: :func:`grazing_profile` at
    the band's centre (1 where the band keeps its rays).
    ``absorption`` float64[material, band]: random-incidence coefficients, each turned into
    Paris' conductance as the locally reacting walls do; a band of a plane above the 0.951 a
    locally reacting wall absorbs keeps its rays as they are (limit 0)."""
    prepared = _prepared(vertices_m, triangles, absorption, centres_hz, speed_of_sound_m_s)
    if prepared is None:
        return None
    pairs, absorption, peak, g, area, k = prepared
    too_high = absorption > peak
    nb = k.size
    normals = np.array([p.normal for p in pairs])
    offsets = np.array([p.offsets for p in pairs])
    cos_limit = np.zeros((len(pairs), nb))
    rate = np.zeros((len(pairs), nb))
    profile = np.ones((len(pairs), nb, PROFILE_NODES))
    for i, p in enumerate(pairs):
        betas, high = [], np.zeros(nb, bool)
        for side in p.triangles:
            m = np.asarray(material_index)[side]
            betas.append(np.sum(area[side, None] * g[m], axis=0) / area[side].sum())
            high |= too_high[m].any(axis=0)
        for b in range(nb):
            if high[b]:
                continue
            kappa2 = grazing_wavenumber_squared(float(k[b]), p.spacing_m, float(betas[0][b]),
                                                float(betas[1][b]))
            cos_limit[i, b] = min(1.0, np.pi / (k[b] * p.spacing_m))
            rate[i, b] = max(kappa2.imag, 0.0) / k[b]
            profile[i, b] = grazing_profile(float(k[b]), p.spacing_m, float(betas[0][b]),
                                            float(betas[1][b]))
    return normals, offsets, cos_limit, rate, profile


__all__ = ["PROFILE_NODES", "Pair", "grazing_profile", "grazing_wavenumber_squared",
           "interference_length_m", "mixed_plane_spread", "modes_table", "parallel_pairs"]
