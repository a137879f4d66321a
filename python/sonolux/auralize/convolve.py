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
HRIR) to be multiplied in before the inverse FFT, still exactly (see render.py).
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from sonolux.errors import SonoluxError
from sonolux.sound.synthesis import _PAD_PERIODS, band_split_weights, pressure_ir


# --- multi-band ------------------------------------------------------------------------------
def band_kernels(fs: float, bands_hz) -> np.ndarray:
    """float64[band, 2·pad + 1]: the zero-phase band bank as FIRs centred on tap ``pad``;
    they sum to a unit impulse at tap ``pad`` (to rounding)."""
    bands = np.asarray(bands_hz, float)
    if bands.size == 1:
        return np.ones((1, 1))
    pad = int(np.ceil(_PAD_PERIODS * fs / np.min(np.diff(bands))))
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
                               field.bands_hz, field.sample_rate_hz, field.settings["volume_m3"],
                               field.settings["speed_of_sound_m_s"], seed=ss))
    n = max(1, max(r.size for r in out))
    h = np.zeros((len(out), n), np.float32)
    for d, r in enumerate(out):
        h[d, : r.size] = r
    return h


# --- the partitioned convolver ---------------------------------------------------------------
def partition(filters: np.ndarray, block: int, fft_size: int, dtype=np.complex64,
              partitions: int | None = None) -> np.ndarray:
    """Spectra [K/2 + 1, channel, P] of filters float[channel, n] cut into P = ceil(n / B)
    partitions of B taps (or ``partitions``, zero-padded), each zero-padded to the FFT size K.
    Bins first and partitions last, newest-input partition last (p reversed): the layout
    :meth:`PartitionedConvolver.apply` multiplies with one batched matrix product."""
    h = np.atleast_2d(np.asarray(filters))
    c, n = h.shape
    p = partitions or max(1, -(-n // block))
    if p * block < n:
        raise SonoluxError(f"filters of {n} taps do not fit in {p} partitions of {block}")
    padded = np.zeros((c, p * block), h.dtype)
    padded[:, :n] = h
    parts = padded.reshape(c, p, block)[:, ::-1]
    spectra = sfft.rfft(parts, fft_size, axis=2, workers=1).astype(dtype)
    return np.ascontiguousarray(spectra.transpose(2, 0, 1))


class PartitionedConvolver:
    """Uniformly partitioned overlap-save convolution (FDL) of one input signal.

    block: B samples per call; partitions: P, of every filter applied; fft_size: K ≥ 2B;
    dtype: complex64 (fast, ~1e-7 relative error) or complex128.
    """

    def __init__(self, block: int, partitions: int, fft_size: int | None = None,
                 dtype=np.complex64):
        if not (isinstance(block, (int, np.integer)) and block >= 1):
            raise SonoluxError(f"block size {block!r} is not allowed: a whole number ≥ 1")
        self.block = int(block)
        self.fft_size = int(fft_size or 2 * block)
        if self.fft_size < 2 * self.block:
            raise SonoluxError(f"FFT size {self.fft_size} is below twice the block ({block})")
        self.partitions = int(partitions)
        self.dtype = np.dtype(dtype)
        self.real = np.float32 if self.dtype == np.complex64 else np.float64
        bins = self.fft_size // 2 + 1
        self._input = np.zeros(self.fft_size, self.real)
        # Each input spectrum is stored twice, in columns s and s + P of [bins, 2P], so the
        # last P spectra, oldest first, are one slice: ring[:, s + 1 : s + 1 + P].
        self._ring = np.zeros((bins, 2 * self.partitions), self.dtype)
        # The same spectra partition-major, [2P, bins], for filters laid out channels-first.
        self._ring_rows = np.zeros((2 * self.partitions, bins), self.dtype)
        self._slot = -1

    def push(self, x: np.ndarray) -> None:
        """Takes the next B input samples."""
        x = np.asarray(x, self.real)
        if x.shape != (self.block,):
            raise SonoluxError(f"expected a block of {self.block} samples, got {x.shape}")
        buf = self._input
        buf[: -self.block] = buf[self.block:]
        buf[-self.block:] = x
        self._slot = (self._slot + 1) % self.partitions
        spec = sfft.rfft(buf, workers=1)
        self._ring[:, self._slot] = spec
        self._ring[:, self._slot + self.partitions] = spec
        self._ring_rows[self._slot] = spec
        self._ring_rows[self._slot + self.partitions] = spec

    def apply(self, spectra: np.ndarray) -> np.ndarray:
        """complex[channel, K/2 + 1]: Σ_p X[i − p] · H[p] for filter spectra [bins, channel, P]
        from :func:`partition`. Its inverse FFT's last B samples are the block's output."""
        if spectra.shape[2] != self.partitions or spectra.shape[0] != self._ring.shape[0]:
            raise SonoluxError(f"filter spectra {spectra.shape} do not fit the convolver "
                               f"({self._ring.shape[0]} bins, {self.partitions} partitions)")
        s = self._slot
        x = self._ring[:, s + 1: s + 1 + self.partitions, None]
        # One small matrix-vector product per frequency bin, batched: BLAS does the sums.
        return np.matmul(spectra, x)[:, :, 0].T

    def apply_channels_first(self, spectra: np.ndarray) -> np.ndarray:
        """As :meth:`apply` for filter spectra laid out [channel, P, bins] (bins contiguous):
        faster with few partitions of many bins (large blocks, few channels), where it streams
        once through the filters instead of one small matrix product per bin."""
        if spectra.ndim != 3 or spectra.shape[1:] != (self.partitions, self._ring.shape[0]):
            raise SonoluxError(f"filter spectra {spectra.shape} do not fit the convolver "
                               f"({self.partitions} partitions, {self._ring.shape[0]} bins)")
        s = self._slot
        return (spectra * self._ring_rows[s + 1: s + 1 + self.partitions]).sum(axis=1)

    def output(self, spectra: np.ndarray) -> np.ndarray:
        """float[channel, B]: the block's output through the filters (apply + inverse FFT)."""
        return sfft.irfft(self.apply(spectra), self.fft_size, axis=-1,
                          workers=1)[..., -self.block:]
