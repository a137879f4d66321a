"""A surface described by its profile, and the scattering it gives at each angle and band.

A scene's plain ``scattering`` is ISO 17497-1's random-incidence scattering coefficient (Vorländer
and Mommertz, "Definition and measurement of random-incidence scattering coefficients", Applied
Acoustics 60(2), 2000): one number a band, which ray tracers (ODEON, CATT, RAVEN and ours) apply
at every angle, and which a wave solver with flat walls cannot see at all. A material whose
``surface`` is described instead carries a model that gives both halves of a hybrid the same
surface: the wave solver its walls (a well behind every boundary patch), the rays s(θ, f).

The model: a phase grating of rigid-backed wells (Kowalczyk, van Walstijn and Murphy, "A phase
grating approach to modeling surface diffusion in FDTD room acoustics simulations", IEEE TASLP
19(3), 528-537, 2011; Cox and D'Antonio, "Acoustic Absorbers and Diffusers", 2nd ed. 2009,
ch. 9-10 for the locally reacting well). The surface is tiled with square patches of side
``patch_m``; each patch is a well whose depth is one of ``depths_m``, all equally likely (a
designed sequence, e.g. a quadratic-residue diffuser's depths, or measured ones). A well of
depth d reflects at its mouth with R = e^{-2jkd} at normal incidence, i.e. it is locally
reacting with specific admittance β = j·tan(kd); at incidence θ from the normal

    R(θ) = (cos θ − β)/(cos θ + β) = (cos θ cos kd − j sin kd)/(cos θ cos kd + j sin kd).

The specular part of the reflection is its phase-locked average over the surface (Mommertz and
Vorländer; ISO 17497-1), so

    s(θ, f) = 1 − |⟨R⟩|² / ⟨|R|²⟩,

and since the wells are lossless (|R| = 1; the material's absorption is applied apart, as for
any material), s = 1 − |⟨R⟩|². The random-incidence coefficient is the ratio of the specular
and total energies averaged over a diffuse field's incidences (Paris' weights sin 2θ dθ; ISO
17497-1 measures exactly these two energies in a reverberation room):

    s_rand = 1 − ∫ |⟨R⟩|² sin 2θ dθ.

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


def mean_reflection(depths_m: Sequence[float], wavenumber_per_m: np.ndarray,
                    cos_theta: np.ndarray) -> np.ndarray:
    """complex128[...]: ⟨R⟩, the wells' reflection factors averaged over the depths, broadcast
    over ``wavenumber_per_m`` and ``cos_theta`` (module doc). At grazing (cos θ = 0) a well of
    depth 0 is a rigid wall, R = 1 (the limit cos θ → 0 of its R)."""
    k = np.asarray(wavenumber_per_m, float)[..., None]
    c = np.asarray(cos_theta, float)[..., None]
    d = np.asarray(depths_m, float)
    a, b = c * np.cos(k * d), np.sin(k * d)
    num, den = a - 1j * b, a + 1j * b
    flat = np.abs(den) == 0.0
    r = np.where(flat, 1.0 + 0j, num / np.where(flat, 1.0, den))
    return r.mean(axis=-1)


def band_frequencies_hz(bands: BandSet) -> np.ndarray:
    """float64[band, FREQUENCIES_PER_BAND]: log-spaced midpoints through each band."""
    edges = bands.edges_hz
    u = (np.arange(FREQUENCIES_PER_BAND) + 0.5) / FREQUENCIES_PER_BAND
    return edges[:, :1] * (edges[:, 1:] / edges[:, :1]) ** u[None, :]


def scattering_by_angle(surface: WellSurface, bands: BandSet, cos_theta: np.ndarray,
                        speed_of_sound_m_s: float) -> np.ndarray:
    """float64[angle, band]: s(θ) in each band (an energy mean over the band's frequencies) at
    ``cos_theta`` (θ from the normal)."""
    k = 2 * np.pi * band_frequencies_hz(bands) / speed_of_sound_m_s   # [band, f]
    c = np.asarray(cos_theta, float)[:, None, None]
    specular = np.abs(mean_reflection(surface.depths_m, k[None], c)) ** 2
    return np.clip(1.0 - specular.mean(axis=-1), 0.0, 1.0)


def random_incidence_scattering(surface: WellSurface, bands: BandSet,
                                speed_of_sound_m_s: float) -> np.ndarray:
    """float64[band]: the random-incidence scattering coefficient (Paris' weights sin 2θ dθ,
    midpoints in θ; module doc)."""
    theta = (np.arange(RANDOM_INCIDENCE_ANGLES) + 0.5) * (np.pi / 2) / RANDOM_INCIDENCE_ANGLES
    w = np.sin(2 * theta) * (np.pi / 2) / RANDOM_INCIDENCE_ANGLES
    s = scattering_by_angle(surface, bands, np.cos(theta), speed_of_sound_m_s)
    return np.clip((w[:, None] * s).sum(axis=0) / w.sum(), 0.0, 1.0)


def rays_table(surface: WellSurface, bands: BandSet, speed_of_sound_m_s: float) -> np.ndarray:
    """float64[TABLE_COSINES, band]: s at cos θ evenly spaced from 0 to 1, the table the rays
    and the image sources read (sonolux_core::sound::scattering)."""
    return np.ascontiguousarray(scattering_by_angle(
        surface, bands, np.linspace(0.0, 1.0, TABLE_COSINES), speed_of_sound_m_s))
