"""Decay analysis of one band's energy histogram: the Schroeder decay curve, EDT/T20/T30 with
their checks, clarity (C50, C80), definition (D50), centre time and strength G (ISO 3382-1:2009).

Input convention. ``energy`` holds bin totals in J/m², shape (..., T): any leading axes (bands,
receivers) are kept and every quantity is computed along the last axis, in float64 whatever
the input's dtype (a float32 field summed in another order gives the same parameters). The
time axis may be non-uniform: ``bin_start_s`` and ``bin_width_s`` (both shape (T,)) describe
contiguous bins, for example one-sample bins for the first 80 ms and 1 ms bins after. Within
a bin the energy is taken as spread uniformly, so a bin that straddles a time limit (50 ms,
80 ms, a truncation point) is split in proportion to the time on each side.

Decay curve. The energy decay curve (EDC) at time t is the energy still to arrive after t
(Schroeder, "New method of measuring reverberation time", JASA 37, 1965): at a bin start, the
sum of that bin and all later bins. How the end of the record is treated is the caller's
choice, named in the output (``compensation``):

- ``"none"`` (default, for simulated fields): the plain backward integral of the whole record.
  A simulated histogram has no measurement noise; its tail thins out into isolated Monte
  Carlo deposits, which are energy that did arrive, not noise. The curve is known down to the
  start of the last non-empty bin; below that it is NaN.
- ``"lundeby"`` (measured responses, or synthesised ones with noise added): the noise power N
  and the crosspoint t_x come from Lundeby's iteration (:mod:`sonolux.analysis.lundeby`), N is
  subtracted before t_x and the late decay's energy is added after it (ISO 3382-1 5.3.3). A
  given ``noise_floor`` replaces the estimate; ``noise_floor=0`` compensates truncation only.

Decay times are least-squares lines through the EDC in dB. The EDC is known at bin starts and
taken as piecewise linear between them, and the fit is the continuous one over the exact
crossing times of the range's ends, so that dense early bins weigh no more than sparse late
ones and any binning of the same decay gives the same line.

Checks. A fit is used only when it passes every check below; otherwise its time is NaN and
``<name>_reason`` says why, as 'kind: details' (a wrong number would enter means, maps and
reports):

1. range reached: the curve falls to the range's lower end before its floor (the last
   non-empty bin, or the truncation point t_x); when the record's last 10 % is densely filled
   up to its last bin, the floor is the record's end, which more rays do not lower: the reason
   is then "record too short" (a setting), not "range not reached" (too few rays);
2. slope: negative, and no slower than ``max_decay_time_s`` (the slowest decay the room's
   least absorbing surface and its air allow, see :func:`slowest_decay_time_s`);
3. linearity (T20, T30): ξ = 1000 (1 - r²) ‰ at most 10 ‰ (the non-linearity parameter of
   ISO 3382-2:2008 Annex B, to which ISO 3382-1 refers; values above 10 ‰ mark a curved
   decay). Not for EDT: it is the slope of the early decay by definition, the step of the
   direct sound included, and near a source its curve is never straight;
4. curvature: C = 100 (T30 / T20 - 1) % within ±10 % (same annex: 0-5 % is typical, above 10 %
   the decay is not one slope); T30 is left undefined beyond it, T20 kept;
5. truncation (``"none"`` only): the energy the record misses after its end, estimated as the
   mean power of its last 10 % times the fitted decay's time constant (see ``_end_power`` for
   a histogram that stops while still densely filled), lies at least 20 dB
   below the range's lower end. 20 dB is where a single exponential's fitted time is biased by
   less than 0.4 % for each range (EDT 0.36 %, T20 0.16 %, T30 0.09 %; worked out by fitting
   10 log10(exp(-t/τ) - ε) over each range).
"""

from __future__ import annotations

import math

import numpy as np

from sonolux.analysis.lundeby import DB_PER_NEPER, late_decay_without_noise, lundeby
from sonolux.errors import AnalysisError

# ISO 3382-1 evaluation ranges (upper dB, lower dB); each time is the 60 dB extrapolation.
DECAY_RANGES_DB = {"edt": (0.0, -10.0), "t20": (-5.0, -25.0), "t30": (-5.0, -35.0)}
#: The ways to treat the end of the record (see the module docstring).
COMPENSATIONS = {
    "none": "plain backward integral of the whole record (Schroeder 1965)",
    "lundeby": "noise subtraction and truncation after Lundeby et al. 1995 (ISO 3382-1 5.3.3)",
}
XI_LIMIT_PERMILLE = 10.0  # ISO 3382-2:2008 Annex B
CURVATURE_LIMIT_PERCENT = 10.0  # ISO 3382-2:2008 Annex B
TRUNCATION_MARGIN_DB = 20.0  # missing tail below the range's end: bias < 0.4 % (docstring)
_END_FRACTION = 0.1  # the record's end power is its mean over the last 10 %


# --- public functions --------------------------------------------------------------------


def slowest_decay_time_s(min_absorption, max_chord_m, air_attenuation_per_m,
                         speed_of_sound_m_s):
    """The longest reverberation time a closed room can have, s (broadcasts over bands).

    Every path between two reflections is a chord of the room, at most ``max_chord_m`` long
    (the bounding box's diagonal bounds it), and every reflection keeps at most 1 - α_min of
    the energy; the air takes m (Np/m, energy) along the way. So the energy of any ray, and
    the room's, falls at least at the rate c (-ln(1 - α_min) / d_max + m) per second, and
    T60 ≤ 6 ln 10 / that rate. Openings and scattering only shorten it. Far longer than
    Sabine's or Eyring's T60 (d_max ≫ 4V/S): a bound that flags impossible fits, not a model.
    """
    alpha = np.clip(np.asarray(min_absorption, dtype=np.float64), 0.0, 1.0)
    with np.errstate(divide="ignore"):
        per_reflection = -np.log1p(-alpha)
        rate = speed_of_sound_m_s * (per_reflection / max_chord_m
                                     + np.asarray(air_attenuation_per_m, dtype=np.float64))
        return np.where(rate > 0, 6.0 * math.log(10.0) / rate, np.inf)


def schroeder_curve(energy, noise_floor=None, *, bin_start_s=None, bin_width_s=None,
                    compensation="none"):
    """Backward-integrated energy decay curve in dB re its value at the first bin start.

    ``energy``: float[..., T] bin totals. ``compensation``: ``"none"`` (the plain integral) or
    ``"lundeby"``; ``noise_floor`` (only with ``"lundeby"``): the noise power (energy per
    unit time, J/m² per s; per bin when no widths are given), scalar or shape (...); ``None``
    estimates it, ``0`` compensates truncation only. ``bin_start_s``, ``bin_width_s``:
    float[T]; without them the bins are uniform and of unit width. Returns float[..., T],
    the EDC at bin starts; NaN where no energy is left and nothing is extrapolated.
    """
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    floors = _noise_floors(compensation, noise_floor, lead)
    curves = np.empty_like(e)
    for i in range(e.shape[0]):
        curves[i] = _decay_curve(e[i], edges, compensation, floors[i], math.inf)["edc_db"]
    return curves.reshape(*lead, e.shape[-1])


def decay_times(energy, bin_start_s, bin_width_s, *, compensation="none", noise_floor=None,
                max_decay_time_s=None, onset_s=None, fit_limits=True) -> dict:
    """EDT, T20 and T30 in s by least-squares lines through the EDC (ISO 3382-1 5.3.3, 5.3.4),
    each checked (module docstring); a time that fails a check is NaN with its reason.

    Ranges: EDT 0 to -10 dB (×6), T20 -5 to -25 dB (×3), T30 -5 to -35 dB (×2).
    ``compensation``, ``noise_floor``: see :func:`schroeder_curve`. ``max_decay_time_s``:
    scalar or shape (...), the slowest physically possible decay (``None``: no bound).
    ``onset_s`` (scalar or shape (...)): where the response starts (the direct sound, ISO
    3382-1 A.3.4); the ranges are then counted from the curve's level there, so that energy
    before it (a filter's pre-ringing, noise) does not stretch EDT. ``None``: the first bin.
    ``fit_limits=False`` leaves out checks 3 to 5 (ξ, curvature, the record's length: limits on
    continuous measures of a fit that exists) and gives the fitted times: for an error estimate
    of the fitted value (sonolux.sound.accuracy), where those checks were decided on the whole
    data.

    Returns a dict; each entry has the leading shape of ``energy`` (a float or str for 1-D):
      ``edt_s``, ``t20_s``, ``t30_s``    decay times, s (NaN where undefined)
      ``<name>_r``                       correlation coefficient of the fit (near -1)
      ``<name>_xi_permille``             non-linearity ξ = 1000 (1 - r²)
      ``<name>_reason``                  '' or why the time is NaN
      ``curvature_percent``              C = 100 (T30 / T20 - 1), from the fitted lines
      ``floor_db``                       the EDC's floor (fits stay above it)
      ``edc_db``                         the EDC itself, float[..., T]
      ``compensation``                   the method, a str (one for all traces)
    """
    if compensation not in COMPENSATIONS:
        raise AnalysisError(f"compensation must be one of {sorted(COMPENSATIONS)}, "
                            f"got {compensation!r}")
    e, edges, lead = _prepare(energy, bin_start_s, bin_width_s)
    floors = _noise_floors(compensation, noise_floor, lead)
    bounds = _bounds(max_decay_time_s, lead)
    n = e.shape[0]
    onsets = (np.full(n, edges[0]) if onset_s is None
              else np.broadcast_to(np.asarray(onset_s, dtype=np.float64), lead).reshape(n))
    out: dict = {"edc_db": np.empty_like(e), "floor_db": np.empty(n),
                 "curvature_percent": np.full(n, np.nan)}
    for name in DECAY_RANGES_DB:
        out[f"{name}_s"] = np.full(n, np.nan)
        out[f"{name}_r"] = np.full(n, np.nan)
        out[f"{name}_xi_permille"] = np.full(n, np.nan)
        out[f"{name}_reason"] = np.full(n, "", dtype=object)
    for i in range(n):
        curve = _decay_curve(e[i], edges, compensation, floors[i], bounds[i])
        out["edc_db"][i] = curve["edc_db"]
        out["floor_db"][i] = curve["floor_db"]
        t, curve = _from_onset(edges[:-1], curve, onsets[i])
        slopes = {}
        for name, (upper, lower) in DECAY_RANGES_DB.items():
            fit = _checked_fit(t, curve, upper, lower, bounds[i], linear=name != "edt",
                               limits=fit_limits)
            out[f"{name}_reason"][i] = fit["reason"]
            out[f"{name}_r"][i] = fit["r"]
            out[f"{name}_xi_permille"][i] = 1000.0 * max(0.0, 1.0 - fit["r"] ** 2)
            slopes[name] = fit["slope"]
            if not fit["reason"]:
                out[f"{name}_s"][i] = -60.0 / fit["slope"]
        # (4) Curvature from the two fitted lines (kept as a diagnostic even when T30 fails).
        if slopes["t20"] < 0 and slopes["t30"] < 0:
            c = 100.0 * (slopes["t20"] / slopes["t30"] - 1.0)
            out["curvature_percent"][i] = c
            if fit_limits and not out["t30_reason"][i] and not out["t20_reason"][i] \
                    and abs(c) > CURVATURE_LIMIT_PERCENT:
                out["t30_s"][i] = np.nan
                out["t30_reason"][i] = (
                    f"double slope: curvature C = {c:.1f} % (T30 against T20) is beyond ±"
                    f"{CURVATURE_LIMIT_PERCENT:g} % (ISO 3382-2 Annex B); T20 and EDT describe "
                    "it better")
    out["edc_db"] = out["edc_db"].reshape(*lead, e.shape[-1])
    for key, value in out.items():
        if key == "edc_db":
            continue
        if key.endswith("_reason"):
            value = value.astype(str)
        out[key] = value.reshape(lead)[()] if lead else value[0].item()
    out["compensation"] = compensation
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


def _per_trace(value, lead, name, *, allow_inf=False):
    """A scalar or (lead)-shaped parameter as a float64 array with one entry per trace."""
    n = int(np.prod(lead, dtype=np.int64))
    v = np.broadcast_to(np.asarray(value, dtype=np.float64), lead).reshape(n)
    bad = np.isnan(v) | (np.isinf(v) if not allow_inf else False)
    if np.any(bad) or np.any(v < 0):
        raise AnalysisError(f"{name} must be {'' if allow_inf else 'finite and '}non-negative")
    return v


def _noise_floors(compensation, noise_floor, lead):
    """Per-trace noise floors: None (estimate) or a power; only Lundeby uses them."""
    if compensation not in COMPENSATIONS:
        raise AnalysisError(f"compensation must be one of {sorted(COMPENSATIONS)}, "
                            f"got {compensation!r}")
    n = int(np.prod(lead, dtype=np.int64))
    if noise_floor is None:
        return [None] * n
    if compensation == "none":
        raise AnalysisError("noise_floor needs compensation='lundeby' (a simulated field has "
                            "no noise floor; its whole record is integrated)")
    return [float(x) for x in _per_trace(noise_floor, lead, "noise_floor")]


def _bounds(max_decay_time_s, lead):
    """Per-trace slowest possible decay times, s (inf: no bound)."""
    if max_decay_time_s is None:
        return np.full(int(np.prod(lead, dtype=np.int64)), np.inf)
    v = _per_trace(max_decay_time_s, lead, "max_decay_time_s", allow_inf=True)
    if np.any(v == 0):
        raise AnalysisError("max_decay_time_s must be positive")
    return v


def _scalar(a):
    a = np.asarray(a)
    return a.item() if a.ndim == 0 else a


# --- the decay curve ---------------------------------------------------------------------


def _decay_curve(e, edges, compensation, noise_floor, max_decay_time_s):
    """EDC of one trace: {'edc_db': float[T], 'floor_db', 'failure': str, 'end_power',
    'total'}; ``end_power`` (J/m² per s, mean over the record's last 10 %) is kept for the
    truncation check of the plain integral and 0 where the tail is compensated."""
    cum = np.concatenate([[0.0], np.cumsum(e)])  # float64 running sum at the bin edges
    starts = edges[:-1]
    nonzero = np.nonzero(e > 0)[0]
    if nonzero.size == 0:
        return {"edc_db": np.full(e.size, np.nan), "floor_db": np.nan, "end_power": 0.0,
                "total": 0.0, "failure": "no energy: the histogram holds no energy"}
    if compensation == "none":
        return _plain_curve(e, edges, cum, nonzero[-1])
    t_last = edges[nonzero[-1] + 1]  # end of the last non-empty bin
    slowest_db_s = -60.0 / max_decay_time_s
    # Find the truncation point t_x, the noise power N and the late decay line.
    fit = lundeby(cum, edges, None if noise_floor is None else noise_floor) \
        if noise_floor != 0 else None
    failure = fit if isinstance(fit, str) else ""
    if failure:  # plain Schroeder integral, flagged: decay times will not be fitted to it
        noise, t_x, a, b = 0.0, t_last, np.nan, np.nan
    elif fit is not None:
        noise, t_x, a, b = fit
        if not b < slowest_db_s:
            failure = (f"late decay slower than physically possible: Lundeby's iteration found "
                       f"{b:.3g} dB/s, the room allows at most {slowest_db_s:.3g} dB/s; no real "
                       "noise floor? (simulated fields need compensation='none')")
    else:  # noise-free: cut at the empty tail, extrapolate the late decay after it
        noise, t_x = 0.0, t_last
        late = late_decay_without_noise(cum, edges, t_last)
        a, b = late if late is not None and late[1] < slowest_db_s else (np.nan, np.nan)
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
        return {"edc_db": np.full(e.size, np.nan), "floor_db": np.nan, "end_power": 0.0,
                "total": 0.0, "failure": "no decay: no decay found above the noise floor"}
    with np.errstate(divide="ignore", invalid="ignore"):
        edc_db = DB_PER_NEPER * np.log(edc / total)
        floor_db = DB_PER_NEPER * math.log(tail / total) if tail > 0 else -np.inf
    if tau == 0:
        # No late line: the curve is measured down to the last non-empty bin's start.
        floor_db = float(np.nanmin(edc_db))
    return {"edc_db": edc_db, "floor_db": floor_db, "failure": failure, "end_power": 0.0,
            "total": total}


def _plain_curve(e, edges, cum, last):
    """The plain backward integral (Schroeder 1965) of the whole record; ``last``: index of
    the last non-empty bin. Sums in float64 from the end, so late bins lose no digits."""
    edc = np.cumsum(e[::-1])[::-1]
    total = edc[0]
    with np.errstate(divide="ignore"):
        edc_db = DB_PER_NEPER * np.log(edc / total)
    edc_db[last + 1:] = np.nan
    end_power = max(_end_power(e, edges, cum, edges[-1], require_dense=False),
                    _end_power(e, edges, cum, edges[last + 1], require_dense=True))
    # Sound still arriving densely at the record's end: the curve's floor is the record's,
    # which more rays do not lower (check 1 then says "record too short", not "not reached").
    dense_end = last == e.size - 1 and _end_power(e, edges, cum, edges[-1], require_dense=True) > 0
    return {"edc_db": edc_db, "floor_db": float(edc_db[last]), "failure": "",
            "end_power": float(end_power), "total": float(total), "dense_end": dense_end}


def _end_power(e, edges, cum, t_end, *, require_dense):
    """Mean power over the last 10 % of [start, t_end], J/m² per s; with ``require_dense``,
    0 unless at least half of that window's time lies in non-empty bins.

    A Monte Carlo histogram is an unbiased estimate of the energy up to the record's end,
    however thinly its late bins are filled: what it misses is what would arrive after the
    record's end (t_end = the end). A histogram that stops while its bins are still densely
    filled was cut short (rays dropped below an energy threshold): then the missing energy
    starts at its last non-empty bin (t_end = that bin's end).
    """
    t_from = t_end - _END_FRACTION * (t_end - edges[0])
    power = (np.interp(t_end, edges, cum) - np.interp(t_from, edges, cum)) / (t_end - t_from)
    if require_dense:
        covered = np.clip(np.minimum(edges[1:], t_end) - np.maximum(edges[:-1], t_from), 0, None)
        if covered[e > 0].sum() < 0.5 * (t_end - t_from):
            return 0.0
    return float(power)


# --- decay times -------------------------------------------------------------------------


def _from_onset(t, curve, onset_s):
    """(t, curve) with the curve starting at the onset, at 0 dB there (ISO 3382-1 A.3.4)."""
    if not onset_s > t[0] or curve["failure"]:
        return t, curve
    keep = t > onset_s
    y = curve["edc_db"]
    finite = np.isfinite(y)
    at = float(np.interp(onset_s, t[finite], y[finite])) if finite.any() else 0.0
    shifted = dict(curve, edc_db=np.concatenate([[0.0], y[keep] - at]),
                   floor_db=curve["floor_db"] - at, total=curve["total"] * 10 ** (at / 10))
    return np.concatenate([[onset_s], t[keep]]), shifted


def _checked_fit(t, curve, upper, lower, max_decay_time_s, *, linear, limits=True):
    """The fit over one range and its checks (module docstring, 1-3 and 5; 3 only when
    ``linear``; 3 and 5 only with ``limits``): {'slope': dB/s, 'r', 'reason': '' or why the
    time is undefined}. A reason reads 'kind: details', the kind a short fixed text that tables
    group by."""
    if curve["failure"]:
        return {"slope": np.nan, "r": np.nan, "reason": curve["failure"]}
    y, floor_db = curve["edc_db"], curve["floor_db"]
    # (1) The range is reached above the curve's floor.
    if lower < floor_db:
        if curve.get("dense_end", False):
            return {"slope": np.nan, "r": np.nan,
                    "reason": f"record too short: the decay curve reaches only {floor_db:.1f} dB "
                              f"before the record ends, not {lower:g} dB, and sound still arrives "
                              "at its end (bake longer: max_time_s)"}
        return {"slope": np.nan, "r": np.nan,
                "reason": f"range not reached: the decay curve reaches only {floor_db:.1f} dB "
                          f"before its end, not {lower:g} dB"}
    slope, r = _fit_range(t, y, upper, lower)
    if math.isnan(slope):
        return {"slope": np.nan, "r": np.nan,
                "reason": f"range not reached: the decay curve does not reach {lower:g} dB"}
    out = {"slope": slope, "r": r, "reason": ""}
    # (2) A physically possible slope.
    if not slope < 0:
        out["reason"] = f"no decay: the curve does not fall over {upper:g} to {lower:g} dB"
    elif -60.0 / slope > max_decay_time_s:
        out["reason"] = (f"slower than physically possible: the fit gives {-60.0 / slope:.3g} s, "
                         f"this room at most {max_decay_time_s:.3g} s (its least absorbing "
                         "surface and the air)")
    # (3) A straight line through the range.
    elif not limits:
        pass
    elif linear and 1000.0 * (1.0 - r * r) > XI_LIMIT_PERMILLE:
        out["reason"] = (f"curved decay: ξ = {1000.0 * (1.0 - r * r):.1f} ‰ > "
                         f"{XI_LIMIT_PERMILLE:g} ‰ over {upper:g} to {lower:g} dB "
                         "(ISO 3382-2 Annex B)")
    # (5) The record does not cut the decay short.
    elif curve["end_power"] > 0:
        tail_db = DB_PER_NEPER * math.log(curve["end_power"] * DB_PER_NEPER / -slope
                                          / curve["total"])
        if tail_db > lower - TRUNCATION_MARGIN_DB:
            out["reason"] = (f"record too short: about {tail_db:.0f} dB of the energy would "
                             f"arrive after its end, less than {TRUNCATION_MARGIN_DB:g} dB below "
                             f"{lower:g} dB (bake longer: max_time_s)")
    return out


def _fit_range(t, y, upper, lower):
    """Continuous least-squares line through the piecewise-linear curve y(t) between the
    last crossing of ``upper`` and the first crossing of ``lower``: (slope, r); NaNs when
    the curve does not reach ``lower``."""
    below = np.nonzero(y <= lower)[0]
    if below.size == 0 or below[0] == 0:
        return np.nan, np.nan
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
    return slope, max(-1.0, min(1.0, r))


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
