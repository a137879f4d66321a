"""The bundle's responses: per cell and direction, the pressure impulse response of the whole
field and of the direct sound alone, packed for the browser.

A response is :meth:`SoundField.impulse_response` (the energy histogram turned into pressure,
see :mod:`sonolux.sound.synthesis`). The direct sound alone is the same synthesis from a
histogram that keeps only the bins where a source's direct sound arrives: for each source, the
bins overlapping (t − w, t + w) around t = distance / c, with w half a sample: both estimators
put the direct sound in the bin that holds t (the "rain" estimator computes it there; the
"paper" estimator's spheres time every crossing by the wavefront's distance to the centre), and
the half sample allows for rounding at a bin's edge. So "direct only" is the same sound, at the
same level, without what the walls add; a cell out of sight of a source has none from it.

The decay is cut where it has died away (``tail_db``, :func:`decay_end`): where the energy still
to come, over all the cell's directions, is that far below the cell's whole energy, so every
direction of a cell ends together and the cut leaves out at most 10^(−tail_db/10) of its energy.

Packing: leading and trailing zeros are cut (``delay`` counts the leading ones, so a response
is ``delay`` zeros then ``length`` stored samples); int16 samples carry one ``scale`` each
(value = int16 × scale, the peak at ±32767), float32 samples a scale of 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.sound.field import SoundField
from sonolux.sound.synthesis import pressure_ir

FADE_OUT_S = 0.010  # the fade at a cut made by max_length_s, so the cut does not click


@dataclass
class PackedResponse:
    delay: int  # zeros before the first stored sample
    samples: np.ndarray  # int16[length] or float32[length]
    scale: float


@dataclass
class CellResponses:
    """One cell's responses, float64[samples] each, in direction order."""

    full: list[np.ndarray]
    direct: list[np.ndarray]


def direct_bins(field: SoundField, receiver: int) -> np.ndarray:
    """bool[time]: the bins that hold a source's direct sound at this receiver."""
    c = float(field.settings["speed_of_sound_m_s"])
    fs = field.sample_rate_hz
    spread_s = 0.5 / fs
    start = field.bin_start_s
    end = start + field.bin_width_s
    keep = np.zeros(start.size, bool)
    for src in np.atleast_2d(field.source_positions_m):
        t = float(np.linalg.norm(field.positions_m[receiver] - src)) / c
        keep |= (start < t + spread_s) & (end > t - spread_s)
    return keep


def decay_end(responses: list[np.ndarray], tail_db: float) -> int:
    """Samples until the energy still to come (summed over the responses: the cell's Schroeder
    curve) is tail_db below the whole; the longest response's length when it never is."""
    n = max((x.size for x in responses), default=0)
    energy = np.zeros(n)
    for x in responses:
        energy[:x.size] += x * x
    to_come = np.cumsum(energy[::-1])[::-1]  # to_come[k]: the energy from sample k on
    if n == 0 or to_come[0] == 0:
        return n
    below = np.flatnonzero(to_come <= to_come[0] * 10.0 ** (-tail_db / 10.0))
    return int(below[0]) if below.size else n


def cell_responses(field: SoundField, receiver: int, seed: int, max_length_s: float | None,
                   tail_db: float | None = None) -> CellResponses:
    """Both sets of one cell: seeds seed + receiver × directions + d, cut at max_length_s and
    where the cell's decay has fallen tail_db (None: not cut by the decay)."""
    n_dir = field.energy.shape[1]
    keep = direct_bins(field, receiver)
    fs = field.sample_rate_hz
    volume = float(field.settings["volume_m3"])
    c = float(field.settings["speed_of_sound_m_s"])
    full, direct = [], []
    whole = [field.impulse_response(receiver, d, seed=seed + receiver * n_dir + d)
             for d in range(n_dir)]
    end_s = max_length_s
    if tail_db is not None:
        t = decay_end(whole, tail_db) / fs
        end_s = t if end_s is None else min(end_s, t)
    for d in range(n_dir):
        s = seed + receiver * n_dir + d
        full.append(_cut(whole[d], fs, end_s))
        e = np.where(keep, field.energy[receiver, d].astype(np.float64), 0.0)
        if np.any(e > 0):
            ir = pressure_ir(e, field.bin_start_s, field.bin_width_s, field.synthesis_bands_hz,
                             fs, volume, c, seed=s)
            direct.append(_cut(ir, fs, end_s))
        else:
            direct.append(np.zeros(0))
    return CellResponses(full, direct)


def pack(x: np.ndarray, sample_format: str) -> PackedResponse:
    """The response without its leading and trailing zeros, as int16 with a scale or float32."""
    x = np.asarray(x, np.float64)
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if peak == 0.0:
        return PackedResponse(0, np.zeros(0, np.int16 if sample_format == "int16" else np.float32),
                              1.0)
    if sample_format == "int16":
        scale = peak / 32767.0
        q = np.clip(np.rint(x / scale), -32767, 32767).astype(np.int16)
    else:
        scale = 1.0
        q = x.astype(np.float32)
    nz = np.flatnonzero(q)
    return PackedResponse(int(nz[0]), q[nz[0]:nz[-1] + 1], scale)


def _cut(x: np.ndarray, fs: int, max_length_s: float | None) -> np.ndarray:
    if max_length_s is None:
        return x
    return fade_cut(x, int(round(max_length_s * fs)), fs)


def fade_cut(x: np.ndarray, n: int, fs: int) -> np.ndarray:
    """x cut to n samples, its last FADE_OUT_S faded by a raised cosine (x itself if shorter)."""
    if x.size <= n:
        return x
    y = x[:n].copy()
    k = min(n, max(1, int(round(FADE_OUT_S * fs))))
    y[n - k:] *= 0.5 * (1 + np.cos(np.pi * (np.arange(k) + 1) / k))
    return y
