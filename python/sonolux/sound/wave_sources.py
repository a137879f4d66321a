"""Directional sources in the waves: a cluster of monopoles fitted to the source's pattern per band.

The wave solver's source is a point monopole. A directional source is a cluster of them, each
fed its own signal, whose far field is the pattern's low-order spherical-harmonic part (Bilbao
and Hamilton, "Directional sources in wave-based acoustic simulation", IEEE/ACM TASLP 27(2),
2019: sources as weighted sums of spatial derivatives of the delta, approximated on the grid by
monopoles at neighbouring points). Here:

- **Fit, per band.** The pattern's amplitude A_b(u) (the square root of the engine's energy
  gain towards u, normalised over the sphere; signed for the first-order family, whose pressure
  a + (1 − a)·cos θ changes sign behind the hypercardioid, supercardioid and figure-of-eight)
  is projected on the spherical harmonics of order 0 and 1 over :data:`FIT_DIRECTIONS` nearly
  uniform directions: A_b ≈ c₀ + c·u, with c₀ = ⟨A⟩ and c = 3⟨A·u⟩ (the harmonics' norms over
  the sphere). The fitted pattern is scaled to radiate the source's power in every band
  (c₀² + |c|²/3 = 1, the tracer's convention); the share of the pattern's energy above order 1,
  1 − (c₀² + |c|²/3)/⟨A²⟩, is reported (:attr:`SourceFit.residual`). A pattern given as energy
  only (the talker, the dodecahedron, SOFA) is taken as zero-phase amplitude √g.
- **Cluster.** Order 0: a monopole at the source fed c₀(f)·q̇. Order 1 along each axis e_k: two
  monopoles at ±Δx/2·e_k fed ±(c/Δx)·c_k(f)·q, whose far field is ρ/(4πr)·c_k(f)·(u·e_k)·q̇(τ)
  up to the centred difference's error, 1 − sinc(kΔx/2) ≤ (kΔx)²/24: 1.6% in amplitude
  (0.14 dB) at the grid's f_max, 10 points per wavelength. So **the grid resolves order 1 in
  every wave band** (the rule: order L is kept where (kΔx)²/24 ≤ 2%, which holds for L ≤ 1 up
  to f_max; order 2 is not built). The coefficients c(f) are each band's within the band and
  blend across a quarter band on either side of each band edge (a raised sine in log
  frequency, the width of the energy bands' own crossovers in ``bands.rs``), flat beyond the
  outer bands, applied to the pulse by FFT: smooth in frequency, so the filters are short; the
  pulse is delayed by :data:`PRE_PERIODS` periods of the lowest band so that their non-causal
  half fits before it.
- **Direct sound.** The terms' direct sound is taken out of the responses in the core (each a
  monopole with its own signal) and the exact pattern's direct sound is added back by the bake
  (the tracer's gain towards each receiver), so the direct sound is the target's exactly and only
  the room's part carries the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import fft as sfft

from sonolux.scene.directivity import FIRST_ORDER

#: Directions of the fit (a Fibonacci lattice: nearly equal areas, so plain means integrate).
FIT_DIRECTIONS = 4096
#: The pulse of a directional source is delayed by this many periods of the lowest band centre
#: (plus its own 6σ), room for the non-causal half of the coefficient filters.
PRE_PERIODS = 4.0
#: The air density the wave settings use (the core's WaveSettings default): the terms' signals
#: are volume accelerations scaled as the core's reference pulse.
AIR_DENSITY_KG_M3 = 1.2


@dataclass(frozen=True)
class SourceFit:
    """A pattern's order-0 and order-1 spherical-harmonic fit per band."""

    #: float64[band, 4]: c₀, c_x, c_y, c_z (world frame), scaled so that c₀² + |c|²/3 = 1.
    coefficients: np.ndarray
    #: float64[band]: the share of the pattern's energy above order 1 (0 for the first-order
    #: family).
    residual: np.ndarray

    def energy_gain(self, directions: np.ndarray) -> np.ndarray:
        """float64[direction, band]: the fitted pattern's energy gain towards unit directions."""
        c = self.coefficients
        return (c[:, 0][None] + np.asarray(directions, float) @ c[:, 1:].T) ** 2


def fibonacci_directions(n: int = FIT_DIRECTIONS) -> np.ndarray:
    """float64[n, 3]: unit vectors of the Fibonacci lattice on the sphere."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def amplitude(source: Any, directivity: Any, directions: np.ndarray, n_bands: int) -> np.ndarray:
    """float64[direction, band]: the source's pressure pattern, √(energy gain), signed where the
    first-order family's a + (1 − a)·cos θ is negative."""
    a = np.sqrt(np.maximum(np.asarray(directivity.gains(directions, n_bands), float), 0.0))
    if source.directivity in FIRST_ORDER:
        f = np.asarray(source.forward, float)
        f = f / np.linalg.norm(f)
        first = FIRST_ORDER[source.directivity]
        a = a * np.where(first + (1.0 - first) * (directions @ f) < 0.0, -1.0, 1.0)[:, None]
    return a


def fit(source: Any, directivity: Any, n_bands: int) -> SourceFit:
    """The source's order-0/1 fit per band (see the module's doc)."""
    u = fibonacci_directions()
    a = amplitude(source, directivity, u, n_bands)  # [direction, band]
    c0 = a.mean(axis=0)
    c = 3.0 * (u.T @ a) / len(u)  # [axis, band]
    power = c0 ** 2 + (c ** 2).sum(axis=0) / 3.0
    total = (a ** 2).mean(axis=0)
    norm = np.sqrt(np.maximum(power, 1e-300))
    coefficients = np.column_stack([c0 / norm, (c / norm).T])
    return SourceFit(coefficients, np.clip(1.0 - power / np.maximum(total, 1e-300), 0.0, 1.0))


def pulse_delay_s(bands_hz: np.ndarray, max_frequency_hz: float) -> float:
    """The delay of a directional source's pulse: its own 6σ plus :data:`PRE_PERIODS` periods
    of the lowest band centre."""
    return 6.0 / (math.pi * max_frequency_hz) + PRE_PERIODS / float(np.min(bands_hz))


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
          speed_of_sound_m_s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The cluster of a directional source at ``position_m``: (positions float64[term, 3],
    volume accelerations float64[term, step] at n/fs, pulse delay s), for
    ``engine.simulate_waves(terms=...)``. Bands are those of ``source_fit``, centred at
    ``bands_hz``."""
    sigma = 1.0 / (math.pi * max_frequency_hz)
    delay = pulse_delay_s(bands_hz, max_frequency_hz)
    q0 = 4.0 * math.pi * sigma * math.exp(0.5) / AIR_DENSITY_KG_M3  # as the core's SourcePulse
    t = np.arange(steps) / sample_rate_hz
    x = (t - delay) / sigma
    q = q0 * np.exp(-0.5 * x * x)
    q_dot = -q0 * x / sigma * np.exp(-0.5 * x * x)
    n_fft = sfft.next_fast_len(2 * steps, real=True)
    f = sfft.rfftfreq(n_fft, 1.0 / sample_rate_hz)
    blends = edge_blends(f, np.asarray(bands_hz, float))  # [edge, frequency]

    def filtered(signal: np.ndarray, coefficient: np.ndarray) -> np.ndarray:
        gain = coefficient[0] + np.diff(coefficient) @ blends
        return sfft.irfft(sfft.rfft(signal, n_fft) * gain, n_fft)[:steps]

    c = source_fit.coefficients
    centre = np.asarray(position_m, float)
    positions, signals = [centre], [filtered(q_dot, c[:, 0])]
    scale = speed_of_sound_m_s / spacing_m
    for k in range(3):
        if np.all(c[:, 1 + k] == 0.0):
            continue
        s = filtered(q, c[:, 1 + k]) * scale
        axis = np.eye(3)[k] * (0.5 * spacing_m)
        positions += [centre + axis, centre - axis]
        signals += [s, -s]
    return np.array(positions), np.ascontiguousarray(signals), delay
