"""Synthesis from energy histograms: the filter bank, the Poisson impulses, the pressure impulse
response and the paper's filters, against exact identities and the statistics they promise."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from scipy import fft as sfft
from scipy import stats

from sonolux.acoustics.bands import NOMINAL_HZ, THIRD_OCTAVE, BandSet
from sonolux.errors import SonoluxError
from sonolux.sound.synthesis import (
    band_split_weights,
    paper_filters,
    poisson_impulses,
    pressure_ir,
    weighted_sequences,
)

FS = 48000
OCTAVES = np.array([125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0])
C = 343.0


def time_axis(early_bins: int = 3840, late_bins: int = 1000, late_bin_s: float = 1e-3):
    """The tracer's axis: one-sample bins for 80 ms, then 1 ms bins (starts, widths, mids)."""
    start = np.r_[np.arange(early_bins) / FS, early_bins / FS + np.arange(late_bins) * late_bin_s]
    width = np.r_[np.full(early_bins, 1.0 / FS), np.full(late_bins, late_bin_s)]
    return start, width, start + width / 2


def decay(t60_s, direct_s: float = 0.01, level: float = 1e-2):
    """Exponential decays float[band, time] (J/m² per bin) from direct_s on, one T60 per band."""
    start, width, mid = time_axis()
    rate = 6 * np.log(10) / np.asarray(t60_s, dtype=float)[:, None]
    energy = level * np.exp(-rate * mid) * width
    energy[:, start < direct_s - 0.5 / FS] = 0.0
    return energy, start, width


def bin_energy(p: np.ndarray, start: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Σ p² / fs in each bin of the axis (bins on the sample grid)."""
    first = np.round(start * FS).astype(int)
    end = round((start[-1] + width[-1]) * FS)
    p2 = np.r_[p, np.zeros(max(0, end - p.size))][:end] ** 2
    return np.add.reduceat(p2, first) / FS


# --- the filter bank -------------------------------------------------------------------------
@pytest.mark.parametrize("n_fft", [4096, 4095, 48000])
@pytest.mark.parametrize("bands", [OCTAVES, 1000 * 2 ** (np.arange(-10, 11) / 3), [500.0]])
def test_bank_sums_to_one(n_fft, bands):
    # The bands telescope to 1 - 0; only rounding (a few ulp) is left: tolerance 1e-12.
    w = band_split_weights(n_fft, FS, bands)
    assert w.shape == (len(bands), n_fft // 2 + 1)
    assert np.max(np.abs(w.sum(axis=0) - 1.0)) <= 1e-12
    assert np.all(w >= -1e-15)


def test_bands_peak_at_their_centres_and_cross_at_geometric_means():
    # With n_fft = fs the grid is 1 Hz, so every octave centre is a grid point (exact values).
    w = band_split_weights(FS, FS, OCTAVES)
    f = np.arange(w.shape[1], dtype=float)
    for b, centre in enumerate(OCTAVES.astype(int)):
        assert w[b, centre] == 1.0
        assert np.all(w[b] <= 1.0)
        rising, falling = np.diff(w[b, : centre + 1]), np.diff(w[b, centre:])
        assert np.all(rising >= 0) and np.all(falling <= 0)
    assert np.all(w[0, f <= 125] == 1.0) and np.all(w[-1, f >= 4000] == 1.0)  # 0 Hz, Nyquist
    for b in range(len(OCTAVES) - 1):
        # The crossover (both bands at 1/2) lies within the 1 Hz bin of the geometric mean.
        lo, hi = int(OCTAVES[b]), int(OCTAVES[b + 1])
        cross = lo + np.flatnonzero(np.diff(np.sign(w[b, lo:hi] - w[b + 1, lo:hi])))[0] + 0.5
        assert abs(cross - np.sqrt(OCTAVES[b] * OCTAVES[b + 1])) <= 1.0


# --- the Poisson impulses --------------------------------------------------------------------
def test_impulse_density_grows_as_t_squared():
    # Σ x² over a window counts every arrival once (E[S_k²] = k for k random signs), so its mean
    # is the integral of 4π c³ t² / V and its variance Σ(λ + 2λ²) over the window's samples.
    # Each window must be within 5σ, and the windows together pass a chi-square test at 1e-4.
    volume, t0, seeds = 2000.0, 0.005, 8
    a = 4 * np.pi * C**3 / volume
    edges = np.arange(0.02, 0.3001, 0.02)
    lam = np.diff(a * (np.arange(int(0.3 * FS) + 1) / FS) ** 3 / 3)  # per sample, below the cap
    assert a * 0.3**2 < FS / 2
    k = np.round(edges * FS).astype(int)
    mean = np.array([lam[i:j].sum() for i, j in pairwise(k)]) * seeds
    var = np.array([(lam[i:j] + 2 * lam[i:j] ** 2).sum() for i, j in pairwise(k)]) * seeds
    counts = np.zeros(len(edges) - 1)
    for seed in range(seeds):
        x = poisson_impulses(0.3, FS, volume, C, np.random.default_rng(seed), t0_s=t0)
        assert x.shape == (int(0.3 * FS),)
        assert x[round(t0 * FS)] == 1.0 and not np.any(x[: round(t0 * FS)])
        counts += np.add.reduceat(x**2, k[:-1])[: len(counts)]
    z = (counts - mean) / np.sqrt(var)
    assert np.all(np.abs(z) < 5), z
    assert np.sum(z**2) < stats.chi2.ppf(1 - 1e-4, len(z))
    # The density at the last window is (0.29 / 0.03)² ≈ 93 times that of the first.
    assert counts[-1] / counts[0] == pytest.approx(mean[-1] / mean[0], rel=0.25)


def test_impulses_cap_at_half_the_sample_rate_and_have_balanced_signs():
    # In a 50 m³ room 4π c³ t² / V passes fs/2 at 14 ms: afterwards each sample expects 1/2
    # arrival. Over 0.5 s (24 000 samples, variance 0.5 + 2·0.25 each) the mean of x² is within
    # 5σ = 5·sqrt(1/24000) of 1/2; the sum of signs within 5 sqrt(Σλ).
    x = poisson_impulses(1.0, FS, 50.0, C, np.random.default_rng(3))
    late = x[FS // 2:]
    assert abs(np.mean(late**2) - 0.5) < 5 * np.sqrt(1.0 / late.size)
    assert abs(np.sum(late)) < 5 * np.sqrt(0.5 * late.size)


# --- the pressure impulse response -----------------------------------------------------------
@pytest.mark.parametrize("volume", [200.0, 1e6])
def test_weighted_sequences_carry_each_bins_energy_exactly(volume):
    # Different decays per band, with holes: for every band and bin Σ s² / fs = energy, to
    # rounding (1e-9 relative). In the 10⁶ m³ room most 1 ms bins draw no Poisson impulse and
    # get the one they need, so this also checks that no energy is lost there.
    energy, start, width = decay([1.5, 1.2, 1.0, 0.8, 0.6, 0.5])
    energy[2, 4000:4100] = 0.0
    energy[:, 4500:4510] = 0.0
    s = weighted_sequences(energy, start, width, FS, volume, C, seed=7)
    got = np.stack([bin_energy(row, start, width) for row in s])
    np.testing.assert_allclose(got, energy, rtol=1e-9, atol=0.0)


def test_equal_bands_give_the_histograms_bin_energies():
    # T60 = 1 s in every band: since the bank sums to one, p is the weighted sequence itself
    # and every bin (early sparse arrivals and late 1 ms bins) has exactly the histogram's
    # energy. Left over is FFT rounding, ~1e-16 of the peak, 1e-13 of the last bins' amplitude.
    energy, start, width = decay(np.ones(6))
    p = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=1)
    assert p.size == round((start[-1] + width[-1]) * FS)
    np.testing.assert_allclose(bin_energy(p, start, width), energy[0], rtol=1e-9, atol=1e-30)


def test_third_octave_bank_sums_to_flat_and_crosses_at_the_iec_edges():
    # All 30 IEC 61260-1 thirds (25 Hz … 20 kHz) on their exact mid-band frequencies, as a
    # third-octave field synthesises: the bank telescopes to one (rounding only: 1e-12), and
    # each crossover (both neighbours at 1/2) is the geometric mean of the two exact centres,
    # the IEC band edge f_m · 10^(0.05), within the 1 Hz grid.
    thirds = BandSet(THIRD_OCTAVE, NOMINAL_HZ[THIRD_OCTAVE])
    w = band_split_weights(FS, FS, thirds.exact_hz)
    assert np.max(np.abs(w.sum(axis=0) - 1.0)) <= 1e-12
    f = np.arange(w.shape[1], dtype=float)
    for b in range(8, thirds.n_bands - 1):  # above 160 Hz a third spans > 35 grid points
        lo, hi = thirds.exact_hz[b], thirds.exact_hz[b + 1]
        inside = (f > lo) & (f < hi)
        cross = f[inside][np.argmin(np.abs(w[b, inside] - w[b + 1, inside]))]
        assert abs(cross - thirds.edges_hz[b, 1]) <= 1.0
    # A histogram equal in every third comes out with its bin energies, as for octaves.
    energy, start, width = decay(np.ones(thirds.n_bands))
    p = pressure_ir(energy, start, width, thirds.exact_hz, FS, 200.0, C, seed=1)
    np.testing.assert_allclose(bin_energy(p, start, width), energy[0], rtol=1e-9, atol=1e-30)


def test_each_band_follows_its_own_decay():
    # Bands with different T60s: band b of p (filtered with its weight w_b, divided by w_b's share
    # of white noise, Σ h_b²) holds the histogram's band energy from 0.1 to 0.6 s. Band-limited
    # noise fluctuates: over 0.5 s the 125 Hz band has a relative spread of ≈ 10 % (≈ 50
    # degrees of freedom), so 32 seeds leave a standard error of ≈ 2 %; the crossovers' overlap
    # biases the top band by ≈ 1 % (its neighbour decays slower). Tolerance: 6 %.
    energy, start, width = decay([1.3, 1.2, 1.0, 0.9, 0.8, 0.7])
    mid = start + width / 2
    window = (mid > 0.1) & (mid < 0.6)
    i0, i1 = round(0.1 * FS), round(0.6 * FS)
    ratio = np.zeros(len(OCTAVES))
    seeds = 32
    for seed in range(seeds):
        p = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=seed)
        n_fft = sfft.next_fast_len(2 * p.size)
        w = band_split_weights(n_fft, FS, OCTAVES)
        share = np.sum(sfft.irfft(w, n_fft, axis=1) ** 2, axis=1)
        bands = sfft.irfft(w * sfft.rfft(p, n_fft), n_fft, axis=1)[:, i0:i1]
        ratio += np.sum(bands**2, axis=1) / FS / share / energy[:, window].sum(axis=1) / seeds
    np.testing.assert_allclose(ratio, 1.0, atol=0.06)


def test_bands_superpose():
    # p is linear in the weighted sequences: the responses of each band alone (same seed, same
    # bins with energy, hence the same impulses) add up to the response of all bands, to FFT
    # rounding (1e-12 of the peak).
    energy, start, width = decay([1.3, 1.2, 1.0, 0.9, 0.8, 0.7])
    whole = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=4)
    parts = sum(pressure_ir(energy * (np.arange(6) == b)[:, None], start, width, OCTAVES, FS,
                            200.0, C, seed=4) for b in range(6))
    assert np.max(np.abs(parts - whole)) <= 1e-12 * np.max(np.abs(whole))


def test_same_seed_same_bits_other_seed_other_response():
    energy, start, width = decay(np.linspace(1.5, 0.6, 6))
    a = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=11)
    b = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=11)
    other = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=12)
    assert np.array_equal(a, b)
    assert a.shape == other.shape
    late = slice(round(0.1 * FS), None)
    assert abs(np.corrcoef(a[late], other[late])[0, 1]) < 0.05  # independent noise


def test_single_early_arrival_is_one_spike():
    # One broadband arrival of E = 1e-4 J/m² in the one-sample bin 480 (10 ms): p is one spike of
    # +sqrt(E fs) (the direct sound is positive) at sample 480, and nothing else: the bank sums
    # to one. Tolerances: rounding, 1e-12 relative.
    start, width, _ = time_axis()
    energy = np.zeros((6, start.size))
    energy[:, 480] = 1e-4
    p = pressure_ir(energy, start, width, OCTAVES, FS, 200.0, C, seed=5)
    assert p.size == 481
    assert p[480] == pytest.approx(np.sqrt(1e-4 * FS), rel=1e-12)
    assert np.max(np.abs(p[:480])) <= 1e-12 * p[480]
    assert np.sum(p**2) / FS == pytest.approx(1e-4, rel=1e-12)


def test_other_sample_rates_keep_the_energy():
    # A 48 kHz histogram synthesized at 44.1 kHz: its one-sample bins no longer fall on the
    # grid; they are spread over the samples they overlap, so each band keeps its total energy
    # (rounding, 1e-9) and the direct sound stays at 10 ms (sample 441).
    energy, start, width = decay(np.linspace(1.5, 0.6, 6))
    s = weighted_sequences(energy, start, width, 44100, 200.0, C, seed=2)
    np.testing.assert_allclose(np.sum(s**2, axis=1) / 44100, energy.sum(axis=1), rtol=1e-9)
    assert np.flatnonzero(s[0])[0] == 441


def test_silence_and_empty_axes():
    start, width, _ = time_axis(early_bins=100, late_bins=10)
    p = pressure_ir(np.zeros((6, start.size)), start, width, OCTAVES, FS, 200.0, C)
    assert p.shape == (round((start[-1] + width[-1]) * FS),) and not np.any(p)
    p = pressure_ir(np.zeros((6, 0)), np.zeros(0), np.zeros(0), OCTAVES, FS, 200.0, C)
    assert p.shape == (0,)


def test_bad_histograms_are_refused():
    start, width, _ = time_axis(early_bins=10, late_bins=3)
    energy = np.ones((6, start.size))
    with pytest.raises(SonoluxError, match="one row per band"):
        pressure_ir(energy[:5], start, width, OCTAVES, FS, 200.0, C)
    overlapping = start.copy()
    overlapping[5] -= 0.5 / FS
    with pytest.raises(SonoluxError, match="begins before"):
        pressure_ir(energy, overlapping, width, OCTAVES, FS, 200.0, C)
    with pytest.raises(SonoluxError, match="≥ 0"):
        pressure_ir(-energy, start, width, OCTAVES, FS, 200.0, C)


# --- the paper's filters ---------------------------------------------------------------------
def test_paper_filters_of_one_sample_bins_are_the_histogram():
    # One-sample bins on the sample grid: each tap is its bin's value, bit for bit.
    energy, start, width = decay(np.linspace(1.5, 0.6, 6))
    taps = paper_filters(energy, start, width, FS)
    assert taps.shape == (6, 3840)
    assert np.array_equal(taps, energy[:, :3840])


@pytest.mark.parametrize("late_bin_s", [1e-3, 1.5 / FS, 0.37e-3])
def test_paper_filters_conserve_energy_of_coarse_bins(late_bin_s):
    # Coarse bins (on or off the sample grid) are spread over the samples they cover: the taps
    # hold the histogram's total (rounding, 1e-12), and a 48-sample bin gives 48 equal taps.
    start, width, _ = time_axis(early_bins=96, late_bins=50, late_bin_s=late_bin_s)
    energy = np.random.default_rng(0).random((6, start.size))
    length = int(np.ceil((start[-1] + width[-1]) * FS))
    taps = paper_filters(energy, start, width, FS, length=length)
    np.testing.assert_allclose(taps.sum(axis=1), energy.sum(axis=1), rtol=1e-12)
    assert np.array_equal(taps[:, :96], energy[:, :96])
    if late_bin_s == 1e-3:
        np.testing.assert_allclose(taps[:, 96:144], np.repeat(energy[:, 96:97] / 48, 48, axis=1),
                                   rtol=1e-12)
        # The default 80 ms keep what arrives in them and leave the rest out.
        short = paper_filters(energy, start, width, FS, length=120)
        np.testing.assert_allclose(short.sum(axis=1), taps[:, :120].sum(axis=1), rtol=1e-12)
