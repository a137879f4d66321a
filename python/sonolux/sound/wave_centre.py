"""A measured source's acoustic centre, from its measured phase (:mod:`sonolux.sound.wave_sources`).

A source measured by a surrounding microphone array whose centre is not the source's own has a
far-field pattern D(u) multiplied by the translation's phase e^{ik·u·d} (d the source's offset
from the array's centre; k = 2πf/c; the transfer functions' e^{−iωt} convention, in which a
path shorter by u·d arrives earlier). Referred to the point d, the pattern is D(u)·e^{−ik·u·d}.
A translation spreads a pattern's spherical-harmonic spectrum to higher orders, and the
acoustic centre is the translation that undoes it: Ben Hagai, Pollow, Vorländer and Rafaely,
"Acoustic centering of sources measured by surrounding spherical microphone arrays", JASA
130(4), 2011, who measure the misalignment by the energy the spectrum holds above low orders
and minimise it over translations.

The measure used here weighs each order by n(n + 1): J(d) = Σ n(n + 1)·|f_nm(d)|² / Σ |f_nm|²,
f_nm(d) the spectrum of D·e^{−ik·u·d}. By the spherical harmonics' eigen-property
(∇²_S Y_nm = −n(n + 1)·Y_nm) J is the pattern's mean squared surface gradient,
⟨|∇_S(D·e^{−ik·u·d})|²⟩/⟨|D|²⟩, and since ∇_S e^{−ik·u·d} = −ik·P_u·d·e^{−ik·u·d}
(P_u = I − u·uᵀ, the projection on the sphere's tangent plane) it is exactly quadratic in d:

    ⟨|∇_S D|²⟩ − 2k·d·B + k²·dᵀM·d,  B = ⟨Im(D̄·∇_S D)⟩,  M = ⟨|D|²·P_u⟩,

whose minimum is d = M⁻¹·B/k, in closed form (no search, no local minima). Summed over bands
(each normalised to ⟨|D|²⟩ = 1): d = (Σ k_b²·M_b)⁻¹·Σ k_b·B_b. Since Im(D̄·∇_S D) = |D|²·∇_S φ
(φ the phase), this is the energy-weighted least-squares fit of the measured phase's gradient by
a translation's, k·P_u·d: the point the wavefronts diverge from (the acoustic centre of
Jacobsen, Barrera-Figueroa and Rasmussen, JASA 115(4), 2004). It is exact for any pattern
of constant phase moved by d (a real pattern's sign changes, where D̄·∇_S D is real, add
nothing), whatever its orders (a dipole's centre is not moved, where a measure of the energy
above order 0 would move it).
"""

from __future__ import annotations

import numpy as np

from sonolux.sound.wave_stencils import RESOLVED_AMPLITUDE


def surface_gradient(values: np.ndarray, rings_z: np.ndarray, azimuths: int) -> np.ndarray:
    """complex[direction, band, 3]: the surface gradient ∇_S of ``values`` [direction, band]
    given on a product grid of rings (cos θ = ``rings_z``, increasing) × ``azimuths`` equally
    spaced azimuths (2π(j + ½)/azimuths), ring by ring: ∂_θ by second-order differences on the
    rings' angles (``np.gradient``), ∂_φ by central differences around each ring (periodic);
    ∇_S = e_θ·∂_θ + e_φ·∂_φ/sin θ."""
    rings = len(rings_z)
    v = values.reshape(rings, azimuths, -1)
    theta = np.arccos(rings_z)
    d_theta = meridian_derivative(v, theta)
    m = np.fft.fftfreq(azimuths, 1.0 / azimuths)  # the azimuthal orders on the ring
    d_phi = np.fft.ifft(1j * m[None, :, None] * np.fft.fft(v, axis=1), axis=1)
    phi = 2.0 * np.pi * (np.arange(azimuths) + 0.5) / azimuths
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    sp, cp = np.sin(phi)[None], np.cos(phi)[None]
    e_theta = np.stack(np.broadcast_arrays(ct * cp, ct * sp, -st * np.ones_like(cp)), axis=-1)
    e_phi = np.stack(np.broadcast_arrays(-sp * np.ones_like(st), cp * np.ones_like(st),
                                         np.zeros((rings, azimuths))), axis=-1)
    grad = (e_theta[:, :, None, :] * d_theta[..., None]
            + e_phi[:, :, None, :] * (d_phi / st[:, :, None])[..., None])
    return grad.reshape(rings * azimuths, -1, 3)


def acoustic_centre_m(pattern: np.ndarray, directions: np.ndarray, weights: np.ndarray,
                      rings_z: np.ndarray, azimuths: int, k_per_m: np.ndarray) -> np.ndarray:
    """float64[3]: the translation d minimising the spectrum's mean n(n + 1) summed over the
    bands (module doc), for a complex ``pattern`` [direction, band] on the product grid
    (``directions`` [direction, 3] and quadrature ``weights`` summing to 1, rings × azimuths as
    :func:`surface_gradient` takes them) at wavenumbers ``k_per_m`` [band]. The pattern
    referred to d is pattern·e^{−ik·u·d}. A band without energy or with k = 0 adds nothing;
    with none left, 0."""
    d = np.asarray(pattern, complex)
    energy = weights @ (np.abs(d) ** 2)  # [band]
    k = np.asarray(k_per_m, float)
    use = (energy > 0) & (k > 0)
    if not np.any(use):
        return np.zeros(3)
    # The pattern squared (normalised): its sign changes are gone, its translation's phase is
    # e^{2ik·u·d}.
    sq = (d[:, use] / np.sqrt(energy[use])[None]) ** 2
    k = 2.0 * k[use]
    grad = surface_gradient(sq, rings_z, azimuths)  # [direction, band, 3]
    b = np.einsum("d,db,dbi->bi", weights, np.conj(sq), grad).imag  # ⟨Im(S̄·∇_S S)⟩
    u = np.asarray(directions, float)
    projector = np.eye(3)[None] - u[:, :, None] * u[:, None, :]  # [direction, 3, 3]
    m = np.einsum("d,db,dij->bij", weights, np.abs(sq) ** 2, projector)  # ⟨|S|²·P_u⟩
    return np.linalg.solve(np.einsum("b,bij->ij", k * k, m), k @ b)


def refer_to_centre(a: np.ndarray, u: np.ndarray, weight: np.ndarray, rings_z: np.ndarray,
                    azimuths: int, k_per_m: np.ndarray,
                    centre_bands: int | None) -> tuple[np.ndarray, np.ndarray]:
    """(the pattern referred to its acoustic centre, the centre float64[3] from the source's
    position) of a measured complex pattern ``a`` [direction, band] on the fit's product
    quadrature: the centre d from the first ``centre_bands`` bands (all if None;
    :func:`acoustic_centre_m`), and a·e^{−ik·u·d} in every band. A measured source whose
    array was not centred on it then radiates from where it was (the builtin talker's cure,
    ``wave_sources.acoustic_centre_offset_m``, applied to measured phase): the translation
    costs no orders, and the cluster's phase does not rotate within a band as a fixed
    coefficient's would."""
    k = np.asarray(k_per_m, float)
    n = k.size if centre_bands is None else max(1, min(int(centre_bands), k.size))
    d = acoustic_centre_m(a[:, :n], u, weight, rings_z, azimuths, k[:n])
    return a * np.exp(-1j * np.outer(u @ d, k)), d


#: The share of its offset by which a centre found from measured phase may be off: the
#: tolerance tests/sound/test_wave_sources_centre.py holds it to (phase interpolated on a
#: triangulation of 500 directions, ≈ h²/8 = 0.4 % measured, 2 % asserted).
CENTRE_UNCERTAINTY = 0.02


def band_centres_m(pattern: np.ndarray, directions: np.ndarray, weights: np.ndarray,
                   rings_z: np.ndarray, azimuths: int, k_per_m: np.ndarray) -> np.ndarray:
    """float64[band, 3]: each band's own acoustic centre (:func:`acoustic_centre_m` on that
    band alone), where the measured phase puts it band by band (a loudspeaker's centre moves
    with frequency: Jacobsen, Barrera-Figueroa and Rasmussen, JASA 115(4), 2004)."""
    k = np.asarray(k_per_m, float)
    return np.array([acoustic_centre_m(pattern[:, [b]], directions, weights, rings_z, azimuths,
                                       k[[b]]) for b in range(k.size)]).reshape(k.size, 3)


def translation_spill(k_per_m: np.ndarray, distance_m: np.ndarray,
                      orders: np.ndarray) -> np.ndarray:
    """float64[band]: the share of a monopole's energy that a translation by ``distance_m``
    puts above order ``orders`` (per band): 1 − Σ_{n≤L} (2n + 1)·j_n(kδ)², from the plane
    wave's expansion e^{ik u·δ} = Σ (2n + 1) iⁿ j_n(kδ) P_n(u·δ̂) and Σ (2n + 1) j_n² = 1
    (Abramowitz and Stegun 10.1.47, 10.1.50). What radiating a band from a centre δ off its
    own costs in the fit's orders, for the energy the band's pattern holds at order 0."""
    from scipy.special import spherical_jn
    x = np.asarray(k_per_m, float) * np.asarray(distance_m, float)
    out = np.empty(x.size)
    for b, (xb, L) in enumerate(zip(x, np.asarray(orders, int))):
        n = np.arange(int(L) + 1)
        out[b] = max(0.0, 1.0 - float(np.sum((2 * n + 1) * spherical_jn(n, xb) ** 2)))
    return out


def centres_differ(shared_m: np.ndarray, band_centres: np.ndarray, k_per_m: np.ndarray,
                   orders: np.ndarray, residual_shared: np.ndarray,
                   residual_own: np.ndarray) -> np.ndarray:
    """bool[band]: whether the measured phase says a band's centre differs from the shared one:
    radiated from the shared centre, the band's fit leaves more of its energy above its orders
    (``residual_shared``) than from its own centre (``residual_own``) by more than it leaves
    there anyway (sharing at least doubles the loss), more than the centres' own uncertainty
    would (:func:`translation_spill` of :data:`CENTRE_UNCERTAINTY` of the band's offset), and
    at least the share for which the fit radiates an order at all
    (``wave_stencils.RESOLVED_AMPLITUDE``², 4·10⁻⁴: less is not worth a term). False
    where one centre costs the band nothing measurable: the fit's orders carry a small
    translation (a translation by δ moves a pattern's energy above its orders only as the
    spherical Bessel functions j_n(kδ), n > L, allow)."""
    uncertain = CENTRE_UNCERTAINTY * np.linalg.norm(band_centres, axis=1)
    excess = np.asarray(residual_shared, float) - np.asarray(residual_own, float)
    floor = np.maximum(np.maximum(np.asarray(residual_own, float), RESOLVED_AMPLITUDE ** 2),
                       translation_spill(k_per_m, uncertain, orders))
    apart = np.linalg.norm(band_centres - np.asarray(shared_m)[None], axis=1)
    return (apart > uncertain) & (excess > floor)


def meridian_derivative(v: np.ndarray, theta: np.ndarray, points: int = 7) -> np.ndarray:
    """∂_θ of ``v`` [ring, azimuth, ...] on rings at polar angles ``theta`` (any order) and an
    even number of equally spaced azimuths: along each meridian, continued through the poles
    (the ring at −θ is the ring at θ seen from the azimuth opposite), by ``points``-point
    Lagrange differences on the rings' angles (sixth order for 7; Fornberg, Math. Comp. 51,
    1988: the weights of the derivative of the interpolating polynomial)."""
    order = np.argsort(theta)
    t, w = theta[order], v[order]
    half, n = points // 2, len(t)
    opposite = np.roll(w, v.shape[1] // 2, axis=1)
    t_ext = np.concatenate([-t[:half][::-1], t, 2.0 * np.pi - t[-half:][::-1]])
    w_ext = np.concatenate([opposite[:half][::-1], w, opposite[-half:][::-1]])
    out = np.empty_like(w)
    for i in range(n):
        x = t_ext[i:i + points] - t[i]
        # The derivative at 0 of the polynomial through (x_j, f_j): row 1 of the inverse
        # Vandermonde matrix (powers 0..points-1).
        weights = np.linalg.solve(np.vander(x, increasing=True).T, np.eye(points)[1])
        out[i] = np.tensordot(weights, w_ext[i:i + points], axes=1)
    back = np.empty_like(out)
    back[order] = out
    return back
