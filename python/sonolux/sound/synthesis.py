"""From energy histograms to sound: the pressure impulse response and the paper's filters.

The tracer gives, for one receiver and one direction, ``energy: float[band, time]`` in J/m² per
time bin (the bin's total, not a density) on a non-uniform axis ``bin_start_s``,
``bin_width_s: float[time]`` (one-sample bins early, wider bins later). This module owns the step
from there to signals:

- :func:`band_split_weights`: a zero-phase filter bank whose bands sum to exactly one.
- :func:`poisson_impulses`: random-sign impulses arriving with the density of reflections in a
  room, dN/dt = 4π c³ t² / V (Kuttruff, *Room Acoustics*, ch. 4).
- :func:`weighted_sequences` and :func:`pressure_ir`: the impulses weighted per band by the
  histogram, then split into bands and summed (the method of Schröder and Vorländer).
- :func:`paper_filters`: the energy taps of Pope and Chalmers, one per sample.

Units and normalisation. A pressure ``p`` here is the sound pressure divided by sqrt(ρ₀ c), in
sqrt(W/m²): then Σ p² / fs over a stretch of time is the energy per area that passed in it, in
J/m², the unit of the histogram (multiply by sqrt(ρ₀ c) ≈ 20.3 for pascals in air at 20 °C).

Band energies follow the tracer: every ray carries its whole energy in every band, so a short
broadband pulse of energy E reads E in each band (not E split among them). Synthesis keeps that
convention exactly: for every band b and time bin k,

    Σ_{n in bin k} s[b, n]² / fs = energy[b, k]           (s: the band's weighted sequence)

and ``p = Σ_b w_b ⊛ s[b]`` with the bank w of :func:`band_split_weights`. Since the bank sums to
one, a histogram that is the same in every band gives ``p = s``: its bin energies are the
histogram's, and a single arrival is a single spike of the arrival's energy. Band b of ``p``
(filtered with w_b and divided by the band's share of white noise, mean(W_b²)) follows
energy[b] up to the band filter's time spread and the noise of band-limited signals.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import fft as sfft

from sonolux.errors import SonoluxError

# Bin edges within this many samples of the sample grid are taken to lie on it (their times went
# through floating point on the way here).
_SNAP_SAMPLES = 1e-6
# Zero padding of the band split, in periods of the narrowest crossover (f_{i+1} - f_i): the
# bank's impulse responses keep about 2e-9 of their energy beyond 12.5 such periods (measured
# for octaves), so the circular FFT convolution does not wrap the tail onto the start.
PAD_PERIODS = 12.5


# --- the filter bank -------------------------------------------------------------------------
def band_split_weights(n_fft: int, fs: float, bands_hz) -> np.ndarray:
    """Zero-phase weights float[band, n_fft // 2 + 1] of a perfect-reconstruction filter bank.

    The weights multiply an ``rfft`` of length ``n_fft`` at sample rate ``fs``. Between adjacent
    centres f_i < f_{i+1} the crossover is a raised cosine in log-frequency,
    cos²(π/2 · log(f/f_i) / log(f_{i+1}/f_i)), which falls from 1 at f_i through 1/2 at the
    geometric mean sqrt(f_i f_{i+1}) to 0 at f_{i+1}; the upper band takes the complement.
    So the bands sum to one at every frequency (to rounding), each band is 1 exactly at its
    centre and smaller elsewhere, the lowest band reaches down to 0 Hz and the highest up to
    Nyquist. One band gives all ones.
    """
    bands = _check_bands(bands_hz, fs)
    if not (isinstance(n_fft, (int, np.integer)) and n_fft >= 1):
        raise SonoluxError(f"n_fft = {n_fft!r} is not allowed: a whole number ≥ 1")
    return _cached_weights(int(n_fft), float(fs), tuple(bands.tolist()))


@functools.lru_cache(maxsize=8)
def _cached_weights(n_fft: int, fs: float, bands: tuple) -> np.ndarray:
    """The weights of :func:`band_split_weights`, read-only: every direction of every cell of a
    field asks for the same few."""
    w = _band_weights_at(sfft.rfftfreq(n_fft, 1.0 / fs), np.asarray(bands))
    w.setflags(write=False)
    return w


def _band_weights_at(f: np.ndarray, bands: np.ndarray) -> np.ndarray:
    """The bank's weights float[band, f.size] at frequencies f (Hz, ≥ 0)."""
    lo, hi = bands[:-1, None], bands[1:, None]
    # low[i]: the part of the spectrum below crossover i (1 under f_i, 0 above f_{i+1}).
    with np.errstate(divide="ignore"):
        x = np.log(np.maximum(f, 1e-300) / lo) / np.log(hi / lo)
    low = np.where(f <= lo, 1.0, np.where(f >= hi, 0.0, np.cos(0.5 * np.pi * x) ** 2))
    # Band b is what lies below crossover b but not below crossover b - 1: the bands telescope
    # to low[-1] - low[0] = 1 - 0 at every frequency.
    edges = np.vstack([np.zeros((1, f.size)), low, np.ones((1, f.size))])
    return np.diff(edges, axis=0)


# --- the fine structure ----------------------------------------------------------------------
def poisson_impulses(duration_s: float, fs: float, volume_m3: float, c: float,
                     rng: np.random.Generator, t0_s: float = 0.0,
                     max_rate_hz: float | None = None) -> np.ndarray:
    """Random-sign impulses float[round(duration_s · fs)] with the arrival density of a room.

    Sample n covers [n/fs, (n+1)/fs). The direct sound is a +1 in the sample holding ``t0_s``;
    after it, reflections arrive as a Poisson process of rate min(4π c³ t² / V, max_rate_hz)
    (t since emission; ``max_rate_hz`` defaults to fs/2, past which the sequence is dense
    noise). Each arrival is +1 or -1 with equal odds and arrivals in the same sample add, so a
    sample holds 0, ±1, ±2, ... and E[x[n]²] equals the expected number of arrivals in it.
    Everything random comes from ``rng``.
    """
    if not (fs > 0 and volume_m3 > 0 and c > 0 and duration_s >= 0 and t0_s >= 0):
        raise SonoluxError("poisson_impulses needs fs, volume_m3 and c > 0 and duration_s, "
                           f"t0_s ≥ 0 (got {fs}, {volume_m3}, {c}, {duration_s}, {t0_s})")
    rate_max = 0.5 * fs if max_rate_hz is None else float(max_rate_hz)
    n = int(np.rint(duration_s * fs))
    x = np.zeros(n)
    k0 = int(np.floor(_snap(np.float64(t0_s * fs))))
    if k0 >= n:
        return x
    # Expected arrivals per sample: the integral of the capped rate over the sample,
    # F(t) = a t³/3 up to the time t_cap where a t² reaches the cap, then linear.
    a = 4.0 * np.pi * c**3 / volume_m3
    t_cap = np.sqrt(rate_max / a)

    def arrivals_until(t):
        return np.where(t <= t_cap, a * t**3 / 3.0, a * t_cap**3 / 3.0 + rate_max * (t - t_cap))

    edges = np.arange(k0 + 1, n + 1, dtype=np.float64) / fs
    mean = np.diff(arrivals_until(edges))
    count = rng.poisson(mean)
    x[k0 + 1:] = 2 * rng.binomial(count, 0.5) - count
    x[k0] = 1.0
    return x


# --- the pressure impulse response -----------------------------------------------------------
def weighted_sequences(energy, bin_start_s, bin_width_s, fs: float, volume_m3: float, c: float,
                       seed: int = 0, direct_s: float | None = None) -> np.ndarray:
    """The impulses weighted per band, float[band, n], before the band split.

    For every band b and bin k with energy, Σ_{n in bin k} s[b, n]² / fs = energy[b, k] (to
    rounding). All bands share one impulse sequence (:func:`poisson_impulses` from ``direct_s``,
    default the start of the first bin with energy); a bin that holds energy but no impulse
    gets one, of random sign, at a random sample of the bin, so no energy is lost. In one-sample
    bins the histogram resolves the arrivals itself: they keep their exact samples and the
    sequence only gives their signs. n is the end of the last bin with energy in samples, or
    of the whole axis when there is none (then s is all zeros). Bins that do not fall on the
    sample grid of ``fs`` are spread over the samples they overlap, each sample counting in
    the bin that holds its middle.
    """
    e, a, b = _check_histogram(energy, bin_start_s, bin_width_s, fs)
    n_bands = e.shape[0]
    has_energy = np.flatnonzero(e.sum(axis=0) > 0)
    if has_energy.size == 0:
        return np.zeros((n_bands, int(np.ceil(b[-1])) if b.size else 0))
    n = int(np.ceil(b[has_energy[-1]]))

    # Spread each bin over its samples, then group the samples by the bin holding their middle.
    group, first, size = _sample_groups(a, n, max(n, int(np.ceil(b[-1]))))
    n_groups = a.size
    if np.all(a == np.floor(a)) and np.all(b == np.floor(b)):
        target = e  # bins on the sample grid (the tracer's): each group is its bin
    else:
        per_sample = _energy_per_sample(e, a, b, n)
        target = np.bincount((np.arange(n_bands)[:, None] * n_groups + group).ravel(),
                             weights=per_sample.ravel(), minlength=n_bands * n_groups)
        target = target.reshape(n_bands, n_groups)

    # The fine structure: one impulse sequence from the direct sound on.
    rng = np.random.default_rng(seed)
    t0 = float(direct_s) if direct_s is not None else a[has_energy[0]] / fs
    x = poisson_impulses(n / fs, fs, volume_m3, c, rng, t0_s=t0)
    power = np.bincount(group, weights=x * x, minlength=n_groups)

    # Give an impulse to every bin that holds energy but drew none.
    empty = np.flatnonzero((target.sum(axis=0) > 0) & (power == 0) & (size > 0))
    where = first[empty] + np.floor(rng.random(empty.size) * size[empty]).astype(np.int64)
    x[where] = rng.choice([-1.0, 1.0], size=empty.size)
    power[empty] = 1.0

    # Scale each bin's impulses so that their energy is the bin's, band by band.
    gain = np.sqrt(np.divide(target * fs, power, out=np.zeros_like(target), where=power > 0))
    return gain[:, group] * x


def pressure_ir(energy, bin_start_s, bin_width_s, bands_hz, fs: float, volume_m3: float,
                c: float, seed: int = 0, direct_s: float | None = None) -> np.ndarray:
    """Pressure impulse response float[n] (sqrt(W/m²), see the module doc) of an energy histogram.

    energy: float[band, time] J/m² per bin; bin_start_s, bin_width_s: float[time] s;
    bands_hz: float[band] centres; fs: sample rate (Hz); volume_m3, c: of the room (the
    density of reflections); seed: of the impulses (same seed, same bits); direct_s: arrival
    of the direct sound (default: the first bin with energy).

    p = Σ_b w_b ⊛ s[b]: the weighted sequences of :func:`weighted_sequences`, each filtered
    with its band of :func:`band_split_weights` (zero-phase, one FFT per band over the whole
    response, zero-padded so that nothing wraps around) and summed. Length as in
    :func:`weighted_sequences`.
    """
    bands = _check_bands(bands_hz, fs)
    e = np.asarray(energy, dtype=np.float64)
    if e.ndim != 2 or e.shape[0] != bands.size:
        raise SonoluxError(f"energy has shape {e.shape}, expected ({bands.size}, time): one row "
                           "per band of bands_hz")
    s = weighted_sequences(e, bin_start_s, bin_width_s, fs, volume_m3, c, seed, direct_s)
    n = s.shape[1]
    if bands.size == 1 or n == 0:
        return s.sum(axis=0)
    pad = int(np.ceil(PAD_PERIODS * fs / np.min(np.diff(bands))))
    # The FFT size follows the whole time axis, not this histogram's last energy, so that every
    # direction of every cell shares one set of band weights.
    n_axis = int(np.ceil((float(np.max(np.asarray(bin_start_s) + np.asarray(bin_width_s)))) * fs))
    n_fft = sfft.next_fast_len(max(n, n_axis) + pad, real=True)
    weights = band_split_weights(n_fft, fs, bands)
    spectrum = np.einsum("bf,bf->f", weights, sfft.rfft(s, n_fft, axis=1))
    return sfft.irfft(spectrum, n_fft)[:n]


# --- the paper's filters ---------------------------------------------------------------------
def paper_filters(energy, bin_start_s, bin_width_s, fs: float, length: int = 3840) -> np.ndarray:
    """The energy filters of Pope and Chalmers: float[band, length] taps at ``fs``.

    Tap k holds the energy (J/m²) arriving in sample k, [k/fs, (k+1)/fs): the bin's value for
    one-sample bins; a wider bin is spread evenly over the time it covers, so its samples share
    its energy in proportion to their overlap. The default 3840 taps are the paper's 80 ms at
    48 kHz; energy after the last tap is left out.
    """
    if not (isinstance(length, (int, np.integer)) and length >= 0):
        raise SonoluxError(f"length = {length!r} is not allowed: a whole number of taps ≥ 0")
    e, a, b = _check_histogram(energy, bin_start_s, bin_width_s, fs)
    return _energy_per_sample(e, a, b, int(length))


# --- helpers ---------------------------------------------------------------------------------
def _energy_per_sample(e: np.ndarray, a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """float[band, n]: each bin [a, b) (in samples) spread evenly over the samples it overlaps."""
    n_axis = max(n, int(np.ceil(b[-1]))) if b.size else n
    which, sample, share = _sample_shares(a.tobytes(), b.tobytes(), n_axis)
    if n < n_axis:  # samples ascend: the ones below n are a prefix
        k = int(np.searchsorted(sample, n))
        which, sample, share = which[:k], sample[:k], share[:k]
    out = np.zeros((e.shape[0], n))
    for band in range(e.shape[0]):
        out[band] = np.bincount(sample, weights=e[band, which] * share, minlength=n)
    return out


# The time axis is the same for every direction of every cell of a field: what depends on it
# alone is computed once (the arrays are read-only).
@functools.lru_cache(maxsize=4)
def _sample_shares(a_bytes: bytes, b_bytes: bytes, n: int):
    """(bin, sample, share) for every sample < n that a bin [a, b) touches: the part of the bin's
    energy that falls in the sample."""
    a, b = np.frombuffer(a_bytes), np.frombuffer(b_bytes)
    k0 = np.floor(a).astype(np.int64)
    touched = np.ceil(b).astype(np.int64) - k0
    which = np.repeat(np.arange(a.size), touched)
    sample = k0[which] + np.arange(which.size) - np.repeat(np.cumsum(touched) - touched, touched)
    share = (np.minimum(b[which], sample + 1) - np.maximum(a[which], sample)) / (b - a)[which]
    keep = sample < n
    out = which[keep], sample[keep], share[keep]
    for x in out:
        x.setflags(write=False)
    return out


def _sample_groups(a: np.ndarray, n: int, n_axis: int):
    """(group, first, size): the bin holding the middle of each of n samples, and each bin's
    first sample and number of samples in that grouping (computed for the n_axis ≥ n samples
    of the whole axis, the same for every histogram on it)."""
    group, first, size = _cached_groups(a.tobytes(), n_axis)
    return group[:n], first, size


@functools.lru_cache(maxsize=4)
def _cached_groups(a_bytes: bytes, n: int):
    a = np.frombuffer(a_bytes)
    group = np.clip(np.searchsorted(a, np.arange(n) + 0.5, side="right") - 1, 0, None)
    first = np.searchsorted(group, np.arange(a.size), side="left")
    size = np.searchsorted(group, np.arange(a.size), side="right") - first
    for x in (group, first, size):
        x.setflags(write=False)
    return group, first, size


def _snap(x: np.ndarray) -> np.ndarray:
    """Sample positions within _SNAP_SAMPLES of a whole number, made whole."""
    r = np.round(x)
    return np.where(np.abs(x - r) <= _SNAP_SAMPLES, r, x)


def _check_bands(bands_hz, fs: float) -> np.ndarray:
    bands = np.asarray(bands_hz, dtype=np.float64).ravel()
    if not fs > 0:
        raise SonoluxError(f"fs = {fs!r} is not allowed: a sample rate > 0 Hz")
    if bands.size == 0 or not np.all(np.isfinite(bands)) or np.any(bands <= 0) \
            or np.any(np.diff(bands) <= 0) or bands[-1] >= fs / 2:
        raise SonoluxError(f"bands_hz = {bands.tolist()} is not allowed: increasing centres "
                           f"above 0 and below Nyquist ({fs / 2:g} Hz)")
    return bands


def _check_histogram(energy, bin_start_s, bin_width_s, fs: float):
    """(energy float64[band, time], bin starts and ends in samples, on the grid when close)."""
    e = np.asarray(energy, dtype=np.float64)
    start = np.asarray(bin_start_s, dtype=np.float64)
    width = np.asarray(bin_width_s, dtype=np.float64)
    if not fs > 0:
        raise SonoluxError(f"fs = {fs!r} is not allowed: a sample rate > 0 Hz")
    if e.ndim != 2 or start.ndim != 1 or start.shape != width.shape \
            or e.shape[1] != start.size:
        raise SonoluxError(f"energy {e.shape}, bin_start_s {start.shape} and bin_width_s "
                           f"{width.shape} do not fit: expected (band, time), (time,), (time,)")
    if not (np.all(np.isfinite(e)) and np.all(e >= 0)):
        raise SonoluxError("energy must be finite and ≥ 0 in every bin")
    if not (np.all(np.isfinite(start)) and np.all(start >= 0) and np.all(width > 0)):
        raise SonoluxError("bins must start at a time ≥ 0 and have a width > 0")
    a = _snap(start * fs)
    b = _snap((start + width) * fs)
    if np.any(a[1:] < b[:-1] - _SNAP_SAMPLES):
        k = int(np.argmax(a[1:] < b[:-1] - _SNAP_SAMPLES))
        raise SonoluxError(f"time bin {k + 1} (start {start[k + 1]:g} s) begins before bin {k} "
                           f"ends ({start[k] + width[k]:g} s): bins must follow one another")
    b[:-1] = np.minimum(b[:-1], a[1:])  # touching bins touch exactly
    if np.any(b <= a):
        raise SonoluxError(f"some bins are narrower than {_SNAP_SAMPLES:g} samples at fs = "
                           f"{fs:g} Hz")
    return e, a, b
