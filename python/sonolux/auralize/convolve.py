"""Convolution: the cells' responses, multi-band done right, and the partitioned convolver.

Multi-band, two ways that give one result. The field's responses are built per band (the
weighted impulse sequences s[band, n] of :func:`sonolux.sound.synthesis.weighted_sequences`)
and joined by a zero-phase filter bank whose bands sum to one. The paper filters the *signal*
into bands, convolves each band with its band's response and sums (:func:`convolve_bands`);
we build *one broadband response* per direction, Σ_b k_b ⊛ s[b] (:func:`broadband_response`),
and convolve once. Convolution is linear and commutes, so

    Σ_b s[b] ⊛ (k_b ⊛ x) = (Σ_b k_b ⊛ s[b]) ⊛ x

exactly, for the same kernels k_b (tests/auralize/test_convolve.py checks it to 1e-9). Here
k_b = :func:`band_kernels`: the bank of :func:`~sonolux.sound.synthesis.band_split_weights`
as linear-phase FIRs of 2·pad + 1 taps centred on tap pad, where the bank's impulse responses
keep < 2e-9 of their energy (the padding :func:`~sonolux.sound.synthesis.pressure_ir` uses);
trimmed by that delay, the broadband response is the field's pressure response, which
:func:`cell_responses` computes per direction with :func:`~sonolux.sound.synthesis.pressure_ir`.

:class:`PartitionedConvolver` is the engine of every rendering, offline and streaming: uniformly
partitioned overlap-save convolution (a frequency-domain delay line, FDL) of one input with
many filters. The input is cut into blocks of B samples; each block, the spectrum of the last K
input samples (K ≥ 2B, an FFT size) joins a ring of P spectra; a filter cut into P partitions
of B taps, each FFT'd at K, gives the block's output spectrum Σ_p X[i − p] · H[p], whose last B
samples after the inverse FFT are exact. The output of a block needs no input after it: no
latency beyond the block. K > 2B leaves room for a short filter (L ≤ K − 2B + 1 taps, e.g. an
HRIR) to be multiplied in before the inverse FFT, still exactly (:func:`fold`, render.py).

In float32 (the default) the core's engine does the work (``sonolux_core::convolver``: SIMD
multiply-adds and FFTs chosen for the CPU at run time). Its spectra are *planar*: the last two
axes of every spectrum array are [2, bins], real parts then imaginary parts. float64 runs the
same arithmetic in numpy, with the same layouts: a slower reference that the tests hold the
core against.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from sonolux import engine
from sonolux.errors import SonoluxError
from sonolux.sound.synthesis import PAD_PERIODS, band_split_weights, pressure_ir


# --- multi-band ------------------------------------------------------------------------------
def band_kernels(fs: float, bands_hz) -> np.ndarray:
    """float64[band, 2·pad + 1]: the zero-phase band bank as FIRs centred on tap ``pad``;
    they sum to a unit impulse at tap ``pad`` (to rounding)."""
    bands = np.asarray(bands_hz, float)
    if bands.size == 1:
        return np.ones((1, 1))
    pad = int(np.ceil(PAD_PERIODS * fs / np.min(np.diff(bands))))
    taps = 2 * pad + 1
    w = band_split_weights(taps, fs, bands)
    return np.roll(sfft.irfft(w, taps, axis=1), pad, axis=1)


def broadband_response(sequences: np.ndarray, kernels: np.ndarray, trim: bool = True) -> np.ndarray:
    """Σ_b kernels[b] ⊛ sequences[b]: float64[n] trimmed to the sequences' time axis (trim),
    else the whole float64[n + taps − 1], delayed by the kernels' centre tap."""
    s = np.asarray(sequences, float)
    n, taps = s.shape[1], kernels.shape[1]
    size = sfft.next_fast_len(n + taps - 1, real=True)
    spec = np.einsum("bf,bf->f", sfft.rfft(s, size, axis=1), sfft.rfft(kernels, size, axis=1))
    full = sfft.irfft(spec, size)[: n + taps - 1]
    return full[taps // 2: taps // 2 + n] if trim else full


def convolve_bands(x: np.ndarray, sequences: np.ndarray, kernels: np.ndarray) -> np.ndarray:
    """The paper's playback: x split into bands by the kernels, each band convolved with its
    band's sequence, summed. float64[len(x) + n + taps − 2], delayed by the kernels' centre."""
    from scipy.signal import fftconvolve

    return sum(fftconvolve(fftconvolve(x, k), s) for k, s in zip(kernels, sequences))


def cell_responses(field, receiver: int, seed: int = 0) -> np.ndarray:
    """float32[direction, n]: the pressure response of each direction of one cell.

    Each (receiver, direction) draws its fine structure from its own random stream
    (SeedSequence([seed, receiver, direction])): directions and neighbouring cells are then
    decorrelated, as the equal-power cross-fades between cells assume. n is the longest
    direction's length; shorter ones are zero-padded."""
    e = field.energy[receiver]
    out = []
    for d in range(e.shape[0]):
        ss = np.random.SeedSequence([int(seed), int(receiver), d])
        out.append(pressure_ir(e[d].astype(np.float64), field.bin_start_s, field.bin_width_s,
                               field.synthesis_bands_hz, field.sample_rate_hz,
                               field.settings["volume_m3"],
                               field.settings["speed_of_sound_m_s"], seed=ss))
    n = max(1, max(r.size for r in out))
    h = np.zeros((len(out), n), np.float32)
    for d, r in enumerate(out):
        h[d, : r.size] = r
    return h


# --- the partitioned convolver ---------------------------------------------------------------
def fft_size_for(samples: int) -> int:
    """The smallest even 5-smooth number ≥ samples: FFT sizes that both the core's FFTs and
    scipy's handle fastest (an odd size or a large prime factor costs 2x or more)."""
    k = max(2, int(samples))
    while True:
        m = k
        for f in (2, 3, 5):
            while m % f == 0:
                m //= f
        if m == 1 and k % 2 == 0:
            return k
        k += 1


def planar(z: np.ndarray, dtype=None) -> np.ndarray:
    """complex[..., bins] -> float[..., 2, bins] (real parts, then imaginary parts)."""
    return np.ascontiguousarray(np.stack([z.real, z.imag], axis=-2), dtype)


def _complex(a: np.ndarray) -> np.ndarray:
    return a[..., 0, :] + 1j * a[..., 1, :]


def partition(filters: np.ndarray, block: int, fft_size: int, precision: str = "float32",
              partitions: int | None = None) -> np.ndarray:
    """Planar spectra float[channel, P, 2, K/2 + 1] of filters float[channel, n] cut into
    P = ceil(n / B) partitions of B taps (or ``partitions``, zero-padded), each zero-padded to
    the FFT size K; partition 0 holds the first B taps."""
    h = np.atleast_2d(np.asarray(filters))
    c, n = h.shape
    p = partitions or max(1, -(-n // block))
    if p * block < n:
        raise SonoluxError(f"filters of {n} taps do not fit in {p} partitions of {block}")
    if precision == "float32":
        return engine.partition(np.ascontiguousarray(h, np.float32), block, fft_size, p)
    padded = np.zeros((c, p * block))
    padded[:, :n] = h
    return planar(sfft.rfft(padded.reshape(c, p, block), fft_size, axis=2, workers=1))


def fold(filters: np.ndarray, mix: np.ndarray) -> np.ndarray:
    """Planar float[channel, P, 2, bins]: out[e, p] = Σ_d mix[e, d] · filters[d, p], complex,
    bin by bin, for filters float[direction, P, 2, bins] and mix float[channel, direction, 2,
    bins] (e.g. HRIR spectra per ear and direction): exact while the FFT has room for them."""
    if filters.dtype == np.float32:
        return engine.fold(filters, np.ascontiguousarray(mix, np.float32))
    out = np.einsum("edf,dpf->epf", _complex(mix), _complex(filters))
    return planar(out)


class PartitionedConvolver:
    """Uniformly partitioned overlap-save convolution (FDL) of one input signal.

    block: B samples per call; partitions: P, of every filter applied; fft_size: K ≥ 2B;
    precision: "float32" (the core's engine, ~1e-7 relative error) or "float64" (numpy).
    Filters are planar spectra float[channel, P, 2, K/2 + 1] from :func:`partition` or
    :func:`fold`.
    """

    def __init__(self, block: int, partitions: int, fft_size: int | None = None,
                 precision: str = "float32"):
        if not (isinstance(block, (int, np.integer)) and block >= 1):
            raise SonoluxError(f"block size {block!r} is not allowed: a whole number ≥ 1")
        if precision not in ("float32", "float64"):
            raise SonoluxError(f"precision {precision!r} is not allowed: float32 or float64")
        self.block = int(block)
        self.fft_size = int(fft_size or fft_size_for(2 * block))
        if self.fft_size < 2 * self.block:
            raise SonoluxError(f"FFT size {self.fft_size} is below twice the block ({block})")
        self.partitions = int(partitions)
        self.precision = precision
        self.real = np.float32 if precision == "float32" else np.float64
        self.bins = self.fft_size // 2 + 1
        if precision == "float32":
            self._core = engine.Convolver(self.block, self.partitions, self.fft_size)
        else:  # the numpy reference: the last K samples and a ring of P spectra
            self._core = None
            self._input = np.zeros(self.fft_size)
            self._ring = np.zeros((self.partitions, self.bins), np.complex128)
            self._slot = self.partitions - 1

    def push(self, x: np.ndarray) -> None:
        """Takes the next B input samples."""
        x = np.ascontiguousarray(x, self.real)
        if x.shape != (self.block,):
            raise SonoluxError(f"expected a block of {self.block} samples, got {x.shape}")
        if self._core is not None:
            return self._core.push(x)
        self._input[: -self.block] = self._input[self.block:]
        self._input[-self.block:] = x
        self._slot = (self._slot + 1) % self.partitions
        self._ring[self._slot] = sfft.rfft(self._input, workers=1)

    def _check(self, filters: np.ndarray) -> None:
        if filters.ndim != 4 or filters.shape[1:] != (self.partitions, 2, self.bins):
            raise SonoluxError(f"filter spectra {filters.shape} do not fit the convolver: "
                               f"(channel, {self.partitions}, 2, {self.bins})")

    def apply(self, filters: np.ndarray) -> np.ndarray:
        """Planar float[channel, 2, bins]: Σ_p X[i − p] · H[p], the block's output spectra."""
        self._check(filters)
        if self._core is not None:
            return self._core.apply(filters)
        newest_first = (self._slot - np.arange(self.partitions)) % self.partitions
        return planar((_complex(filters) * self._ring[newest_first]).sum(axis=1))

    def inverse(self, spectra: np.ndarray) -> np.ndarray:
        """float[channel, B]: the last B samples of the inverse FFT of planar spectra
        float[channel, 2, bins]."""
        if spectra.ndim != 3 or spectra.shape[1:] != (2, self.bins):
            raise SonoluxError(f"spectra {spectra.shape} do not fit the convolver: "
                               f"(channel, 2, {self.bins})")
        if self._core is not None:
            return self._core.inverse(np.ascontiguousarray(spectra, np.float32))
        return sfft.irfft(_complex(spectra), self.fft_size, axis=-1, workers=1)[:, -self.block:]

    def output(self, filters: np.ndarray) -> np.ndarray:
        """float[channel, B]: the block's output through the filters (apply + inverse FFT)."""
        if self._core is not None:
            self._check(filters)
            return self._core.output(filters)
        return self.inverse(self.apply(filters))
