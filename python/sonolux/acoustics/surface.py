"""A surface described by its profile, and the scattering it gives at each angle and band.

A scene's plain ``scattering`` is ISO 17497-1's random-incidence scattering coefficient (Vorländer
and Mommertz, "Definition and measurement of random-incidence scattering coefficients", Applied
Acoustics 60(2), 2000): one number a band, which ray tracers (ODEON, CATT, RAVEN and ours) apply
at every angle, and which a wave solver with flat walls cannot see at all. A material whose
``surface`` is described instead carries a model that gives both halves of a hybrid the same
surface: the wave solver its walls (a well behind every boundary patch), the rays and the image
sources its absorption α(θ, f) and scattering s(θ, f).

The model: a phase grating of rigid-backed wells (Kowalczyk, van Walstijn and Murphy, "A phase
grating approach to modeling surface diffusion in FDTD room acoustics simulations", IEEE TASLP
19(3), 528-537, 2011; Cox and D'Antonio, "Acoustic Absorbers and Diffusers", 2nd ed. 2009,
ch. 9-10 for the locally reacting well). The surface is tiled with square patches of side
``patch_m``; each patch is a well whose depth is one of ``depths_m``, all equally likely (a
designed sequence, e.g. a quadratic-residue diffuser's depths, or measured ones). A rigid-backed
well of depth d has at its mouth the specific admittance j·tan(kd) (R = e^{-2jkd} at normal
incidence). The material's own absorption sits at the mouth, in parallel: its conductance g (the
real admittance whose random-incidence absorption is the material's coefficient, Paris 1928, as
the tracer's locally reacting walls take it), so each patch is a locally reacting wall of
β_n = g + j·tan(k d_n), and at incidence θ from the normal (Morse and Ingard 1968, §6.3)

    R_n(θ) = (cos θ − β_n)/(cos θ + β_n).

The specular part of the reflection is its phase-locked average over the surface (Mommertz and
Vorländer; ISO 17497-1), the total reflected energy the mean of |R_n|², so

    s(θ, f) = 1 − |⟨R⟩|² / ⟨|R|²⟩,        α(θ, f) = 1 − ⟨|R|²⟩.

With g = 0 the wells are lossless and s = 1 − |⟨R⟩|². A well in front of the material changes
what it absorbs (a reactive part lowers α, most at grazing incidence); the waves' walls have the
same admittances (docs/waves-walls.md), so both halves absorb alike. The random-incidence values are
energy means over a diffuse field's incidences (Paris' weights sin 2θ dθ; ISO 17497-1 measures
exactly the specular and total energies in a reverberation room):

    s_rand = 1 − ∫ |⟨R⟩|² sin 2θ dθ / ∫ ⟨|R|²⟩ sin 2θ dθ.

A band's values are energy means over frequencies spread through the band. The model assumes each
patch reflects on its own, which holds for patches of about a third of a wavelength or more: the
wave solver's own measurement (crates/sonolux-core/tests/wave_scattering.rs) gave s within 0.03 of
it for 0.4 m patches at 286-454 Hz, and no scattering for wells drawn per 5 cm cell, finer than the
wave can see. Smaller patches than λ/3 scatter less in the waves than the rays are told.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from sonolux.acoustics.bands import BandSet

#: Frequencies a band's values are averaged over (log-spaced midpoints through the band).
FREQUENCIES_PER_BAND = 16
#: Incidence angles of the random-incidence integral (midpoints in θ, 0 to 90°).
RANDOM_INCIDENCE_ANGLES = 720
#: Nodes of the rays' table, evenly spaced in cos θ from grazing (0) to normal (1): the
#: phase grating's s(θ) peaks a few degrees from grazing (cos θ ≈ 0.05-0.1), which 129 nodes
#: (steps of 0.0078) follow; the table's random-incidence mean is checked against the integral.
TABLE_COSINES = 129


@dataclass(frozen=True)
class WellSurface:
    """Rigid-backed wells (a phase grating): depths ``depths_m`` (m, ≥ 0, at least one > 0),
    each equally likely, one per square patch of side ``patch_m`` (m)."""

    depths_m: tuple[float, ...]
    patch_m: float

    def __post_init__(self) -> None:
        d = np.asarray(self.depths_m, float)
        if d.ndim != 1 or d.size == 0 or not np.all(np.isfinite(d)) or np.any(d < 0) or not np.any(d > 0):
            raise ValueError(f"depths_m = {list(self.depths_m)}: at least one depth, each ≥ 0 m, "
                             "one at least > 0")
        if not (np.isfinite(self.patch_m) and self.patch_m > 0):
            raise ValueError(f"patch_m = {self.patch_m}: a positive length in m")


def paris_absorption(g: np.ndarray) -> np.ndarray:
    """Random-incidence absorption of a wall of real specific admittance g (Paris 1928):
    8g[1 + g/(1 + g) − 2g·ln((1 + g)/g)] (sonolux_core::wall::paris_absorption)."""
    g = np.asarray(g, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 8 * g * (1 + g / (1 + g) - 2 * g * np.log((1 + g) / g))
    return np.where(g > 0, a, 0.0)


#: The real admittance at which Paris' absorption peaks (0.951 at g ≈ 0.64); a locally reacting
#: wall absorbs no more at random incidence.
PARIS_PEAK_G = float(optimize.minimize_scalar(lambda g: -paris_absorption(g), bounds=(0.1, 2.0),
                                              method="bounded", options={"xatol": 1e-12}).x)


def conductance_from_random(alpha: np.ndarray) -> np.ndarray:
    """float64[...]: the smaller real admittance whose random-incidence absorption is ``alpha``
    (the tracer's locally reacting walls: sonolux_core::wall::admittance_from_random); ValueError
    above the 0.951 a locally reacting wall can absorb."""
    alpha = np.asarray(alpha, float)
    peak = float(paris_absorption(PARIS_PEAK_G))
    if np.any(alpha > peak):
        raise ValueError(f"absorption {float(alpha.max()):.3f}: a surface profile needs a locally "
                         f"reacting wall, which absorbs at most {peak:.3f} at random incidence")
    lo, hi = np.zeros_like(alpha), np.full_like(alpha, PARIS_PEAK_G)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        low = paris_absorption(mid) < alpha
        lo, hi = np.where(low, mid, lo), np.where(low, hi, mid)
    return np.where(alpha > 0, 0.5 * (lo + hi), 0.0)


def reflections(depths_m: Sequence[float], conductance: np.ndarray,
                wavenumber_per_m: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """complex128[..., well]: each well's R_n, broadcast over ``conductance``,
    ``wavenumber_per_m`` and ``cos_theta`` (module doc). Written as
    (c·cos kd − g·cos kd − j sin kd)/(c·cos kd + g·cos kd + j sin kd), which has no pole at
    kd = π/2; a rigid flat patch (g = 0, d = 0) at grazing has R = 1, the limit cos θ → 0."""
    g = np.asarray(conductance, float)[..., None]
    k = np.asarray(wavenumber_per_m, float)[..., None]
    c = np.asarray(cos_theta, float)[..., None]
    d = np.asarray(depths_m, float)
    ck, sk = np.cos(k * d), np.sin(k * d)
    num, den = (c - g) * ck - 1j * sk, (c + g) * ck + 1j * sk
    flat = np.abs(den) == 0.0
    return np.where(flat, 1.0 + 0j, num / np.where(flat, 1.0, den))


def band_frequencies_hz(bands: BandSet) -> np.ndarray:
    """float64[band, FREQUENCIES_PER_BAND]: log-spaced midpoints through each band."""
    edges = bands.edges_hz
    u = (np.arange(FREQUENCIES_PER_BAND) + 0.5) / FREQUENCIES_PER_BAND
    return edges[:, :1] * (edges[:, 1:] / edges[:, :1]) ** u[None, :]


def energies(surface: WellSurface, absorption: np.ndarray, bands: BandSet,
             cos_theta: np.ndarray, speed_of_sound_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(specular, total) float64[angle, band]: |⟨R⟩|² and ⟨|R|²⟩, energy means over each band's
    frequencies, at ``cos_theta``, for a material of random-incidence ``absorption``
    float64[band] (its flat face's)."""
    g = conductance_from_random(absorption)[None, :, None]
    k = 2 * np.pi * band_frequencies_hz(bands) / speed_of_sound_m_s   # [band, f]
    c = np.asarray(cos_theta, float)[:, None, None]
    r = reflections(surface.depths_m, g, k[None], c)                   # [angle, band, f, well]
    return (np.abs(r.mean(axis=-1)) ** 2).mean(axis=-1), (np.abs(r) ** 2).mean(axis=-1).mean(axis=-1)


def by_angle(surface: WellSurface, absorption: np.ndarray, bands: BandSet, cos_theta: np.ndarray,
             speed_of_sound_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(α, s) float64[angle, band] at ``cos_theta`` (θ from the normal)."""
    specular, total = energies(surface, absorption, bands, cos_theta, speed_of_sound_m_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(total > 0, 1.0 - specular / total, 0.0)
    return np.clip(1.0 - total, 0.0, 1.0), np.clip(s, 0.0, 1.0)


def random_incidence(surface: WellSurface, absorption: np.ndarray, bands: BandSet,
                     speed_of_sound_m_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(α, s) float64[band]: the random-incidence absorption and scattering coefficients
    (Paris' weights sin 2θ dθ, midpoints in θ; module doc)."""
    theta = (np.arange(RANDOM_INCIDENCE_ANGLES) + 0.5) * (np.pi / 2) / RANDOM_INCIDENCE_ANGLES
    w = np.sin(2 * theta)[:, None]
    specular, total = energies(surface, absorption, bands, np.cos(theta), speed_of_sound_m_s)
    spec, tot = (w * specular).sum(axis=0) / w.sum(), (w * total).sum(axis=0) / w.sum()
    return np.clip(1.0 - tot, 0.0, 1.0), np.clip(1.0 - spec / np.maximum(tot, 1e-300), 0.0, 1.0)


def rays_table(surface: WellSurface, absorption: np.ndarray, bands: BandSet,
               speed_of_sound_m_s: float) -> np.ndarray:
    """float64[2, TABLE_COSINES, band]: α and s at cos θ evenly spaced from 0 to 1, the table
    the rays and the image sources read (sonolux_core::sound::scattering)."""
    a, s = by_angle(surface, absorption, bands, np.linspace(0.0, 1.0, TABLE_COSINES),
                    speed_of_sound_m_s)
    return np.ascontiguousarray(np.stack([a, s]))
