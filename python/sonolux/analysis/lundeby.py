"""Noise and truncation compensation of a *measured* decay (Lundeby et al. 1995).

A measured impulse response ends in background noise; integrating the noise as if it were
decay bends the Schroeder curve. Lundeby, Vigran, Bietz & Vorländer, "Uncertainties of
measurements in room acoustics", Acustica 81 (1995) 344-355, find the noise power N and the
crosspoint t_x where the decay meets it; ISO 3382-1:2009 5.3.3 then integrates up to t_x with
N subtracted (Chu) and adds the late decay's energy after t_x (Guski & Vorländer 2014).

A simulated field has no noise floor: its late bins thin out into isolated Monte Carlo
deposits, which this iteration would take for noise. :mod:`sonolux.analysis.decay` therefore
calls it only when a caller asks for ``compensation="lundeby"`` (measured or noise-added
responses). ``cum`` below is the histogram's cumulative energy at the bin edges (float64).
"""

from __future__ import annotations

import math

import numpy as np

DB_PER_NEPER = 10.0 / math.log(10.0)  # 10 log10(e): dB per unit of ln(energy)

_INITIAL_WINDOWS = 50  # Lundeby step 1: the first smoothing window is 1/50 of the record
_WINDOWS_PER_10_DB = 5  # Lundeby step 5: 3 to 10 windows per 10 dB of decay
_NOISE_TAIL_FRACTION = 0.1  # the noise is estimated from at least the last 10 % of the record
_MAX_ITERATIONS = 10


def _windows(cum, edges, t_from, t_to, width):
    """Mean power in windows of ``width`` ending at t_to: (centres, means). At least one."""
    width = min(width, t_to - t_from)
    count = max(1, math.floor((t_to - t_from) / width + 1e-9))
    bounds = t_to - width * np.arange(count, -1, -1)
    energy = np.diff(np.interp(bounds, edges, cum))
    return 0.5 * (bounds[:-1] + bounds[1:]), energy / width


def _line(t, power):
    """Least-squares line through 10 log10(power) vs t: (intercept_db, slope_db_per_s)."""
    y = DB_PER_NEPER * np.log(power)
    slope, intercept = np.polyfit(t - t[0], y, 1)
    return intercept - slope * t[0], slope


def _window_bias_db(slope_db_s, width_s):
    """How far a window's mean power lies above an exponential's value at its centre, dB."""
    x = 0.5 * abs(slope_db_s) * width_s / DB_PER_NEPER
    return DB_PER_NEPER * math.log(math.sinh(x) / x) if x > 1e-8 else 0.0


def late_decay_without_noise(cum, edges, t_cut):
    """Late decay line of a noise-free histogram ending at t_cut: (intercept_db, slope) or None.

    A first line through all windows after the peak sets the window length; the second is
    fitted over the last 20 dB before t_cut.
    """
    t0 = edges[0]
    centres, power = _windows(cum, edges, t0, t_cut, (t_cut - t0) / _INITIAL_WINDOWS)
    keep = (np.arange(power.size) >= np.argmax(power)) & (power > 0)
    if keep.sum() < 2:
        return None
    a, b = _line(centres[keep], power[keep])
    if not b < 0:
        return None
    width = 10.0 / -b / _WINDOWS_PER_10_DB
    if width < t_cut - t0:
        centres, power = _windows(cum, edges, t0, t_cut, width)
        keep = ((np.arange(power.size) >= np.argmax(power)) & (power > 0)
                & (centres >= t_cut - 20.0 / -b))
        if keep.sum() >= 2:
            a2, b2 = _line(centres[keep], power[keep])
            if b2 < 0:
                a, b = a2 - _window_bias_db(b2, width), b2
    return a, b


def lundeby(cum, edges, noise_floor):
    """Lundeby's iteration: (noise power, crosspoint t_x, intercept_db, slope); None when the
    record ends in empty bins (no noise to find); a reason (str) when no decay stands out.

    Steps (Lundeby, Vigran, Bietz & Vorländer 1995): 1 smooth; 2 noise from the last 10 %;
    3 line from the peak to 10 dB above the noise; 4 crosspoint with the noise; 5-6 re-smooth
    with 5 windows per 10 dB; 7 noise from 10 dB of decay past the crosspoint (at least the
    last 10 %); 8 late line over 5..25 dB above the noise (noise subtracted); 9 new crosspoint,
    repeat 7-9 until it settles.
    """
    t0, t_end = edges[0], edges[-1]
    duration = t_end - t0

    def mean_power(t_from):
        return (cum[-1] - np.interp(t_from, edges, cum)) / (t_end - t_from)

    # (1)-(2) Smooth; estimate the noise from the record's last 10 %.
    centres, power = _windows(cum, edges, t0, t_end, duration / _INITIAL_WINDOWS)
    t_tail = t_end - _NOISE_TAIL_FRACTION * duration
    noise = mean_power(t_tail) if noise_floor is None else noise_floor
    if noise <= 0:
        return None
    no_decay = "no decay: no decay found above the noise floor"
    noise_db = DB_PER_NEPER * math.log(noise)
    # (3) Line from the peak to the first window within 10 dB of the noise.
    peak = int(np.argmax(power))
    level = DB_PER_NEPER * np.log(np.maximum(power, 1e-300))
    low = np.nonzero(level[peak:] < noise_db + 10.0)[0]
    stop = peak + (low[0] if low.size else power.size - peak)
    stop = max(stop, min(peak + 2, power.size))
    if stop - peak < 2 or level[peak] < noise_db + 10.0:
        return no_decay
    a, b = _line(centres[peak:stop], power[peak:stop])
    if not b < 0:
        return no_decay
    # (4) Preliminary crosspoint.
    t_x = min(max((noise_db - a) / b, t0), t_end)
    for _ in range(_MAX_ITERATIONS):
        # (5)-(6) Re-smooth with a few windows per 10 dB of the current slope.
        width = min(10.0 / -b / _WINDOWS_PER_10_DB, duration / 4)
        centres, power = _windows(cum, edges, t0, t_end, width)
        # (7) Noise from 10 dB of decay past the crosspoint, at least the last 10 %.
        if noise_floor is None:
            noise = mean_power(min(t_x + 10.0 / -b, t_tail))
            if noise <= 0:
                return None  # the noise window holds only empty bins
            noise_db = DB_PER_NEPER * math.log(noise)
        # (8) Late decay 5 to 25 dB above the noise, with the noise subtracted.
        level = DB_PER_NEPER * np.log(np.maximum(power, 1e-300))
        after_peak = np.arange(power.size) >= np.argmax(power)
        keep = (after_peak & (level >= noise_db + 5.0) & (level <= noise_db + 25.0)
                & (centres <= t_x))
        if keep.sum() < 2:
            keep = after_peak & (level >= noise_db + 5.0)
        if keep.sum() < 2:
            break
        a_new, b_new = _line(centres[keep], power[keep] - noise)
        if not b_new < 0:
            break
        a, b = a_new - _window_bias_db(b_new, width), b_new
        # (9) New crosspoint; stop when it no longer moves.
        t_new = min(max((noise_db - a) / b, t0), t_end)
        settled = abs(t_new - t_x) < 1e-4 * duration
        t_x = t_new
        if settled:
            break
    return noise, t_x, a, b
