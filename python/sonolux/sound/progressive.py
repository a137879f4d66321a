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
- **Receivers no energy reaches** (:mod:`sonolux.sound.reach`): one with not one deposit where
  the rays would have hit it μ = hits × 4π r² / S times in the room's diffuse field, with
  e^(−μ) below the bake's 5 % shared by its receivers, is sealed off: it is left out ("no
  energy reached it"), listed and warned of by name, not waited for until the cap.
- **Which estimator** (``estimator = "auto"``, :func:`choose`): measured by a pilot of each,
  not assumed, and ranked by counted work (segments, visibility tests, deposits, draws: the
  same on any machine), not by wall time; the chosen pilot is the bake's first round.
- **The direct sound** of the rain and nee estimators is exact (no noise); the rays deposit it a
  share per block of 256 (``direct::direct_share`` in the core), so each group holds its share
  and every leave-out estimate the same direct sound (:mod:`sonolux.sound.accuracy`).
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
from dataclasses import field as default_of
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.analysis.params import slowest_decay_s
from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_RAYS
from sonolux.range_bake import bake_ranges
from sonolux.ranges import Checkpointing
from sonolux.scene.schema import Scene
from sonolux.sound.accuracy import (  # noqa: F401  (the error estimate, used through here too)
    DECAY_TIMES,
    GROUPS,
    JND,
    PARAMETERS,
    T_95,
    Errors,
    jackknife,
    minimum_distance_m,
    near_source,
    parameters,
)
from sonolux.sound.bake import add_waves, check_waves, ray_count
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions
from sonolux.sound.ranges import SoundRanges, SoundSum, field_of_sum
from sonolux.sound.reach import SEALED_OR_COUPLED, reach
from sonolux.sound.rounds import RoundSum, RoundWork, omni_bins
from sonolux.sound.tail import describe as describe_tail
from sonolux.sound.tail import first_round_settings, round_k, round_settings, watch_of
from sonolux.sound.waves import with_scene

#: A round's rays are whole blocks of GROUPS × BLOCK_RAYS. Equal to the core's DIRECT_BLOCK_RAYS
#: (sound/trace.rs): each group then holds whole blocks, and its exact share of the direct sound.
BLOCK_RAYS = 256
#: The first round: at least this many rays per group.
FIRST_GROUP_RAYS = 2048
#: The cap when none is given: the largest automatic ray count before progressive bakes.
DEFAULT_MAX_RAYS = 50_000_000
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


def next_total(done: int, worst_over_target: float, ceiling: int) -> int:
    """The rays the next round should reach (module doc): from 1/√n scaling of the worst error."""
    wanted = done * worst_over_target**2 * 1.1 if math.isfinite(worst_over_target) else 4 * done
    return min(ceiling, _blocks(min(max(wanted, 1.25 * done), 4.0 * done)))


@dataclass
class Pilot:
    """A first round already traced (by :func:`choose`): its sum, its rays and the
    wall time it took. The bake goes on from it as if it had traced it itself."""

    state: RoundSum
    rays: int
    seconds: float


def first_round_rays(scene: Scene, options: SoundOptions, ceiling: int,
                     first_rays: int | None = None) -> int:
    """The first round: ``first_rays``, else an eighth of the scene's automatic rule, at least
    GROUPS × FIRST_GROUP_RAYS, in whole blocks, at most ``ceiling``."""
    rule = ray_count(scene, replace(options, rays="auto"))
    return min(ceiling, _blocks(first_rays or max(rule / 8, GROUPS * FIRST_GROUP_RAYS)))


def round_errors(scene: Scene, state: RoundSum, target: tuple[int, int] | None = None) -> Errors:
    """The jackknife errors of a progressive bake's rays so far (near-source rule applied,
    receivers no energy reached found: :mod:`sonolux.sound.reach`; with the round ``target``,
    the heavy-tail diagnostic of its late contributions: :mod:`sonolux.sound.tail`)."""
    assert state.total is not None and state.groups is not None
    t = state.total.template
    errors = near_source(jackknife(state.groups.sum(axis=0, dtype=np.uint64), state.groups,
                                   *omni_bins(t, state.total.counts), slowest_decay_s(t)),
                         scene.receivers.positions_m, np.asarray(t.source_positions_m),
                         scene.volume_m3, scene.settings.speed_of_sound_m_s)
    k = round_k(state.tail, target) if target is not None else None
    return replace(errors, reach=reach(state.groups, int(state.total.stats.get("surface_hits", 0)),
                                       scene.receivers.count, scene.receivers.radius_m,
                                       scene.area_m2),
                   tail_k=k, tail_rays=0 if target is None else target[1] - target[0])


def watched(scene: Scene, state: RoundSum, start: int, end: int
            ) -> tuple[np.ndarray, int] | None:
    """What the round ``start..end`` watches of its rays' late contributions (from the rays
    before it: :func:`sonolux.sound.tail.round_settings`; the first round, from the room's
    Eyring decay: :func:`sonolux.sound.tail.first_round_settings`)."""
    if state.total is None or state.groups is None:
        return first_round_settings(scene, end - start)
    omni = state.groups.sum(axis=0, dtype=np.uint64).astype(np.float64)
    return round_settings(omni, omni_bins(state.total.template, state.total.counts), start, end,
                          scene.settings.threads)


def bake(scene: Scene, options: SoundOptions | None = None, accuracy: Accuracy | None = None, *,
         client: Any = None, checkpoint: str | Path | None = None, resume: bool = False,
         restart: bool = False, checkpoint_every_s: float = 60.0, range_rays: int | None = None,
         tasks: int | None = None, progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, first_rays: int | None = None
         ) -> tuple[SoundField, Errors]:
    """Bakes ``scene`` in rounds until ``accuracy`` is reached (module doc); returns the field
    and its :class:`Errors`. ``options.rays`` is ignored (the rounds decide); ``first_rays``
    sets the first round (:func:`first_round_rays`). Every round runs through
    :func:`sonolux.range_bake.bake_ranges`: ``client`` (Dask), ``checkpoint`` (a side file, kept
    between rounds; ``resume`` continues from it, in whichever round it stopped),
    ``range_rays``, ``tasks`` as there. The field's settings carry ``progressive``: the rounds,
    why the bake stopped, the error summary. With ``estimator = "auto"`` the pilots of
    :func:`choose` run first, and the chosen estimator's pilot is the first round."""
    accuracy = (accuracy or Accuracy()).validate()
    # The scene's [waves] table resolved here, so that the check and the waves added agree.
    options = with_scene(scene, (options or SoundOptions()).validate())
    check_waves(scene, options, log=log)  # the hybrid's clearance and memory, before the pilots
    if options.ray_range is not None:
        raise SonoluxError("a progressive bake (rays = auto) cannot trace a ray range: give the "
                           "bake's ray count (--rays N) to split it")
    side = Path(checkpoint) if checkpoint is not None else None
    resuming = side is not None and resume and not restart and side.exists()
    ceiling = accuracy.ceiling
    stopped = _where_it_stopped(side) if resuming and side is not None else None
    choice, pilot = None, None
    if options.estimator == "auto":
        choice = stopped.choice if stopped is not None else None
        if choice is not None:  # the checkpoint's choice: no pilot is traced again
            options = replace(options, estimator=choice["chosen"])
            if log:
                log(f"estimator: {choice['chosen']} (automatic, chosen by the pilots of the "
                    "bake this checkpoint belongs to; they are not traced again)")
        else:
            options, choice, pilot = choose(scene, options, accuracy, first_rays=first_rays,
                                            log=log)
            if stopped is not None:  # an older checkpoint: it holds later rounds of this choice
                pilot = None
    inner = SoundRanges(scene, replace(options, rays=ceiling))
    start, target = 0, (pilot.rays if pilot is not None
                        else first_round_rays(scene, options, ceiling, first_rays))
    state = pilot.state if pilot is not None else RoundSum()
    state.choice = choice
    if stopped is not None and stopped.target is not None:
        (start, target), state.rounds = stopped.target, stopped.rounds
    if log:
        log(f"progressive bake: rounds until the standard error of T30, EDT and C80 is below "
            f"{accuracy.fraction_of_jnd:g} JND at every receiver and band (at most "
            f"{ceiling:,} rays" + (f" or {accuracy.max_seconds:g} s" if accuracy.max_seconds
                                   else "") + f"); round {len(state.rounds) + 1}: rays "
            f"{start:,}..{target:,}" + (" (the chosen estimator's pilot)" if pilot else ""))
    started = time.perf_counter()
    # Time already spent: a resumed bake's rounds; the automatic choice's pilots, all of them.
    spent = (state.rounds[-1]["seconds"] if state.rounds else
             choice["pilot_seconds"] if choice is not None else 0.0)
    first_round = True
    while True:
        pilot_round = first_round and pilot is not None
        if not pilot_round:  # (else the pilot is this round, traced)
            watch = (stopped.watch if first_round and stopped is not None
                     else watched(scene, state, start, target))
            work = RoundWork(inner, start, target, GROUPS, state, watch)
            state, _ = bake_ranges(work, client=client, checkpoint=side,
                                   resume=resume or not first_round,
                                   restart=restart and first_round,
                                   checkpoint_every_s=checkpoint_every_s,
                                   range_rays=range_rays, tasks=tasks, progress=progress,
                                   log=log if first_round else None)
        first_round = False
        assert state.total is not None
        errors = round_errors(scene, state, (start, target))
        worst = errors.worst_over_target(accuracy.fraction_of_jnd)
        elapsed = spent + time.perf_counter() - started
        # Rays a second of this round (the time since the last round, or the chosen pilot's own)
        before = state.rounds[-1] if state.rounds else {"rays": start, "seconds": spent}
        seconds = pilot.seconds if pilot_round and pilot else elapsed - before["seconds"]
        round_rate = (target - before["rays"]) / seconds if seconds > 0 else math.inf
        state.rounds.append({"rays": target, "seconds": round(elapsed, 3),
                             "worst_over_target": worst if math.isfinite(worst) else None})
        stop = ("cancelled" if state.total.stats.get("cancelled") else
                "converged" if worst <= 1.0 else "max_rays" if target >= ceiling else
                "max_seconds" if accuracy.max_seconds is not None
                and elapsed >= accuracy.max_seconds else "")
        if log:
            log(f"round {len(state.rounds)}: {target:,} rays, {elapsed:.1f} s; "
                + _describe(errors, accuracy.fraction_of_jnd)
                + ("" if stop else "; " + outlook(errors, accuracy, target, ceiling, round_rate)))
        if stop:
            break
        start, target = target, next_total(target, worst, ceiling)
        if accuracy.max_seconds is not None:  # no round that cannot end in time
            rate = start / elapsed if elapsed > 0 else math.inf
            target = min(target, max(start + GROUPS * BLOCK_RAYS,
                                     _blocks(rate * accuracy.max_seconds, down=True)))
        if side is not None:  # the next round starts from here if the bake is killed now
            Checkpointing(side).save(RoundWork(inner, start, target, GROUPS, state,
                                               watched(scene, state, start, target)), state, [])
    unreached = unreached_record(errors, scene)
    if log:
        log(f"progressive bake: {STOPPED[stop]} after {target:,} rays in {len(state.rounds)} "
            f"rounds, {elapsed:.1f} s; standard errors reached: "
            + _describe(errors, accuracy.fraction_of_jnd))
        for u in unreached:
            log(unreached_warning(u, target))
    assert state.total is not None
    field = _field(state.total, GROUPS, target, ceiling, accuracy, errors, state.rounds, stop)
    field = replace(field, settings=dict(field.settings, progressive=dict(
        field.settings["progressive"], unreached=unreached)))
    if choice is not None:
        field = replace(field, settings=dict(field.settings, estimator_choice=choice))
    if options.waves:  # the hybrid's wave bands, once, to the whole field (as ranges do)
        field = add_waves(scene, options, field, progress=bool(progress), log=log)
    return field, errors


def unreached_record(errors: Errors, scene: Scene) -> list[dict[str, Any]]:
    """The receivers no energy reached (``settings["progressive"]["unreached"]``): the field's
    row, the receiver, its position (m), the source (index and name; None when the field sums
    the sources), the hits expected were it in the diffuse field, the bound on its level (dB)."""
    if errors.reach is None:
        return []
    positions = np.asarray(scene.receivers.positions_m, float)
    n, per_source = len(positions), len(errors.reach.unreached) > len(positions)
    return [{"row": r, "receiver": r % n, "label": errors.reach.label(r),
             "source": r // n if per_source else None,
             "source_name": scene.sources[r // n].name if per_source else None,
             "position_m": positions[r % n].tolist(),
             "expected_hits": float(errors.reach.expected_hits[r]),
             "level_below_db": float(errors.reach.level_below_db[r])}
            for r in errors.reach.rows()]


def unreached_warning(u: dict[str, Any], rays: int) -> str:
    """The warning that names an unreached receiver (the bake's end, ``sonolux info``)."""
    where = ", ".join(f"{v:g}" for v in u["position_m"])
    source = f" from source {u['source']} ({u['source_name']})" if u["source"] is not None else ""
    return (f"warning: no energy{source} reached receiver #{u['receiver']} at ({where}) m in "
            f"{rays:,} rays, where a receiver in the room's diffuse field would have been hit about "
            f"{u['expected_hits']:,.0f} times (its level is at least "
            f"{-u['level_below_db']:.1f} dB below the room's, 95 %): "
            + SEALED_OR_COUPLED.format(sources="source" if source else "sources")
            + f"; it was not waited for and its {'field of that source' if source else 'field'} "
            "is silent")


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


@dataclass
class Stopped:
    """Where a progressive bake's checkpoint stopped: the round's ray range (None if it is not
    a progressive checkpoint: the bake's checks will say), the rounds before it and the
    automatic estimator's record (None if the bake did not choose one)."""

    target: tuple[int, int] | None = None
    rounds: list[dict[str, Any]] = default_of(default_factory=list)
    choice: dict[str, Any] | None = None
    watch: tuple[np.ndarray, int] | None = None


def _where_it_stopped(side: Path) -> Stopped:
    """:class:`Stopped` from a checkpoint's header (the bake's checks then read it whole)."""
    from sonolux import checkpoint as checkpoints

    try:
        meta = checkpoints.read_header(side)["meta"]["progressive"]
        choice = meta.get("choice")
        return Stopped((int(meta["target"][0]), int(meta["target"][1])), list(meta["rounds"]),
                       dict(choice) if isinstance(choice, dict) and "chosen" in choice
                       else None, watch_of(meta.get("watch")))
    except (checkpoints.CheckpointError, KeyError, TypeError, ValueError, OSError):
        return Stopped()


#: How a progressive bake ended, in words (``settings["progressive"]["stopped"]``).
STOPPED = {"converged": "converged", "max_rays": "stopped at the ray cap (max_rays), NOT converged",
           "max_seconds": "stopped at the time cap (max_seconds), NOT converged",
           "cancelled": "cancelled, NOT converged"}


def outlook(errors: Errors, accuracy: Accuracy, done: int, ceiling: int, rate: float) -> str:
    """What the round's errors say of the rest (for the log): the rays the worst defined entry
    needs (SE falls as 1/√n: n · (SE / target)²) and the time that takes at ``rate`` (rays a
    second of the last round); a lower bound while entries are undefined by noise; whether a cap
    comes first."""
    fraction = accuracy.fraction_of_jnd
    worst = max((float(np.nanmax(r)) for r in (
        errors.counted(p, waiting=np.nan) / (fraction * JND[p][0]) for p in PARAMETERS)
        if np.isfinite(r).any()), default=math.nan)
    # Entries at a limit count their fitted value's SE (projected above); only those undefined
    # by noise make the projection a lower bound.
    waiting = sum(int((errors.waiting(p) & ~errors.at_limit(p)).sum()) for p in PARAMETERS)
    if not math.isfinite(worst):
        return "nothing defined yet to project from"
    needed = done * max(worst, 1.0) ** 2
    more_s = (needed - done) / rate if rate > 0 else math.inf
    text = (f"about {needed:,.0f} rays to converge{' at least' if waiting else ''} "
            f"(≈ {more_s:,.0f} s more at {rate:,.0f} rays/s)")
    if needed > ceiling:
        cap_s = (ceiling - done) / rate if rate > 0 else math.inf
        text += (f": more than the cap of {ceiling:,} rays, where the bake will stop NOT "
                 f"converged (≈ {cap_s:,.0f} s more)")
    if accuracy.max_seconds is not None and more_s > accuracy.max_seconds:
        text += f"; --max-seconds {accuracy.max_seconds:g} comes first"
    return text


def _describe(errors: Errors, fraction: float) -> str:
    """The round's line: per parameter the worst SE against its target, the entries still
    undefined by noise (waited for) and those left out for good, with why."""
    parts, left = [], []
    for name, s in errors.summary().items():
        label = name.upper()
        if "max" in s:
            unit = "%" if s["unit"] == "relative" else " dB"
            scale = 100.0 if s["unit"] == "relative" else 1.0
            target = fraction * JND[name][0] * scale
            parts.append(f"{label} SE ≤ {s['max'] * scale:.3g}{unit} (target {target:.3g}{unit})")
        if s["undefined"]:
            parts.append(f"{label} undefined at {s['undefined']} receiver-bands (waited for: "
                         "more rays define it)" if "max" in s
                         else f"{label} undefined everywhere (waited for)")
        elif "max" not in s:
            parts.append(f"{label} not counted anywhere")
        left += [f"{label} at {len(at)} ({kind})" for kind, at in s["left_out"].items()]
        if s["at_limit"]:
            parts.append(f"{label} at an ISO 3382-2 limit at "
                         + ", ".join(f"{len(at)} ({kind})" for kind, at in s["at_limit"].items())
                         + " (counted by the fitted value's SE)")
    if left:
        parts.append("left out, more rays cannot define them: " + ", ".join(left))
    if errors.reach is not None and errors.reach.unreached.any():
        rows = errors.reach.rows()
        parts.append(f"no energy reached receiver{'s' if len(rows) > 1 else ''} "
                     + ", ".join(errors.reach.label(r) for r in rows)
                     + f" (0 hits, ≥ {errors.reach.expected_hits[rows].min():,.0f} expected in "
                     "the diffuse field): not waited for")
    uncertain = errors.onset_uncertain()
    if uncertain.size:
        assert errors.onset_s is not None and errors.supported_onset_s is not None
        parts.append(f"onset uncertain at receiver{'s' if uncertain.size > 1 else ''} "
                     + ", ".join(f"#{r} ({errors.onset_s[r] * 1e3:.1f} ms; "
                                 f"{errors.supported_onset_s[r] * 1e3:.1f} ms in every group)"
                                 for r in uncertain) + ": counted in their errors")
    tail = describe_tail(errors.summary()["t30"].get("tail"))
    if tail:
        parts.append(tail)
    near = max(s.get("near_source", 0) for s in errors.summary().values())
    if near:
        parts.append(f"decay times of {near} receiver-bands nearer a source than ISO 3382's "
                     "d_min reported, not waited for")
    return ", ".join(parts)


#: The estimators the automatic choice tries, cheapest per ray first (ties go to the first).
CANDIDATES = ("paper", "nee", "rain")
#: The quantile of the entries' projected work that ranks the candidates (see choose).
PILOT_QUANTILE = 0.9
#: What the choice counts as work (the core's statistics, the same bits on any machine): nearest
#: hits (segments), visibility tests (shadow rays), deposits into receivers, receivers drawn from
#: nee's tree. Each counts one unit; docs/progressive.md has the measured costs per kind.
WORK = ("segments", "shadow_rays", "deposits", "draws")


def counted_work(stats: dict[str, Any]) -> int:
    """The work units of a bake's statistics (:data:`WORK`, one unit each)."""
    return sum(int(stats.get(k, 0)) for k in WORK)


def projection(errors: Errors, fraction_of_jnd: float) -> float:
    """The ``PILOT_QUANTILE`` of (SE / target)² over the entries the stopping rule counts: the
    factor by which the rays (and the work) must grow for that share of entries to reach the
    target (SE falls as 1/√n); an undefined leave-out counts as infinite. An entry the pilot
    leaves undefined has no SE to project from and is left out here (the stopping rule waits
    for it: at a pilot's few rays many are, e.g. 115 of 385 T30 for rain on paper-medium)."""
    squares = np.concatenate([
        ((errors.counted(p, waiting=np.nan) / (fraction_of_jnd * JND[p][0])) ** 2).ravel()
        for p in PARAMETERS])
    squares = squares[~np.isnan(squares)]
    return float(np.quantile(squares, PILOT_QUANTILE, method="higher")) if squares.size else 0.0


def pilot_rays(first: int, paper: dict[str, Any], estimator: str, receivers: int,
               nee_receivers: int) -> int:
    """Rays of a pilot after the paper estimator's pilot of ``first`` rays: as many as cost the
    paper pilot's work, by a prediction from its counts (the paths of every estimator are the
    same rays: rain or nee add a connection to each of N, or M, receivers at each reflection,
    which the paper estimator counts as surface hits), at least one block a group, at most
    ``first``. A prediction only sizes the pilot; the choice uses the counted work."""
    n = float(paper["rays"])
    per_ray = {"segments": paper["segments"] / n, "hits": paper["surface_hits"] / n}
    fan = receivers if estimator == "rain" else min(receivers, nee_receivers)
    draws = nee_receivers if estimator == "nee" and receivers > nee_receivers else 0
    predicted = per_ray["segments"] + per_ray["hits"] * (fan + draws)
    budget = counted_work(paper)
    return max(GROUPS * BLOCK_RAYS, min(first, _blocks(budget / max(predicted, 1.0),
                                                        down=True)))


def choose(scene: Scene, options: SoundOptions, accuracy: Accuracy, *,
           first_rays: int | None = None, log: Callable[[str], None] | None = None
           ) -> tuple[SoundOptions, dict[str, Any], Pilot | None]:
    """Which estimator reaches ``accuracy`` with the least work for this scene, from a pilot of
    each: the first round of its own progressive bake (same seed, same nominal rays, so the
    chosen pilot's rays are rays 0..n of the bake that follows and are not traced again). The
    paper estimator's pilot is the usual first round; the others' are sized to cost about its
    work (:func:`pilot_rays`). Each pilot's projected work to the target is its counted work
    (:func:`counted_work`, exact integers from the core) × :func:`projection`; the smallest
    wins (ties: the first of CANDIDATES). The choice depends on the scene, the seed and the
    options only: the same on any machine, under any load. The wall times are measured and
    recorded beside it (``seconds``, ``projected_seconds``) but not used.
    Returns the options with the chosen estimator, the record (the field's
    ``estimator_choice``) and the chosen pilot (None if nothing was measurable)."""
    options, ceiling = options.validate(), accuracy.ceiling
    first = first_round_rays(scene, replace(options, estimator="paper"), ceiling, first_rays)
    measured: dict[str, Any] = {}
    pilots: dict[str, Pilot] = {}
    for name in CANDIDATES:
        if name == "nee" and scene.receivers.count <= options.nee_receivers:
            # Every receiver connected once: exactly the rain estimator, measured below.
            measured[name] = {"same_as": "rain", "projected_work": math.inf}
            continue
        trial = replace(options, estimator=name, ray_range=None)
        rays = first if name == "paper" else pilot_rays(
            first, measured["paper"]["stats"], name, scene.receivers.count,
            options.nee_receivers)
        started = time.perf_counter()
        state, _ = bake_ranges(RoundWork(SoundRanges(scene, replace(trial, rays=ceiling)), 0,
                                         rays, GROUPS, RoundSum(),
                                         first_round_settings(scene, rays)))
        seconds = time.perf_counter() - started
        assert state.total is not None
        stats = state.total.stats
        q = projection(round_errors(scene, state, (0, rays)), accuracy.fraction_of_jnd)
        work = counted_work(stats)
        measured[name] = {
            "rays": rays, "seconds": seconds, "work": work, "projection": q,
            "projected_work": work * q, "projected_seconds": seconds * q,
            "stats": {k: int(stats.get(k, 0)) for k in ("rays", "surface_hits", *WORK)}}
        pilots[name] = Pilot(state, rays, seconds)
        if log:
            log(f"estimator pilot: {name}, {rays:,} rays, {work:,} work units, {seconds:.2f} s; "
                f"projected {work * q:.3g} units ({seconds * q:.3g} s here) to "
                f"{accuracy.fraction_of_jnd:g} JND at the {PILOT_QUANTILE:.0%} entry")
    chosen = min(CANDIDATES, key=lambda c: (measured[c]["projected_work"], CANDIDATES.index(c)))
    if not math.isfinite(measured[chosen]["projected_work"]):
        chosen = "paper"  # nothing measurable: the default
    if log:
        log(f"estimator: {chosen} (automatic, by the pilots' counted work; its pilot is round 1)")
    record = {"chosen": chosen, "quantile": PILOT_QUANTILE, "work": list(WORK),
              "pilot_seconds": sum(m.get("seconds", 0.0) for m in measured.values()),
              "pilots": measured}
    return replace(options, estimator=chosen), record, pilots.get(chosen)


def choose_estimator(scene: Scene, options: SoundOptions, fraction_of_jnd: float = 0.25, *,
                     log: Callable[[str], None] | None = None
                     ) -> tuple[SoundOptions, dict[str, Any]]:
    """:func:`choose` for a bake of a fixed ray count (its pilots are not reused: that bake's
    rays carry another share of the power). Returns the options and the record."""
    chosen, record, _ = choose(scene, options, Accuracy(fraction_of_jnd), log=log)
    return chosen, record
