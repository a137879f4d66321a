"""Decay analysis of one band's energy histogram: the Schroeder decay curve, EDT/T20/T30, clarity
(C50, C80), definition (D50), centre time and strength G (ISO 3382-1:2009).

Input convention. ``energy`` holds bin totals in J/m², shape (..., T): any leading axes (bands,
receivers) are kept and every quantity is computed along the last axis. The time axis may be
non-uniform: ``bin_start_s`` and ``bin_width_s`` (both shape (T,)) describe contiguous bins, for
example one-sample bins for the first 80 ms and 1 ms bins after. Within a bin the energy is taken
as spread uniformly, so a bin that straddles a time limit (50 ms, 80 ms, a truncation point) is
split in proportion to the time on each side.

Decay curve. The energy decay curve (EDC) at time t is the energy still to arrive after t
(Schroeder 1965): at a bin start it is the sum of that bin and all later bins. A histogram
ends either in a noise floor (measured or Monte-Carlo noise) or in empty bins; integrating
either as if it were decay bends the end of the curve. So the EDC is integrated only up to a
truncation point t_x, with the noise power N subtracted before it (Chu), and the energy
after t_x is replaced by that of the late exponential decay (Lundeby et al. 1995; ISO 3382-1
5.3.3; Guski & Vorländer 2014):

    EDC(t) = ∫_t^{t_x} (e(t') - N) dt' + C,   C = e_late(t_x) · τ_late,   τ_late = T_late / (6 ln 10)

and EDC(t) = e_late(t) τ_late after t_x, which keeps the curve finite where the histogram is
empty. t_x and N come from Lundeby's iteration (or the caller gives N; N = 0 means "no noise":
t_x is then the end of the last non-empty bin). The decay times are fitted only where the curve
lies above its level at t_x, where it is measured rather than extrapolated.

Decay times are least-squares lines through the EDC in dB. The EDC is known at bin starts and
taken as piecewise linear between them, and the fit is the continuous one over the exact
crossing times of the range's ends, so that dense early bins weigh no more than sparse late
ones and any binning of the same decay gives the same line.
"""

from __future__ import annotations

import math

import numpy as np

from sonolux.errors import AnalysisError

DB_PER_NEPER = 10.0 / math.log(10.0)  # 10 log10(e): dB per unit of ln(energy)

# ISO 3382-1 evaluation ranges (upper dB, lower dB); each time is the 60 dB extrapolation.
DECAY_RANGES_DB = {"edt": (0.0, -10.0), "t20": (-5.0, -25.0), "t30": (-5.0, -35.0)}

_INITIAL_WINDOWS = 50  # Lundeby step 1: the first smoothing window is 1/50 of the record
_WINDOWS_PER_10_DB = 5  # Lundeby step 5: 3 to 10 windows per 10 dB of decay
_NOISE_TAIL_FRACTION = 0.1  # the noise is estimated from at least the last 10 % of the record
_MAX_ITERATIONS = 10


# --- public functions --------------------------------------------------------------------


def schroeder_curve(energy, noise_floor=None, *, bin_start_s=None, bin_width_s=None):
    """Backward-integrated energy decay curve in dB re its value at the first bin start.

    ``energy``: float[..., T] bin totals. ``noise_floor``: the noise power (energy per unit
    time, J/m² per s; per bin when no widths are given), scalar or shape (...): ``None``
    estimates it (Lundeby), ``0`` declares a noise-free histogram whose empty tail is cut.
    ``bin_start_s``, ``bin_width_s``: float[T]; without them the bins are taken as uniform and
    of unit width. Returns float[..., T], the EDC at bin starts; NaN only where no energy is
    left and no decay could be fitted to extrapolate (e.g. a histogram of one non-empty bin).
    Where no decay stands out of the noise, the plain (untruncated) integral is returned.
    """
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    floors = _per_trace(noise_floor, lead, "noise_floor")
    curves = np.empty_like(e)
    for i in range(e.shape[0]):
        curves[i] = _decay_curve(e[i], edges, floors[i])["edc_db"]
    return curves.reshape(*lead, e.shape[-1])


def decay_times(energy, bin_start_s, bin_width_s, *, noise_floor=None) -> dict:
    """EDT, T20 and T30 in s by least-squares lines through the EDC (ISO 3382-1 5.3.3, 5.3.4).

    Ranges: EDT 0 to -10 dB (×6), T20 -5 to -25 dB (×3), T30 -5 to -35 dB (×2). A range whose
    lower end the curve does not reach before its truncation point gives NaN and a reason.

    Returns a dict; each entry has the leading shape of ``energy`` (a float or str for 1-D):
      ``edt_s``, ``t20_s``, ``t30_s``    decay times, s
      ``<name>_r``                       correlation coefficient of the fit (near -1)
      ``<name>_xi_permille``             non-linearity ξ = 1000 (1 - r²) (ISO 3382-1 Annex B)
      ``<name>_reason``                  '' or why the time is NaN
      ``curvature_percent``              C = 100 (T30 / T20 - 1) (ISO 3382-1 Annex B)
      ``floor_db``                       EDC level at the truncation point (fits stay above it)
      ``edc_db``                         the EDC itself, float[..., T]
    """
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    floors = _per_trace(noise_floor, lead, "noise_floor")
    n = e.shape[0]
    out: dict = {"edc_db": np.empty_like(e), "floor_db": np.empty(n)}
    for name in DECAY_RANGES_DB:
        out[f"{name}_s"] = np.full(n, np.nan)
        out[f"{name}_r"] = np.full(n, np.nan)
        out[f"{name}_xi_permille"] = np.full(n, np.nan)
        out[f"{name}_reason"] = np.full(n, "", dtype=object)
    for i in range(n):
        curve = _decay_curve(e[i], edges, floors[i])
        out["edc_db"][i] = curve["edc_db"]
        out["floor_db"][i] = curve["floor_db"]
        for name, (upper, lower) in DECAY_RANGES_DB.items():
            if curve["failure"]:
                out[f"{name}_reason"][i] = curve["failure"]
                continue
            slope, r, reason = _fit_range(edges[:-1], curve["edc_db"], upper, lower,
                                          curve["floor_db"])
            out[f"{name}_reason"][i] = reason
            if not reason:
                out[f"{name}_s"][i] = -60.0 / slope if slope < 0 else np.inf
                out[f"{name}_r"][i] = r
                out[f"{name}_xi_permille"][i] = 1000.0 * max(0.0, 1.0 - r * r)
    out["curvature_percent"] = 100.0 * (out["t30_s"] / out["t20_s"] - 1.0)
    out["edc_db"] = out["edc_db"].reshape(*lead, e.shape[-1])
    for key, value in out.items():
        if key == "edc_db":
            continue
        if key.endswith("_reason"):
            value = value.astype(str)
        out[key] = value.reshape(lead)[()] if lead else value[0].item()
    return out


def c50(energy, bin_start_s, bin_width_s, *, onset_s=None):
    """Clarity C50 in dB: 10 log10(E(0..50 ms) / E(50 ms..end)), times from the onset."""
    return _clarity(energy, bin_start_s, bin_width_s, onset_s, 0.050)


def c80(energy, bin_start_s, bin_width_s, *, onset_s=None):
    """Clarity C80 in dB: 10 log10(E(0..80 ms) / E(80 ms..end)), times from the onset."""
    return _clarity(energy, bin_start_s, bin_width_s, onset_s, 0.080)


def d50(energy, bin_start_s, bin_width_s, *, onset_s=None):
    """Definition D50, a fraction in [0, 1]: E(0..50 ms) / E(0..end), times from the onset.

    ``onset_s`` (scalar or shape (...)) is the arrival of the direct sound; by default the start
    of the first bin whose power is within 20 dB of the histogram's peak power (ISO 3382-1 A.3.4).
    """
    early, total = _early_and_total(energy, bin_start_s, bin_width_s, onset_s, 0.050)
    with np.errstate(invalid="ignore", divide="ignore"):
        return _scalar(early / total)


def centre_time_s(energy, bin_start_s, bin_width_s, *, onset_s=None):
    """Centre time Ts in s: ∫ t e(t) dt / ∫ e(t) dt, t from the onset (see ``d50``)."""
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    onset = _onsets(e, edges, onset_s, lead)[:, None]
    # The part of each bin after the onset, with its own mid-time (energy uniform in a bin).
    start = np.maximum(edges[:-1], onset)
    kept = np.clip(edges[1:] - start, 0.0, None) / np.diff(edges)
    weight = e * kept
    mid = 0.5 * (start + edges[1:]) - onset
    with np.errstate(invalid="ignore", divide="ignore"):
        ts = (weight * mid).sum(axis=-1) / weight.sum(axis=-1)
    return _scalar(ts.reshape(lead))


def strength_g_db(energy_total, power_w):
    """Strength G in dB: 10 log10(E / E_free_10m), E_free_10m = W / (4π 10²) J/m².

    ``energy_total``: the histogram's total (J/m², e.g. ``energy.sum(-1)``), ``power_w``: the
    source's power, so that a free field 10 m from the source gives 0 dB. Broadcasts.
    """
    e = np.asarray(energy_total, dtype=np.float64)
    w = np.asarray(power_w, dtype=np.float64)
    if np.any(w <= 0):
        raise AnalysisError("power_w must be positive")
    with np.errstate(divide="ignore"):
        g = 10.0 * np.log10(e * (4.0 * math.pi * 100.0) / w)
    return _scalar(g)


# --- input handling ----------------------------------------------------------------------


def _prepare(energy, bin_start_s, bin_width_s):
    """energy as (n_traces, T) float64, bin edges (T + 1,), and the leading shape."""
    e = np.asarray(energy, dtype=np.float64)
    if e.ndim == 0 or e.shape[-1] == 0:
        raise AnalysisError(f"energy must have a time axis of at least one bin, got shape {e.shape}")
    if not np.all(np.isfinite(e)):
        raise AnalysisError("energy contains NaN or infinite values")
    if np.any(e < 0):
        raise AnalysisError("energy contains negative bin totals")
    lead = e.shape[:-1]
    return e.reshape(-1, e.shape[-1]), _edges(e.shape[-1], bin_start_s, bin_width_s), lead


def _edges(n_bins, bin_start_s, bin_width_s):
    """Bin edges (T + 1,) from starts and widths; unit bins from 0 when neither is given."""
    if bin_width_s is None:
        if bin_start_s is not None:
            raise AnalysisError("bin_start_s needs bin_width_s")
        return np.arange(n_bins + 1, dtype=np.float64)
    width = np.asarray(bin_width_s, dtype=np.float64)
    if width.shape != (n_bins,):
        raise AnalysisError(f"bin_width_s has shape {width.shape}, expected ({n_bins},)")
    if not np.all(np.isfinite(width)) or np.any(width <= 0):
        raise AnalysisError("bin_width_s must be finite and positive")
    if bin_start_s is None:
        start = np.concatenate([[0.0], np.cumsum(width)[:-1]])
    else:
        start = np.asarray(bin_start_s, dtype=np.float64)
        if start.shape != (n_bins,):
            raise AnalysisError(f"bin_start_s has shape {start.shape}, expected ({n_bins},)")
        gap = np.abs(start[1:] - (start[:-1] + width[:-1]))
        if np.any(gap > 1e-6 * width[:-1] + 1e-12):
            raise AnalysisError("bins must be contiguous: bin_start_s[i+1] = start[i] + width[i]")
    return np.append(start, start[-1] + width[-1])


def _per_trace(value, lead, name):
    """A scalar or (lead)-shaped optional parameter as a list with one entry per trace."""
    n = int(np.prod(lead, dtype=np.int64))
    if value is None:
        return [None] * n
    v = np.broadcast_to(np.asarray(value, dtype=np.float64), lead).reshape(n)
    if np.any(~np.isfinite(v)) or np.any(v < 0):
        raise AnalysisError(f"{name} must be finite and non-negative")
    return [float(x) for x in v]


def _scalar(a):
    a = np.asarray(a)
    return a.item() if a.ndim == 0 else a


# --- the decay curve ---------------------------------------------------------------------


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


def _late_decay_without_noise(cum, edges, t_cut):
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


def _lundeby(cum, edges, noise_floor):
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
    no_decay = "no decay found above the noise floor"
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


def _decay_curve(e, edges, noise_floor):
    """EDC of one trace: {'edc_db': float[T], 'floor_db': float, 'failure': str}."""
    cum = np.concatenate([[0.0], np.cumsum(e)])
    starts = edges[:-1]
    nonzero = np.nonzero(e > 0)[0]
    if nonzero.size == 0:
        return {"edc_db": np.full(e.size, np.nan), "floor_db": np.nan,
                "failure": "the histogram holds no energy"}
    t_last = edges[nonzero[-1] + 1]  # end of the last non-empty bin
    # Find the truncation point t_x, the noise power N and the late decay line.
    fit = None if noise_floor == 0 else _lundeby(cum, edges, noise_floor)
    failure = fit if isinstance(fit, str) else ""
    if failure:  # plain Schroeder integral, flagged: decay times will not be fitted to it
        noise, t_x, a, b = 0.0, t_last, np.nan, np.nan
    elif fit is not None:
        noise, t_x, a, b = fit
    else:  # noise-free: cut at the empty tail
        noise, t_x = 0.0, t_last
        late = _late_decay_without_noise(cum, edges, t_last)
        a, b = late if late is not None else (np.nan, np.nan)
    # Integrate the noise-subtracted energy up to t_x; add the late decay's energy after it.
    tau = DB_PER_NEPER / -b if b < 0 else 0.0  # energy time constant of the late decay, s
    tail = math.exp((a + b * t_x) / DB_PER_NEPER) * tau if tau > 0 else 0.0
    measured = np.interp(t_x, edges, cum) - np.interp(starts, edges, cum) - noise * (t_x - starts)
    edc = np.maximum(measured, 0.0) + tail
    after = starts >= t_x
    if tau > 0:
        edc[after] = tail * np.exp(-(starts[after] - t_x) / tau)
    else:
        edc[after] = np.where(edc[after] > 0, edc[after], np.nan)  # nothing to extrapolate
    total = edc[0]
    if not total > 0:
        return {"edc_db": np.full(e.size, np.nan), "floor_db": np.nan,
                "failure": "no decay found above the noise floor"}
    with np.errstate(divide="ignore", invalid="ignore"):
        edc_db = DB_PER_NEPER * np.log(edc / total)
        floor_db = DB_PER_NEPER * math.log(tail / total) if tail > 0 else -np.inf
    if tau == 0:
        # No late line: the curve is measured down to the last non-empty bin's start.
        floor_db = float(np.nanmin(edc_db))
    return {"edc_db": edc_db, "floor_db": floor_db, "failure": failure}


# --- decay times -------------------------------------------------------------------------


def _fit_range(t, y, upper, lower, floor_db):
    """Continuous least-squares line through the piecewise-linear curve y(t) between the
    last crossing of ``upper`` and the first crossing of ``lower``: (slope, r, reason)."""
    if lower < floor_db:
        return np.nan, np.nan, (f"decay curve reaches only {floor_db:.1f} dB before its "
                                f"truncation point, not {lower:g} dB")
    below = np.nonzero(y <= lower)[0]
    if below.size == 0 or below[0] == 0:
        return np.nan, np.nan, f"decay curve does not reach {lower:g} dB"
    k = below[0]
    j = np.nonzero(y[:k] >= upper)[0][-1]  # y[0] = 0 dB >= upper
    # Exact crossing times, linear between bin starts.
    t_a = t[j] + (y[j] - upper) / (y[j] - y[j + 1]) * (t[j + 1] - t[j])
    t_b = t[k - 1] + (y[k - 1] - lower) / (y[k - 1] - y[k]) * (t[k] - t[k - 1])
    tn = np.concatenate([[t_a], t[j + 1:k], [t_b]]) - t_a
    yn = np.concatenate([[upper], y[j + 1:k], [lower]])
    # Moments of t and y over [t_a, t_b], exact for a piecewise-linear y.
    h = np.diff(tn)
    p, q, yp, yq = tn[:-1], tn[1:], yn[:-1], yn[1:]
    s0 = h.sum()
    mt = (h * (p + q)).sum() / (2 * s0)
    my = (h * (yp + yq)).sum() / (2 * s0)
    vt = (h * (p * p + p * q + q * q)).sum() / (3 * s0) - mt * mt
    vy = (h * (yp * yp + yp * yq + yq * yq)).sum() / (3 * s0) - my * my
    cov = (h * (2 * p * yp + p * yq + q * yp + 2 * q * yq)).sum() / (6 * s0) - mt * my
    slope = cov / vt
    r = cov / math.sqrt(vt * vy) if vt * vy > 0 else -1.0
    return slope, max(-1.0, min(1.0, r)), ""


# --- energy ratios -----------------------------------------------------------------------


def _onsets(e, edges, onset_s, lead):
    """Per-trace onset times (n,): given, or the start of the first bin within 20 dB of the
    peak power (ISO 3382-1 A.3.4)."""
    if onset_s is not None:
        return np.broadcast_to(np.asarray(onset_s, dtype=np.float64), lead).reshape(-1)
    power = e / np.diff(edges)
    first = np.argmax(power >= 0.01 * power.max(axis=-1, keepdims=True), axis=-1)
    return edges[first]


def _early_and_total(energy, bin_start_s, bin_width_s, onset_s, limit_s):
    """Energy from the onset to onset + limit_s, and from the onset on: two (...) arrays."""
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    onset = _onsets(e, edges, onset_s, lead)
    cum = np.concatenate([np.zeros((e.shape[0], 1)), np.cumsum(e, axis=-1)], axis=-1)
    early = np.empty(e.shape[0])
    total = np.empty(e.shape[0])
    for i in range(e.shape[0]):
        at_onset = np.interp(onset[i], edges, cum[i])
        early[i] = np.interp(onset[i] + limit_s, edges, cum[i]) - at_onset
        total[i] = cum[i, -1] - at_onset
    return early.reshape(lead), total.reshape(lead)


def _clarity(energy, bin_start_s, bin_width_s, onset_s, limit_s):
    early, total = _early_and_total(energy, bin_start_s, bin_width_s, onset_s, limit_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _scalar(10.0 * np.log10(early / (total - early)))
