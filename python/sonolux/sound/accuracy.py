"""The error of a progressive sound bake's parameters: T30, EDT and C80 with their delete-a-group
jackknife standard errors, in units of their just-noticeable differences, and the entries the
stopping rule leaves out: decay times nearer a source than ISO 3382's minimum distance, and
parameters undefined for a reason more rays cannot change (:func:`undefined_for_good`), and
those of receivers no energy reaches (:mod:`sonolux.sound.reach`). A
parameter undefined by the rays' noise is waited for (it counts as not converged).

:mod:`sonolux.sound.progressive` bakes in rounds and stops by these numbers; docs/progressive.md
has the derivation and the checks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sonolux.analysis.decay import CURVATURE_LIMIT_PERCENT, XI_LIMIT_PERMILLE, c80, decay_times
from sonolux.analysis.params import onsets_s
from sonolux.sound.reach import UNREACHED, Reach
from sonolux.sound.tail import reliable_below, tail_record

#: Independent ray groups of the delete-a-group jackknife (:mod:`sonolux.sound.rounds`): an SE
#: estimate has GROUPS − 1 degrees of freedom. More groups estimate it better, but each is one
#: more call of the tracer per round, one more [receiver, band, time] array of 8-byte counts and
#: a larger minimum round (GROUPS × 256 rays, the rain and nee pilots' too). 16 groups were
#: measured in session 11 (docs/progressive.md, "Why the L-room ran on to 26 M rays") and not
#: kept: paper-medium's automatic bake took 65 % more CPU time (its 55-receiver grid: twice the
#: tracer calls and pilots of twice the rays) and the L-room benchmark's bake 15 % more rays.
GROUPS = 8
#: Student's t, 97.5 % quantile, GROUPS − 1 = 7 degrees of freedom: the 95 % interval of the
#: reported error (scipy.stats.t.ppf(0.975, 7) = 2.3646; tests/sound/test_progressive.py).
T_95 = 2.365
#: Just-noticeable differences (ISO 3382-1:2009 Table A.1; T30 as EDT, see the module's doc):
#: (value, "relative" or "absolute").
JND = {"t30": (0.05, "relative"), "edt": (0.05, "relative"), "c80": (1.0, "absolute")}
PARAMETERS = tuple(JND)



#: Why a parameter can stay undefined however many rays are traced, by the kind of its reason
#: (:mod:`sonolux.analysis.decay`'s checks): the decay is not straight (ξ above ISO 3382-2's
#: 10 ‰, or T30's curvature against T20 beyond its ±10 %, Annex B): a property of the room, once
#: the measure lies beyond its limit by more than its own 95 % interval (:func:`undefined_for_good`);
#: the record is too short for the range: a setting (``max_time_s``), not noise.
CURVED = {"curved decay": (XI_LIMIT_PERMILLE, "t30_xi_permille"),
          "double slope": (CURVATURE_LIMIT_PERCENT, "curvature_abs_percent")}
SETTING = ("record too short",)


@dataclass
class Errors:
    """Estimates and jackknife standard errors of T30, EDT (s) and C80 (dB):
    float64[receiver, band] each; NaN where the whole bake leaves the parameter undefined,
    inf where it is defined but a leave-out estimate is not."""

    value: dict[str, np.ndarray]
    standard_error: dict[str, np.ndarray]
    #: Entries reported but left out of the stopping rule: bool[receiver, band] per parameter
    #: (decay times nearer a source than ISO 3382's minimum distance: :func:`near_source`).
    excluded: dict[str, np.ndarray] | None = None
    #: Why the whole bake leaves an entry undefined: str[receiver, band] per parameter ('' where
    #: it is defined; :mod:`sonolux.analysis.decay`'s reasons). None: not known.
    why_undefined: dict[str, np.ndarray] | None = None
    #: bool[receiver, band] per parameter: undefined for a reason more rays cannot change
    #: (:func:`undefined_for_good`), left out of the rule. An undefined entry not marked here is
    #: undefined by the rays' noise and counts as not converged. None: every undefined entry is
    #: left out (errors built without the reasons).
    for_good: dict[str, np.ndarray] | None = None
    #: float64[receiver, band] per parameter: for an entry refused by a limit on its fit that
    #: its measure is within the noise of (:data:`CURVED`, not for good), the SE of the fitted
    #: value (without the limits) in the JND's unit; NaN elsewhere. The rule counts it: it
    #: waits until the fitted value is known to the target, whichever side of the limit it ends.
    at_limit_error: dict[str, np.ndarray] | None = None
    #: Receivers no energy reached (:mod:`sonolux.sound.reach`): every parameter of theirs is
    #: left out of the rule, for the reason :data:`UNREACHED`. None: not tested.
    reach: Reach | None = None
    #: float64[receiver] (s): the whole bake's onset, and the onset every group reaches on its
    #: own (:func:`supported_onsets`); where they differ, each parameter's SE is at least the
    #: change between its values at the two, over t(0.975, G − 1). None: not known.
    onset_s: np.ndarray | None = None
    supported_onset_s: np.ndarray | None = None
    #: float64[receiver, band]: Pareto k̂ of the last round's per-ray contributions to the energy
    #: after T30's range (:mod:`sonolux.sound.tail`; NaN: too few to fit), and the rays it was
    #: fitted from. Where k̂ reaches :func:`sonolux.sound.tail.reliable_below` the late mean is
    #: carried by rare rays the jackknife cannot see: reported (record, round line, info), not
    #: waited for — waiting stalled paper-medium and the L-room (docs/progressive.md, "The late
    #: tail's diagnostic"). None: not watched.
    tail_k: np.ndarray | None = None
    tail_rays: int = 0

    def heavy_tail(self, name: str) -> np.ndarray:
        """bool[receiver, band]: T30 entries whose late decay rests on a heavy tail (k̂ at or
        above the reliable bound), not near a source nor left out (reported)."""
        shape = self.value[name].shape
        if name != "t30" or self.tail_k is None:
            return np.zeros(shape, bool)
        with np.errstate(invalid="ignore"):
            heavy = self.tail_k >= reliable_below(self.tail_rays)
        out = heavy & ~np.isnan(self.value[name])
        if self.excluded is not None and name in self.excluded:
            out = out & ~self.excluded[name]
        return out

    def _unreached(self, name: str) -> np.ndarray:
        """bool[receiver, band]: the entries of unreached receivers (undefined: no energy)."""
        shape = self.value[name].shape
        if self.reach is None:
            return np.zeros(shape, bool)
        return np.broadcast_to(self.reach.unreached[:, None], shape) & np.isnan(self.value[name])

    def waiting(self, name: str) -> np.ndarray:
        """bool[receiver, band]: undefined, not for good, not near a source (the rule waits:
        by the fitted value's SE at a limit, else as not converged)."""
        out = np.isnan(self.value[name])
        if self.for_good is None:
            return np.zeros_like(out)
        out = out & ~self.for_good[name] & ~self._unreached(name)
        if self.excluded is not None and name in self.excluded:
            out = out & ~self.excluded[name]
        return out

    def at_limit(self, name: str) -> np.ndarray:
        """bool[receiver, band]: waited for by the SE of the fitted value (:attr:`at_limit_error`)."""
        if self.at_limit_error is None:
            return np.zeros(self.value[name].shape, bool)
        return self.waiting(name) & ~np.isnan(self.at_limit_error[name])

    def counted(self, name: str, *, waiting: float = np.inf) -> np.ndarray:
        """SE in the JND's unit where the stopping rule counts it, NaN elsewhere; an entry at a
        limit counts its fitted value's SE; one undefined by noise (no fit) is ``waiting``
        (inf: not converged)."""
        rel = self.relative(name)
        if self.excluded is not None and name in self.excluded:
            rel = np.where(self.excluded[name], np.nan, rel)
        at = self.at_limit(name)
        if at.any():
            assert self.at_limit_error is not None
            rel = np.where(at, self.at_limit_error[name], rel)
        return np.where(self.waiting(name) & ~at, waiting, rel)

    def relative(self, name: str) -> np.ndarray:
        """The standard error in the unit of the JND (relative or dB)."""
        se = self.standard_error[name]
        return se / np.abs(self.value[name]) if JND[name][1] == "relative" else se

    def worst_over_target(self, fraction: float) -> float:
        """max over parameters, receivers and bands of SE / (fraction × JND): inf while an entry
        is undefined by noise; entries left out (NaN) do not count (0 when nothing counts)."""
        worst = 0.0
        for name in PARAMETERS:
            ratio = self.counted(name) / (fraction * JND[name][0])
            ratio = ratio[~np.isnan(ratio)]
            if ratio.size:
                worst = max(worst, float(ratio.max()))
        return worst

    def summary(self) -> dict[str, Any]:
        """Per parameter: the largest and median standard error (in the JND's unit) of the
        defined entries the rule counts, and where; ``undefined``: entries undefined by noise
        (waited for); ``left_out``: {reason kind: [[receiver, band], ...]} of the entries
        undefined for good; ``near_source``: decay times left out near a source;
        ``onset_uncertain``: the receivers whose onset not every group reaches (their errors
        count the onset's shift: :func:`supported_onsets`)."""
        out: dict[str, Any] = {}
        for name in PARAMETERS:
            rel = self.counted(name, waiting=np.nan)
            ok = ~np.isnan(rel)
            near = (0 if self.excluded is None or name not in self.excluded
                    else int((self.excluded[name] & ~np.isnan(self.relative(name))).sum()))
            at = self.at_limit(name)
            heavy = self.heavy_tail(name)
            entry: dict[str, Any] = {"undefined": int((self.waiting(name) & ~at).sum()),
                                     "onset_uncertain": self.onset_uncertain().tolist(),
                                     "near_source": near, "left_out": self.left_out(name),
                                     "at_limit": self._where(name, at),
                                     "unit": "relative" if JND[name][1] == "relative" else "dB"}
            if name == "t30" and self.tail_k is not None:
                entry["tail"] = tail_record(self.tail_k, heavy, self.tail_rays)
            if ok.any():
                worst = np.unravel_index(np.argmax(np.where(ok, rel, -1.0)), rel.shape)
                entry.update(max=float(rel[worst]), median=float(np.median(rel[ok])),
                             at_receiver=int(worst[0]), at_band=int(worst[1]))
            out[name] = entry
        return out

    def onset_uncertain(self) -> np.ndarray:
        """The receivers (indices) whose whole-bake onset not every group reaches on its own."""
        if self.onset_s is None or self.supported_onset_s is None:
            return np.zeros(0, np.int64)
        return np.flatnonzero(self.supported_onset_s != self.onset_s)

    def left_out(self, name: str) -> dict[str, list[list[int]]]:
        """{reason kind: [[receiver, band], ...]} of the entries undefined for good (not near
        a source: those are counted as such), those of unreached receivers as :data:`UNREACHED`."""
        if self.for_good is None:
            return {}
        good = (self.for_good[name] | self._unreached(name)) & np.isnan(self.value[name])
        if self.excluded is not None and name in self.excluded:
            good = good & ~self.excluded[name]
        return self._where(name, good)

    def _where(self, name: str, mask: np.ndarray) -> dict[str, list[list[int]]]:
        """{reason kind: [[receiver, band], ...]} of the entries of ``mask``."""
        if self.why_undefined is None:
            return {}
        out: dict[str, list[list[int]]] = {}
        unreached = self._unreached(name)
        for r, b in zip(*np.nonzero(mask)):
            kind = (UNREACHED if unreached[r, b] else
                    str(self.why_undefined[name][r, b]).split(":")[0] or "undefined")
            out.setdefault(kind, []).append([int(r), int(b)])
        return out


def parameters(omni: np.ndarray, bin_start_s: np.ndarray, bin_width_s: np.ndarray,
               onset_s: np.ndarray, max_decay_s: np.ndarray | None, *,
               fit_limits: bool = True, details: bool = False) -> dict[str, np.ndarray]:
    """T30, EDT (s) and C80 (dB) of direction-summed energies float64[receiver, band, time]:
    float64[receiver, band] each, NaN where undefined (:mod:`sonolux.analysis.decay`'s checks;
    ``fit_limits=False``: without its limits on a fit that exists: ξ, curvature, the record's
    length). ``details``: also ``<name>_reason`` (str, '' where defined) and the measures of
    :data:`CURVED` (T30's ξ in ‰, its |curvature| in %), float64[receiver, band]."""
    onset = np.broadcast_to(onset_s[:, None], omni.shape[:2])
    bound = None if max_decay_s is None else np.broadcast_to(max_decay_s[None, :omni.shape[1]],
                                                             omni.shape[:2])
    with np.errstate(invalid="ignore", divide="ignore"):
        times = decay_times(omni, bin_start_s, bin_width_s, onset_s=onset,
                            max_decay_time_s=bound, fit_limits=fit_limits)
        clarity = c80(omni, bin_start_s, bin_width_s, onset_s=onset)
    out = {"t30": np.asarray(times["t30_s"], float), "edt": np.asarray(times["edt_s"], float),
           "c80": np.where(np.isfinite(clarity), clarity, np.nan)}
    if details:
        out.update(t30_reason=np.asarray(times["t30_reason"], str),
                   edt_reason=np.asarray(times["edt_reason"], str),
                   c80_reason=np.where(np.isnan(out["c80"]), "no energy: nothing before or "
                                       "after 80 ms to compare", ""),
                   t30_xi_permille=np.asarray(times["t30_xi_permille"], float),
                   curvature_abs_percent=np.abs(np.asarray(times["curvature_percent"], float)))
    return out


def jackknife(total: np.ndarray, groups: np.ndarray, bin_start_s: np.ndarray,
              bin_width_s: np.ndarray, max_decay_s: np.ndarray | None) -> Errors:
    """The delete-a-group jackknife of T30, EDT and C80 from exact counts:
    ``total`` uint64[receiver, band, time] and ``groups`` uint64[group, receiver, band, time]
    (total = their sum). Each leave-out estimate takes its own onset (ISO 3382-1 A.3.4: the
    first bin within 20 dB of the peak), as the bake does (:func:`leave_out_onsets`). Entries
    the whole bake leaves undefined are sorted by :func:`undefined_for_good`."""
    edges = np.append(bin_start_s, bin_start_s[-1] + bin_width_s[-1])
    whole = total.astype(np.float64)
    onset = onsets_s(whole.sum(axis=1), edges)
    value = parameters(whole, bin_start_s, bin_width_s, onset, max_decay_s, details=True)
    g = groups.shape[0]
    measured = (*PARAMETERS, *(key for _, key in CURVED.values()))
    leave_out = {name: np.empty((g, *total.shape[:2])) for name in measured}
    onsets = leave_out_onsets(total, groups, edges)
    for k in range(g):
        # The limits on a fit (ξ, curvature, the record's length) are decided on the whole
        # bake: a leave-out gives the fitted time. Near a limit they flip between leave-outs
        # (measured, L-room T30 at 65,536 rays: curvature 1.1 … 11.5 % among the 8, T30
        # 1.63 … 1.75 s; at 4.8 M rays the record-length estimate −55 dB against its −55 dB
        # limit), which made the SE infinite while the value itself is smooth.
        part = parameters((total - groups[k]).astype(np.float64), bin_start_s, bin_width_s,
                          onsets[k], max_decay_s, fit_limits=False, details=True)
        for name in measured:
            leave_out[name][k] = part[name]
    se = {name: _spread(leave_out[name]) for name in measured}
    # The onset's own uncertainty (supported_onsets): the interval θ ± t·SE must hold the value
    # at the onset that every group reaches on its own.
    supported = supported_onsets(groups, edges)
    fitted = parameters(whole, bin_start_s, bin_width_s, onset, max_decay_s, fit_limits=False)
    moved = (supported != onset)[:, None]
    if moved.any():
        shifted = parameters(whole, bin_start_s, bin_width_s, supported, max_decay_s,
                             fit_limits=False)
        for name in PARAMETERS:
            with np.errstate(invalid="ignore"):
                shift = np.abs(shifted[name] - fitted[name]) / T_95
            se[name] = np.where(moved & (shift > se[name]), shift, se[name])
    errors = {name: np.where(np.isnan(value[name]), np.nan, se[name]) for name in PARAMETERS}
    why = {name: value[f"{name}_reason"] for name in PARAMETERS}
    good = {name: undefined_for_good(why[name], value, se) for name in PARAMETERS}
    # At a limit (refused by ξ or curvature within their noise): the fitted value's own SE.
    at_limit = {}
    for name in PARAMETERS:
        kind = np.char.partition(np.asarray(why[name], str), ":")[..., 0]
        near = np.isin(kind, tuple(CURVED)) & ~good[name]
        scale = np.abs(fitted[name]) if JND[name][1] == "relative" else 1.0
        with np.errstate(invalid="ignore", divide="ignore"):
            at_limit[name] = np.where(near, se[name] / scale, np.nan)
    return Errors({name: value[name] for name in PARAMETERS}, errors, None, why, good, at_limit,
                  onset_s=onset, supported_onset_s=supported)


def leave_out_onsets(total: np.ndarray, groups: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """float64[group, receiver]: the onset (s) of each leave-out estimate, from its own energies
    (:func:`sonolux.analysis.params.onsets_s`, summed over bands as the whole bake's).

    Why (session 12, docs/progressive.md "Rare large deposits"): the onset is the first bin
    within 20 dB of the peak power, an extreme-value statistic of single deposits where no
    direct sound fixes it. In the L-room at 1,048,576 paper rays, receiver 2 (around the
    corner) had its onset at 24.8 ms from one rare early arrival; the 26 M-ray bake puts it at
    33.6 ms. With the whole bake's onset kept for every leave-out, the jackknife never saw
    this: C80 lay up to 18.6 of its SEs from the 26 M value (its eight leave-outs, with their own
    onsets: 24.8 ms seven times, 26.75 ms once). The delete-a-group jackknife is a delete-d
    jackknife with d = n / G rays, and a delete-d jackknife estimates the variance of non-smooth
    statistics such as sample quantiles consistently once √n / d → 0 and n − d → ∞ (Shao and Wu,
    Ann. Statist. 17, 1989; Shao and Tu 1995, §2.3), which the delete-one
    jackknife does not: so the onset is re-estimated in every leave-out. Where a direct sound
    or many rays fix the onset (line of sight; rain and nee's exact direct sound, shared by the
    groups) every leave-out finds the same bin and nothing changes.

    Where they disagree, the parameters jump with the onset, and the spread of eight leave-outs
    is the size of the jump one of them revealed, not the whole error (Shao and Tu 1995, §2.3:
    the jackknife is not consistent for statistics with a jump; measured there: with the
    leave-outs' own onsets, 24.8 ms seven times and 26.75 ms once, C80 still lay 3.8 SEs off,
    the true onset being 33.6 ms): :func:`supported_onsets` bounds the rest."""
    return np.stack([onsets_s((total - part).astype(np.float64).sum(axis=1), edges)
                     for part in groups])


def supported_onsets(groups: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """float64[receiver] (s): the first bin within 20 dB of the whole bake's peak power in every
    group on its own (each group's power × G, as if it were the whole bake; summed over bands).

    Why: the onset is a threshold crossing of one 20.8 µs bin's power. A bin one ray's deposit
    lifts above the threshold has a power known to ±100 % (one Poisson count), and such bins
    give way, as rays are added, to later ones: in the L-room's receiver around the corner the
    onset was 24.8 ms at 1 M rays and 33.6 ms from 4 M on. A bin that every one of the G
    independent groups lifts above the threshold by itself is not a single deposit. As n grows
    every group's power tends to its expectation, so this onset tends to the whole bake's and
    to ISO 3382-1's (A.3.4) onset of the expected powers; the change of a parameter between the
    two onsets is the onset's share of its error that the groups can see. :func:`jackknife`
    widens a parameter's SE to that change over t(0.975, G − 1), so that its 95 % interval holds
    the value at either onset. Measured on the 26 M bake's rounds (docs/progressive.md): at
    1,048,576 rays this onset was 35.6 ms and C80 moved 1.13 dB between the two (its real error
    0.75 dB, its jackknife SE 0.20 dB); at 4.2 M, 0.18 dB (real error 0.04); at 16.8 M, 0. Where a
    direct sound is in every group (line of sight; rain and nee's exact direct sound) the two
    onsets are the same bin and nothing changes."""
    g = groups.shape[0]
    width = np.diff(edges)
    whole = groups.sum(axis=(0, 2), dtype=np.uint64).astype(np.float64) / width
    each = groups.sum(axis=2, dtype=np.uint64).astype(np.float64) * (g / width)
    above = (each >= 0.01 * whole.max(axis=-1, keepdims=True)[None]).all(axis=0)
    return np.where(above.any(axis=-1), edges[np.argmax(above, axis=-1)],
                    onsets_s(whole * width, edges))


def _spread(theta: np.ndarray) -> np.ndarray:
    """The jackknife SE of leave-out estimates float64[group, ...]: inf where one is NaN."""
    g = theta.shape[0]
    with np.errstate(invalid="ignore"):
        spread = np.sqrt((g - 1) / g * np.sum((theta - theta.mean(axis=0)) ** 2, axis=0))
    return np.where(np.isnan(theta).any(axis=0), np.inf, spread)


def undefined_for_good(why: np.ndarray, measures: dict[str, np.ndarray],
                       standard_error: dict[str, np.ndarray]) -> np.ndarray:
    """bool[receiver, band]: the entries whose reason (``why``, '' where defined) more rays
    cannot change. A curved decay (:data:`CURVED`: ξ or T30's curvature beyond ISO 3382-2
    Annex B's limit) is one once its measure lies beyond the limit by more than
    t(0.975, G − 1) × its jackknife SE (``measures``, ``standard_error``: the whole bake's
    measure and its SE): then the room's decay is curved there with 95 % confidence, and more
    rays converge to a curved decay. Within that margin the curvature may be the rays' noise
    (measured on paper-medium's grid, rain at 4,096 rays: 115 of 385 T30 undefined as curved,
    ξ 10.8 … 31 ‰), and the entry is waited for, by its fitted value's SE
    (:attr:`Errors.at_limit_error`): once that is below the target, more rays cannot change the
    value materially, whichever side of the limit it is reported on (measured, L-room, paper to
    50 M rays: receiver 0 at 125–500 Hz, curvature 13–19 % with leave-outs 11–23 %, never
    decided, so the bake ran to its cap). A record too short for the range
    (:data:`SETTING`) is a setting (``max_time_s``). Every other reason (range not reached, no
    energy, a slope slower than the room allows) is the noise of too few rays."""
    kind = np.char.partition(np.asarray(why, str), ":")[..., 0]
    out = np.isin(kind, SETTING)
    refused = np.isin(kind, tuple(CURVED))
    for limit, key in CURVED.values():  # either limit, decided, refuses T30 for good
        with np.errstate(invalid="ignore"):
            beyond = measures[key] - limit > T_95 * standard_error[key]
        out |= refused & beyond
    return out


#: The decay times that ISO 3382's minimum source distance applies to.
DECAY_TIMES = ("t30", "edt")


def minimum_distance_m(volume_m3: float, speed_of_sound_m_s: float, t_s: np.ndarray
                       ) -> np.ndarray:
    """ISO 3382-2:2008 §5.2.3, Eq. (1) (also ISO 3382-1:2009 §5.2.2): microphone positions for
    decay times should be at least d_min = 2 √(V / (c T)) from any source, "to avoid too strong
    an influence of the direct sound" (T: the expected reverberation time)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return 2.0 * np.sqrt(volume_m3 / (speed_of_sound_m_s * t_s))


def near_source(errors: Errors, receivers_m: np.ndarray, sources_m: np.ndarray,
                volume_m3: float, speed_of_sound_m_s: float) -> Errors:
    """``errors`` with T30 and EDT at receivers nearer a source than d_min
    (:func:`minimum_distance_m`, T per band: the median T30 of the bake's receivers, else the
    median EDT) marked as left out of the stopping rule; C80 is kept everywhere.

    Why: there the direct sound carries most of the energy, and the decay curve falls through
    the start of EDT's range (0 dB → −10 dB) or T30's (−5 dB) within the direct sound itself.
    Whether the curve just after the direct sound lies above or below −10 dB (or −5 dB) flips
    EDT between a decay of the reverberation (e.g. 0.81 s) and a fit through one sample (1e-4 s):
    the parameter is a discontinuous function of the energies, the jackknife's leave-out estimates
    land on both sides, and its SE (valid for smooth statistics only: Shao and Tu 1995 §2.3) is
    the size of the jump (measured on paper-small, receiver 7 at 8 kHz: 128 %, then 5.7e5 %).
    ISO 3382 itself places no decay-time measurement there. The values and their SE are still
    reported; ``summary`` counts them as ``near_source``. ``sources_m`` are the field's
    sources: with a field per source, each row block is measured from its own."""
    t = np.asarray(errors.value["t30"], float)
    if not np.isfinite(t).any():
        t = np.asarray(errors.value["edt"], float)
    with np.errstate(invalid="ignore"):
        t_band = np.array([np.nanmedian(col) if np.isfinite(col).any() else np.nan
                           for col in t.T])
    d_min = minimum_distance_m(volume_m3, speed_of_sound_m_s, t_band)  # [band]
    # [receiver, source]; a field per source (docs/fieldfile.md) has its rows source by source,
    # each at its own source's distance; a field of all sources together, the nearest one.
    gap = np.linalg.norm(np.asarray(receivers_m, float)[:, None, :]
                         - np.asarray(sources_m, float)[None, :, :], axis=2)
    rows = t.shape[0]
    gaps = gap.T.reshape(-1) if rows == gap.size and rows != gap.shape[0] else gap.min(axis=1)
    close = gaps[:, None] < np.where(np.isfinite(d_min), d_min, 0.0)[None, :]
    return replace(errors, excluded={name: close for name in DECAY_TIMES})
