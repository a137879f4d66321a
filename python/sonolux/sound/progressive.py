"""The progressive sound bake: rays in rounds until T30, EDT and C80 are known well enough.

``rays = "auto"`` bakes this way. A bake of a fixed ray count cannot say whether it converged;
this one measures its own error after every round and stops once the standard error of T30,
EDT and C80 at every receiver and band is below ``accuracy`` × the parameter's just-noticeable
difference (JND), or when a cap (rays, seconds) is reached. It reports the error it reached.

How (docs/progressive.md has the derivation and the checks):

- **One bake, traced in ranges.** Every round traces the next ray range of one bake of
  ``max_rays`` rays (:class:`sonolux.sound.ranges.SoundRanges`): each ray carries
  power / ``max_rays`` and its random numbers come from the seed and its index alone. After n
  rays the field is counts × quantum × max_rays / n. The rounds' sizes follow from the exact
  integer counts, so the same seed gives the same rounds, the same rays and the same bits on any
  number of threads.
- **Groups.** Each round's range is cut into ``GROUPS`` equal parts; part g of every round
  belongs to group g. Rays are independent and identically distributed, so the groups are
  ``GROUPS`` independent bakes of n / ``GROUPS`` rays each. Only their direction-summed counts
  are kept (uint64[receiver, band, time]): that is all T30, EDT and C80 need.
- **Error: the delete-a-group jackknife** (Shao and Tu, *The Jackknife and Bootstrap*,
  Springer 1995, §5.1.3 and §1.3; Efron and Tibshirani, *An Introduction to the Bootstrap*,
  1993, §11.2 and §11.5): with θ₍g₎ the parameter of all rays but group g and θ̄ their mean,
  SE = √((G − 1)/G · Σ_g (θ₍g₎ − θ̄)²). The parameters are ratios of energies, so the leave-out
  sums need no rescaling. The reported 95 % interval is θ ± t(0.975, G − 1) · SE.
- **JNDs** (ISO 3382-1:2009, Table A.1): EDT 5 % (relative), C80 1 dB. T30 has no entry there;
  the 5 % of reverberation time it gives for EDT is used for T30 too (the difference limen of
  reverberation time, e.g. Vorländer, *Auralization*, 2008, §13.2).
- **Near the source** (:func:`near_source`): T30 and EDT nearer a source than ISO 3382's
  d_min = 2 √(V / (c T)) are reported but not waited for: there the decay curve falls through the
  start of their ranges within the direct sound, the parameter jumps between leave-out estimates
  and the jackknife (valid for smooth statistics) reports the jump, not an error.
- **Which estimator** (``estimator = "auto"``, :func:`choose_estimator`): measured by a short
  pilot of each, not assumed.
- **The next round.** A standard error falls as 1/√n, so the rays that the worst
  receiver and band need are n · (SE / target)²; the next round goes to 1.1 × that, at least
  1.25 n and at most 4 n (a round is never tiny and never overshoots by more than the
  estimate's own noise warrants), rounded up to whole blocks of ``GROUPS`` × ``BLOCK_RAYS``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.analysis.decay import c80, decay_times
from sonolux.analysis.params import onsets_s, slowest_decay_s
from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_RAYS
from sonolux.range_bake import bake_ranges
from sonolux.ranges import Checkpointing
from sonolux.scene.schema import Scene
from sonolux.sound.bake import add_waves, ray_count
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions
from sonolux.sound.ranges import SoundRanges, SoundSum, field_of_sum
from sonolux.sound.rounds import RoundSum, RoundWork, omni_bins

#: Independent ray groups of the jackknife. More groups estimate the error better (the interval
#: uses Student's t with GROUPS − 1 degrees of freedom) but each is one more call of the tracer
#: per round and one more [receiver, band, time] array.
GROUPS = 8
#: Student's t, 97.5 % quantile, 7 degrees of freedom: the 95 % interval of the reported error.
T_95 = 2.365
#: A round's rays are whole blocks of GROUPS × BLOCK_RAYS.
BLOCK_RAYS = 256
#: The first round: at least this many rays per group.
FIRST_GROUP_RAYS = 2048
#: The cap when none is given: the largest automatic ray count before progressive bakes.
DEFAULT_MAX_RAYS = 50_000_000
#: Just-noticeable differences (ISO 3382-1:2009 Table A.1; T30 as EDT, see the module's doc):
#: (value, "relative" or "absolute").
JND = {"t30": (0.05, "relative"), "edt": (0.05, "relative"), "c80": (1.0, "absolute")}
PARAMETERS = tuple(JND)


@dataclass(frozen=True)
class Accuracy:
    """When a progressive bake stops.

    fraction_of_jnd: the standard error wanted, as a fraction of each parameter's JND
        (0.25: a quarter of a JND, the default).
    max_rays: rays per source at most (the bake's nominal size; None = 50 million).
    max_seconds: wall time at most (None = no limit); checked between rounds.
    """

    fraction_of_jnd: float = 0.25
    max_rays: int | None = None
    max_seconds: float | None = None

    def validate(self) -> Accuracy:
        check_number("accuracy (fraction of a JND)", self.fraction_of_jnd, 0.0, 10.0,
                     lo_open=True)
        check_number("max_rays", self.max_rays, GROUPS * BLOCK_RAYS, MAX_RAYS, integer=True,
                     none_ok=True)
        check_number("max_seconds", self.max_seconds, 0.0, 1e7, lo_open=True, none_ok=True,
                     unit="s")
        return self

    @property
    def ceiling(self) -> int:
        return _blocks(self.max_rays or DEFAULT_MAX_RAYS, down=True)


def _blocks(rays: float, *, down: bool = False) -> int:
    block = GROUPS * BLOCK_RAYS
    n = math.floor(rays / block) if down else math.ceil(rays / block)
    return max(1, n) * block


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

    def counted(self, name: str) -> np.ndarray:
        """SE in the JND's unit where the stopping rule counts it, NaN elsewhere."""
        rel = self.relative(name)
        if self.excluded is not None and name in self.excluded:
            rel = np.where(self.excluded[name], np.nan, rel)
        return rel

    def relative(self, name: str) -> np.ndarray:
        """The standard error in the unit of the JND (relative or dB)."""
        se = self.standard_error[name]
        return se / np.abs(self.value[name]) if JND[name][1] == "relative" else se

    def worst_over_target(self, fraction: float) -> float:
        """max over parameters, receivers and bands of SE / (fraction × JND); NaN entries are
        left out (0 when nothing is defined)."""
        worst = 0.0
        for name in PARAMETERS:
            ratio = self.counted(name) / (fraction * JND[name][0])
            ratio = ratio[~np.isnan(ratio)]
            if ratio.size:
                worst = max(worst, float(ratio.max()))
        return worst

    def summary(self) -> dict[str, Any]:
        """Per parameter: the largest and median standard error (in the JND's unit), where,
        and how many entries are undefined."""
        out: dict[str, Any] = {}
        for name in PARAMETERS:
            rel = self.counted(name)
            ok = ~np.isnan(rel)
            near = (0 if self.excluded is None or name not in self.excluded
                    else int((self.excluded[name] & ~np.isnan(self.relative(name))).sum()))
            entry: dict[str, Any] = {"undefined": int((~ok).sum()) - near,
                                     "near_source": near,
                                     "unit": "relative" if JND[name][1] == "relative" else "dB"}
            if ok.any():
                worst = np.unravel_index(np.argmax(np.where(ok, rel, -1.0)), rel.shape)
                entry.update(max=float(rel[worst]), median=float(np.median(rel[ok])),
                             at_receiver=int(worst[0]), at_band=int(worst[1]))
            out[name] = entry
        return out


def parameters(omni: np.ndarray, bin_start_s: np.ndarray, bin_width_s: np.ndarray,
               onset_s: np.ndarray, max_decay_s: np.ndarray | None) -> dict[str, np.ndarray]:
    """T30, EDT (s) and C80 (dB) of direction-summed energies float64[receiver, band, time]:
    float64[receiver, band] each, NaN where undefined (:mod:`sonolux.analysis.decay`'s checks)."""
    onset = np.broadcast_to(onset_s[:, None], omni.shape[:2])
    bound = None if max_decay_s is None else np.broadcast_to(max_decay_s[None, :omni.shape[1]],
                                                             omni.shape[:2])
    with np.errstate(invalid="ignore", divide="ignore"):
        times = decay_times(omni, bin_start_s, bin_width_s, onset_s=onset,
                            max_decay_time_s=bound)
        clarity = c80(omni, bin_start_s, bin_width_s, onset_s=onset)
    return {"t30": np.asarray(times["t30_s"], float), "edt": np.asarray(times["edt_s"], float),
            "c80": np.where(np.isfinite(clarity), clarity, np.nan)}


def jackknife(total: np.ndarray, groups: np.ndarray, bin_start_s: np.ndarray,
              bin_width_s: np.ndarray, max_decay_s: np.ndarray | None) -> Errors:
    """The delete-a-group jackknife of T30, EDT and C80 from exact counts:
    ``total`` uint64[receiver, band, time] and ``groups`` uint64[group, receiver, band, time]
    (total = their sum). The onset (direct sound) is taken from the total and kept for every
    leave-out estimate."""
    edges = np.append(bin_start_s, bin_start_s[-1] + bin_width_s[-1])
    whole = total.astype(np.float64)
    onset = onsets_s(whole.sum(axis=1), edges)
    value = parameters(whole, bin_start_s, bin_width_s, onset, max_decay_s)
    g = groups.shape[0]
    leave_out = {name: np.empty((g, *total.shape[:2])) for name in PARAMETERS}
    for k in range(g):
        part = parameters((total - groups[k]).astype(np.float64), bin_start_s, bin_width_s,
                          onset, max_decay_s)
        for name in PARAMETERS:
            leave_out[name][k] = part[name]
    se = {}
    for name in PARAMETERS:
        theta = leave_out[name]
        spread = np.sqrt((g - 1) / g * np.sum((theta - theta.mean(axis=0)) ** 2, axis=0))
        se[name] = np.where(np.isnan(value[name]), np.nan,
                            np.where(np.isnan(theta).any(axis=0), np.inf, spread))
    return Errors(value, se)


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


def next_total(done: int, worst_over_target: float, ceiling: int) -> int:
    """The rays the next round should reach (module doc): from 1/√n scaling of the worst error."""
    wanted = done * worst_over_target**2 * 1.1 if math.isfinite(worst_over_target) else 4 * done
    return min(ceiling, _blocks(min(max(wanted, 1.25 * done), 4.0 * done)))


def bake(scene: Scene, options: SoundOptions | None = None, accuracy: Accuracy | None = None, *,
         client: Any = None, checkpoint: str | Path | None = None, resume: bool = False,
         restart: bool = False, checkpoint_every_s: float = 60.0, range_rays: int | None = None,
         tasks: int | None = None, progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, first_rays: int | None = None
         ) -> tuple[SoundField, Errors]:
    """Bakes ``scene`` in rounds until ``accuracy`` is reached (module doc); returns the field
    and its :class:`Errors`. ``options.rays`` is ignored (the rounds decide); ``first_rays``
    sets the first round (default: an eighth of the scene's automatic rule, at least GROUPS ×
    FIRST_GROUP_RAYS). Every round runs through :func:`sonolux.range_bake.bake_ranges`:
    ``client`` (Dask), ``checkpoint`` (a side file, kept between rounds; ``resume`` continues
    from it, in whichever round it stopped), ``range_rays``, ``tasks`` as there. The field's
    settings carry ``progressive``: the rounds, why the bake stopped, the error summary."""
    accuracy = (accuracy or Accuracy()).validate()
    options = (options or SoundOptions()).validate()
    pilot = None
    if options.estimator == "auto":
        options, pilot = choose_estimator(scene, options, accuracy.fraction_of_jnd, log=log)
    if options.ray_range is not None:
        raise SonoluxError("a progressive bake (rays = auto) cannot trace a ray range: give the "
                           "bake's ray count (--rays N) to split it")
    ceiling = accuracy.ceiling
    inner = SoundRanges(scene, replace(options, rays=ceiling))
    rule = ray_count(scene, replace(options, rays="auto"))
    start, target = 0, min(ceiling, _blocks(first_rays or max(rule / 8,
                                                              GROUPS * FIRST_GROUP_RAYS)))
    state = RoundSum()
    side = Path(checkpoint) if checkpoint is not None else None
    if side is not None and resume and not restart:
        start, target, state.rounds = _where_it_stopped(side, start, target)
    if log:
        log(f"progressive bake: rounds until the standard error of T30, EDT and C80 is below "
            f"{accuracy.fraction_of_jnd:g} JND at every receiver and band (at most "
            f"{ceiling:,} rays" + (f" or {accuracy.max_seconds:g} s" if accuracy.max_seconds
                                   else "") + f"); round {len(state.rounds) + 1}: rays "
            f"{start:,}..{target:,}")
    started = time.perf_counter()
    spent = state.rounds[-1]["seconds"] if state.rounds else 0.0
    first_round = True
    while True:
        work = RoundWork(inner, start, target, GROUPS, state)
        state, _ = bake_ranges(work, client=client, checkpoint=side,
                               resume=resume or not first_round,
                               restart=restart and first_round,
                               checkpoint_every_s=checkpoint_every_s, range_rays=range_rays,
                               tasks=tasks, progress=progress, log=log if first_round else None)
        first_round = False
        assert state.total is not None and state.groups is not None
        t = state.total.template
        errors = near_source(jackknife(state.groups.sum(axis=0, dtype=np.uint64),
                                       state.groups, *omni_bins(t, state.total.counts),
                                       slowest_decay_s(t)),
                             scene.receivers.positions_m, np.asarray(t.source_positions_m),
                             scene.volume_m3,
                             scene.settings.speed_of_sound_m_s)
        worst = errors.worst_over_target(accuracy.fraction_of_jnd)
        elapsed = spent + time.perf_counter() - started
        state.rounds.append({"rays": target, "seconds": round(elapsed, 3),
                             "worst_over_target": worst if math.isfinite(worst) else None})
        if log:
            log(f"round {len(state.rounds)}: {target:,} rays, {elapsed:.1f} s; "
                + _describe(errors, accuracy.fraction_of_jnd))
        stop = ("cancelled" if state.total.stats.get("cancelled") else
                "converged" if worst <= 1.0 else "max_rays" if target >= ceiling else
                "max_seconds" if accuracy.max_seconds is not None
                and elapsed >= accuracy.max_seconds else "")
        if stop:
            break
        start, target = target, next_total(target, worst, ceiling)
        if accuracy.max_seconds is not None:  # no round that cannot end in time
            rate = start / elapsed if elapsed > 0 else math.inf
            target = min(target, max(start + GROUPS * BLOCK_RAYS,
                                     _blocks(rate * accuracy.max_seconds, down=True)))
        if side is not None:  # the next round starts from here if the bake is killed now
            Checkpointing(side).save(RoundWork(inner, start, target, GROUPS, state), state, [])
    if log:
        log(f"progressive bake: {stop} after {target:,} rays")
    field = _field(state.total, GROUPS, target, ceiling, accuracy, errors, state.rounds, stop)
    if pilot is not None:
        field = replace(field, settings=dict(field.settings, estimator_choice=pilot))
    if options.waves:  # the hybrid's wave bands, once, to the whole field (as ranges do)
        field = add_waves(scene, options, field, progress=bool(progress), log=log)
    return field, errors


def _field(total: SoundSum, n_groups: int, done: int, ceiling: int, accuracy: Accuracy,
           errors: Errors, rounds: list[dict[str, Any]], stop: str) -> SoundField:
    """The field of the ``done`` rays traced: energy scaled from the nominal ``ceiling``."""
    quantum = total.template.quantum * ceiling / done
    field = field_of_sum(replace(total, template=replace(total.template, quantum=quantum)),
                         [(0, done)], done, None)
    record = dict(field.settings, rays=done, ray_range=[0, done], progressive={
        "accuracy_jnd": accuracy.fraction_of_jnd, "groups": n_groups, "nominal_rays": ceiling,
        "max_rays": accuracy.max_rays, "max_seconds": accuracy.max_seconds, "stopped": stop,
        "rounds": rounds, "errors": errors.summary(), "jnd": {k: v[0] for k, v in JND.items()}})
    return replace(field, settings=record)  # (field_of_sum added a hybrid's arrivals)


def _where_it_stopped(side: Path, start: int, target: int) -> tuple[int, int, list[Any]]:
    """The round a progressive bake's checkpoint was in, and the rounds before it (from its
    header: the bake's checks then read it whole)."""
    from sonolux import checkpoint as checkpoints

    if not side.exists():
        return start, target, []
    try:
        meta = checkpoints.read_header(side)["meta"]["progressive"]
        return int(meta["target"][0]), int(meta["target"][1]), list(meta["rounds"])
    except (checkpoints.CheckpointError, KeyError, TypeError, ValueError):
        return start, target, []  # not a progressive checkpoint: the bake's checks will say


def _describe(errors: Errors, fraction: float) -> str:
    parts = []
    for name, s in errors.summary().items():
        if "max" not in s:
            parts.append(f"{name.upper()} undefined everywhere")
            continue
        unit = "%" if s["unit"] == "relative" else " dB"
        scale = 100.0 if s["unit"] == "relative" else 1.0
        target = fraction * JND[name][0] * scale
        parts.append(f"{name.upper()} SE ≤ {s['max'] * scale:.3g}{unit} (target {target:.3g}{unit})")
    near = max(s.get("near_source", 0) for s in errors.summary().values())
    if near:
        parts.append(f"decay times of {near} receiver-bands nearer a source than ISO 3382's "
                     "d_min reported, not waited for")
    return ", ".join(parts)


#: The estimators the automatic choice tries, cheapest per ray first.
CANDIDATES = ("paper", "nee", "rain")
#: Rays of each pilot: the smallest progressive round (GROUPS blocks), times this.
PILOT_BLOCKS = 4
#: A pilot is stopped when it takes this many times the fastest finished pilot: it could win only
#: with a standard error below 1/√4 = 0.5 of the fastest's at equal rays; measured on the L-room,
#: rain's is 0.87 of paper's (pilots 1.6 s and 0.85 s). At 10× the pilots took 80 s on
#: paper-medium, more than the bake they choose for.
PILOT_SLOWDOWN = 4.0
#: The quantile of the entries' projected times that ranks the candidates (see choose_estimator).
PILOT_QUANTILE = 0.9


def choose_estimator(scene: Scene, options: SoundOptions, fraction_of_jnd: float = 0.25, *,
                     log: Callable[[str], None] | None = None
                     ) -> tuple[SoundOptions, dict[str, Any]]:
    """Measures which estimator reaches ``fraction_of_jnd`` sooner for this scene: a pilot bake
    of each candidate (the same ``PILOT_BLOCKS`` × GROUPS × BLOCK_RAYS rays, the same seed) gives
    per receiver and band the jackknife SE of T30, EDT and C80 and the wall time; the time that
    candidate needs to bring an entry to the target is t · (SE / target)² (SE falls as 1/√n at
    a fixed cost per ray). Candidates are ranked by the ``PILOT_QUANTILE`` of that projected time
    over the entries (the largest single entry of a small pilot is mostly the noise of its own
    7-degree-of-freedom estimate); an entry whose leave-out estimate is undefined counts as
    infinite. A pilot taking ``PILOT_SLOWDOWN`` × the fastest is stopped and not chosen.
    Returns the options with the chosen estimator, and the measurements (kept in the field's
    settings as ``estimator_choice``)."""
    rays = PILOT_BLOCKS * GROUPS * BLOCK_RAYS
    measured: dict[str, Any] = {}
    fastest = math.inf
    for name in CANDIDATES:
        if name == "nee" and scene.receivers.count <= options.nee_receivers:
            # Every receiver connected once: exactly the rain estimator, measured below.
            measured[name] = {"same_as": "rain", "projected_seconds": math.inf}
            continue
        cap = PILOT_SLOWDOWN * fastest
        started = time.perf_counter()

        def stop_late(done: int, total: int, elapsed_s: float, cap: float = cap,
                      started: float = started) -> bool:
            return time.perf_counter() - started < cap

        trial = replace(options, estimator=name)
        field, errors = bake(scene, trial, Accuracy(fraction_of_jnd, max_rays=rays),
                             first_rays=rays, progress=stop_late)
        seconds = time.perf_counter() - started
        if field.settings["progressive"]["stopped"] == "cancelled":
            measured[name] = {"seconds": seconds, "projected_seconds": math.inf,
                              "stopped": f"slower than {PILOT_SLOWDOWN:g}× the fastest pilot"}
            continue
        fastest = min(fastest, seconds)
        squares = np.concatenate([
            ((errors.counted(p) / (fraction_of_jnd * JND[p][0])) ** 2).ravel()
            for p in PARAMETERS])
        squares = squares[~np.isnan(squares)]
        q = float(np.quantile(squares, PILOT_QUANTILE, method="higher")) if squares.size else 0.0
        measured[name] = {"seconds": seconds, "projected_seconds": seconds * q,
                          "worst_projected_seconds": seconds * float(squares.max(initial=0.0))}
        if log:
            log(f"estimator pilot: {name}, {rays:,} rays in {seconds:.2f} s; projected "
                f"{seconds * q:.3g} s to {fraction_of_jnd:g} JND at the "
                f"{PILOT_QUANTILE:.0%} entry")
    chosen = min(CANDIDATES, key=lambda c: measured[c]["projected_seconds"])
    if not math.isfinite(measured[chosen]["projected_seconds"]):
        chosen = "paper"  # nothing measurable: the default
    if log:
        log(f"estimator: {chosen} (automatic, from the pilots)")
    return replace(options, estimator=chosen), {"chosen": chosen, "pilot_rays": rays,
                                                "quantile": PILOT_QUANTILE, "pilots": measured}
