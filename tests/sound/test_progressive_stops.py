"""The progressive bake (rays = auto) where it stops and starts again: a resumed automatic bake
keeps its choice and traces no pilot again (same bits as an uninterrupted bake); a parameter
undefined by the rays' noise is waited for, one undefined for a reason more rays cannot change
(a curved decay, a record too short) is left out and said."""

from __future__ import annotations

import hashlib
from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.sound import accuracy, progressive
from sonolux.sound.ranges import SoundRanges
from tests.sound.test_progressive import room as progressive_room

pytestmark = pytest.mark.usefixtures("core")


def room(**settings):
    """test_progressive's 5 × 4 × 3 m shoebox with three receivers, named for this file."""
    return replace(progressive_room(**settings), name="progressive-stops")


def digest(field) -> str:
    return hashlib.sha256(np.ascontiguousarray(field.energy).tobytes()).hexdigest()


class Stop(Exception):
    """Stands for a kill."""


class Traced:
    """Records every ray range the tracer is asked for: (estimator, first, end)."""

    def __init__(self, monkeypatch):
        self.ranges: list[tuple[str, int, int]] = []
        trace = SoundRanges.trace

        def recording(inner, first, end, *args, **kwargs):
            self.ranges.append((inner.options.estimator, first, end))
            return trace(inner, first, end, *args, **kwargs)

        monkeypatch.setattr(SoundRanges, "trace", recording)


ACCURACY = progressive.Accuracy(0.15)
OPTIONS = sonolux.SoundOptions(estimator="auto", nee_receivers=2)


@pytest.fixture(scope="module")
def uninterrupted():
    """The automatic progressive bake of room() on two threads, never killed."""
    if not engine.core_available():
        pytest.skip("the compiled core is not built")
    field, _ = progressive.bake(room(threads=2), OPTIONS, ACCURACY)
    return field


@pytest.mark.parametrize("kill", ["after round 1",
                                  pytest.param("within round 2", marks=pytest.mark.slow)])
def test_a_resumed_automatic_bake_keeps_its_choice_and_traces_no_pilot_again(
        tmp_path, monkeypatch, kill, uninterrupted):
    """Killed after round k (its checkpoint written between rounds) or within a round, then
    resumed (on one thread; the first run had two): the same field, hash for hash, as the bake
    that was never killed, and on resume not one pilot ray is traced (no call of the choice, no
    ray of another estimator, no ray below the end of round 1, the chosen pilot)."""
    whole = uninterrupted
    choice = whole.settings["estimator_choice"]
    chosen, first = choice["chosen"], choice["pilots"][choice["chosen"]]["rays"]
    rounds = whole.settings["progressive"]["rounds"]
    assert len(rounds) >= 3, "the test needs a third round to resume into"
    side = tmp_path / "auto.h5.checkpoint"

    if kill == "after round 1":
        class KilledAfterSaving(progressive.Checkpointing):
            def save(self, work, total, done):
                super().save(work, total, done)
                raise Stop

        monkeypatch.setattr(progressive, "Checkpointing", KilledAfterSaving)
        progress = False
    else:
        def progress(done, total, elapsed):  # round 2 is the first one with another size
            if total != first and done > total // 3:
                raise Stop
            return True
    with pytest.raises(Stop):
        progressive.bake(room(threads=2), OPTIONS, ACCURACY, checkpoint=side,
                         checkpoint_every_s=0, range_rays=1024, progress=progress)
    monkeypatch.undo()
    assert side.exists()
    held = sonolux.checkpoint.read_header(side)
    assert held["meta"]["progressive"]["choice"]["chosen"] == chosen
    restored = sum(b - a for a, b in held["done"]) + held["target"][0]

    traced = Traced(monkeypatch)

    def no_pilots(*args, **kwargs):
        raise AssertionError("a resumed automatic bake ran its pilots again")

    monkeypatch.setattr(progressive, "choose", no_pilots)
    again, _ = progressive.bake(room(threads=1), OPTIONS, ACCURACY, checkpoint=side,
                                resume=True, checkpoint_every_s=0, range_rays=1024)
    assert digest(again) == digest(whole)
    assert again.settings["progressive"]["rounds"][-1]["rays"] == rounds[-1]["rays"]
    assert again.settings["estimator_choice"]["chosen"] == chosen
    assert again.settings["estimator_choice"]["pilots"][chosen]["projected_work"] == \
        choice["pilots"][chosen]["projected_work"]
    assert traced.ranges and all(est == chosen for est, _, _ in traced.ranges)
    assert min(a for _, a, _ in traced.ranges) >= first
    # Every ray the resumed bake traced is one the checkpoint did not hold, none twice.
    assert sum(b - a for _, a, b in traced.ranges) == rounds[-1]["rays"] - restored


@pytest.mark.slow
def test_a_checkpoint_without_a_choice_still_resumes_by_choosing_again(tmp_path, monkeypatch,
                                                                       uninterrupted):
    """A checkpoint of an older version (no choice in it): the pilots run again (the choice is
    deterministic) and the bake continues from the checkpoint to the same bits."""
    whole = uninterrupted
    side = tmp_path / "old.h5.checkpoint"

    class KilledAfterSaving(progressive.Checkpointing):
        def save(self, work, total, done):
            total.choice = None  # what an older version wrote
            super().save(work, total, done)
            raise Stop

    monkeypatch.setattr(progressive, "Checkpointing", KilledAfterSaving)
    with pytest.raises(Stop):
        progressive.bake(room(), OPTIONS, ACCURACY, checkpoint=side)
    monkeypatch.undo()
    again, _ = progressive.bake(room(), OPTIONS, ACCURACY, checkpoint=side, resume=True)
    assert digest(again) == digest(whole)


def synthetic_groups(rate: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Eight groups of Poisson counts with mean ``rate`` / 8: uint64[group, 1, 1, time]."""
    return rng.poisson(np.broadcast_to(rate / 8, (8, 1, 1, rate.size))).astype(np.uint64)


def decay(t30_s: float, *, late_t30_s: float | None = None, late_db: float = -20.0,
          peak: float = 2000.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rate, bin starts, bin widths): a 1.2 s record of 1 ms bins, the direct sound at 5 ms,
    one exponential of ``t30_s`` (and a second, slower one ``late_db`` below it)."""
    start = np.arange(1200) * 1e-3
    rate = np.exp(-13.82 * start / t30_s) * peak
    if late_t30_s is not None:
        rate += np.exp(-13.82 * start / late_t30_s) * peak * 10 ** (late_db / 10)
    rate[:5] = 0.0
    rate[5] = 10 * peak
    return rate, start, np.full(start.size, 1e-3)


def test_a_double_slope_decay_is_left_out_for_good_and_said():
    """Two exponentials (0.3 s, and 1.5 s 15 dB below) with plenty of counts: T30's curvature
    against T20 is far beyond ISO 3382-2's 10 % (by many of its own SEs), so T30 is undefined
    for good: left out of the rule, listed under its reason, EDT and C80 still counted."""
    rate, start, width = decay(0.3, late_t30_s=1.5, late_db=-15.0, peak=2e5)
    groups = synthetic_groups(rate, np.random.default_rng(3))
    e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width, None)
    assert np.isnan(e.value["t30"][0, 0])
    kind = e.why_undefined["t30"][0, 0].split(":")[0]
    assert kind in accuracy.CURVED
    assert e.for_good["t30"][0, 0] and not e.waiting("t30")[0, 0]
    assert np.isnan(e.counted("t30")[0, 0])
    assert e.summary()["t30"]["left_out"] == {kind: [[0, 0]]}
    assert e.summary()["t30"]["undefined"] == 0
    assert np.isfinite(e.worst_over_target(0.25))
    assert "left out, more rays cannot define them: T30 at 1 (" in progressive._describe(e, 0.25)


def test_a_parameter_undefined_by_noise_is_waited_for():
    """A single exponential (T30 = 0.5 s) with so few counts that its tail is empty: the decay
    curve's floor lies above −35 dB, T30 is undefined ("range not reached"), a reason more rays
    change: the entry counts as not converged (worst error infinite) and the summary and the
    round's line say so; with 10,000 × the counts T30 is defined and counted."""
    rate, start, width = decay(0.5, peak=0.5)
    groups = synthetic_groups(rate, np.random.default_rng(5))
    e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width, None)
    assert np.isnan(e.value["t30"][0, 0])
    assert not e.for_good["t30"][0, 0] and e.waiting("t30")[0, 0]
    assert e.worst_over_target(10.0) == np.inf
    assert e.summary()["t30"]["undefined"] == 1 and e.summary()["t30"]["left_out"] == {}
    assert "T30 undefined" in progressive._describe(e, 10.0)
    # The automatic choice's projection has no SE to project from there: left out of it.
    assert np.isfinite(progressive.projection(e, 10.0))
    rate, start, width = decay(0.5, peak=5000.0)
    groups = synthetic_groups(rate, np.random.default_rng(5))
    e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width, None)
    assert np.isfinite(e.value["t30"][0, 0]) and not e.waiting("t30").any()


@pytest.mark.parametrize("why, measure, se, for_good", [
    ("curved decay: ξ = 30 ‰", 30.0, 2.0, True),  # 20 ‰ beyond, 10 SE
    ("curved decay: ξ = 12 ‰", 12.0, 2.0, False),  # 2 ‰ beyond, 1 SE: may be noise
    ("double slope: curvature C = 40 %", 40.0, 3.0, True),
    ("double slope: curvature C = 11 %", 11.0, 3.0, False),
    ("curved decay: ξ = 30 ‰", 30.0, np.inf, False),  # a leave-out without a fit
    ("record too short: about -40 dB", np.nan, np.nan, True),  # a setting: max_time_s
    ("range not reached: only -20 dB", np.nan, np.nan, False),
    ("no energy: the histogram holds no energy", np.nan, np.nan, False),
    ("slower than physically possible: 9 s", np.nan, np.nan, False),
])
def test_which_undefined_entries_more_rays_cannot_change(why, measure, se, for_good):
    """A curved decay is the room's once its measure lies beyond ISO 3382-2's limit by more than
    t(0.975, 7) = 2.365 of its SEs; a record too short is a setting; the rest is noise."""
    measures = {"t30_xi_permille": np.array([[measure]]),
                "curvature_abs_percent": np.array([[measure]])}
    errors = {key: np.array([[se]]) for key in measures}
    assert accuracy.undefined_for_good(np.array([[why]]), measures, errors)[0, 0] == for_good


def test_a_converged_bake_has_no_parameter_undefined_by_noise():
    """The stopping rule waits for every entry undefined by noise: when a bake says
    "converged", none is left, and the record lists the ones left out for good (if any)."""
    field, errors = progressive.bake(room(), accuracy=progressive.Accuracy(0.5))
    p = field.settings["progressive"]
    assert p["stopped"] == "converged"
    assert all(p["errors"][name]["undefined"] == 0 for name in progressive.PARAMETERS)
    assert all(not errors.waiting(name).any() for name in progressive.PARAMETERS)
    assert all("left_out" in p["errors"][name] for name in progressive.PARAMETERS)


def test_each_round_says_how_far_it_is_and_the_end_says_what_was_reached():
    """The round's line projects the rays and seconds still needed (and says when the cap comes
    first); the last line says how the bake ended and the errors it reached, per parameter; the
    progress line names the round."""
    lines: list[str] = []
    cap = 2 * progressive.GROUPS * progressive.FIRST_GROUP_RAYS
    progressive.bake(room(), accuracy=progressive.Accuracy(0.05, max_rays=cap), log=lines.append)
    first = next(line for line in lines if line.startswith("round 1:"))
    assert "rays to converge" in first and "rays/s" in first
    assert f"more than the cap of {cap:,} rays" in first
    assert lines[-1].startswith("progressive bake: stopped at the ray cap (max_rays), NOT "
                                "converged after 32,768 rays in 2 rounds")
    assert all(f"{p.upper()} SE ≤" in lines[-1] for p in progressive.PARAMETERS)
    work = progressive.RoundWork(SoundRanges(room(), sonolux.SoundOptions(rays=cap)), 0, cap,
                                 progressive.GROUPS, progressive.RoundSum())
    assert work.name.endswith("round 1")


def test_info_says_which_entries_were_undefined_or_left_out():
    """`sonolux info`'s accuracy line: the worst error per parameter, and where a parameter was
    still undefined (a cap stopped the bake) or left out for good, how many and why."""
    from sonolux.sound.info import progressive_line

    line = progressive_line({"accuracy_jnd": 0.25, "stopped": "max_seconds", "rounds": [{}] * 3,
                             "errors": {
                                 "t30": {"unit": "relative", "max": 0.02, "undefined": 2,
                                         "left_out": {"curved decay": [[0, 1], [3, 0]]}},
                                 "edt": {"unit": "relative", "max": 0.01, "undefined": 0,
                                         "left_out": {}},
                                 "c80": {"unit": "dB", "max": 0.2}}})
    assert "stopped at --max-seconds, not converged in 3 rounds" in line
    assert "T30 ≤ 2% (undefined at 2: more rays needed) (left out at 2: curved decay)" in line
    assert "EDT ≤ 1%, C80 ≤ 0.2 dB" in line


def test_an_entry_at_a_limit_counts_by_its_fitted_values_error():
    """Refused by a limit it is within the noise of (curvature 12 ± 3 %): the entry is neither
    left out nor infinite: the rule counts the SE of its fitted value, so the bake waits until
    that value is known to the target, on whichever side of the limit it is reported."""
    nan = np.nan
    value = {"t30": np.array([[nan, 1.0]]), "edt": np.ones((1, 2)), "c80": np.zeros((1, 2))}
    se = {"t30": np.array([[nan, 0.001]]), "edt": np.full((1, 2), 0.001),
          "c80": np.full((1, 2), 0.01)}
    why = {"t30": np.array([["double slope: C = 12 %", ""]]), "edt": np.full((1, 2), ""),
           "c80": np.full((1, 2), "")}
    good = {name: np.zeros((1, 2), bool) for name in value}
    at = {"t30": np.array([[0.02, nan]]), "edt": np.full((1, 2), nan),
          "c80": np.full((1, 2), nan)}
    e = progressive.Errors(value, se, None, why, good, at)
    assert e.at_limit("t30")[0, 0] and e.counted("t30")[0, 0] == 0.02
    assert e.worst_over_target(0.25) == pytest.approx(0.02 / 0.0125)
    s = e.summary()["t30"]
    assert s["at_limit"] == {"double slope": [[0, 0]]} and s["undefined"] == 0
    assert "T30 at an ISO 3382-2 limit at 1 (double slope)" in progressive._describe(e, 0.25)
    # Its SE is projected like any other: the round's outlook is no lower bound ("at least")
    # for it (it said so before session 11 while any entry was at a limit).
    text = progressive.outlook(e, progressive.Accuracy(0.25), 16_384, 1_000_000, 1000.0)
    assert "rays to converge (" in text and "at least" not in text
    e.at_limit_error = None  # the same entry without a fitted SE: undefined by noise
    assert "rays to converge at least" in progressive.outlook(e, progressive.Accuracy(0.25),
                                                              16_384, 1_000_000, 1000.0)


def test_an_onset_that_not_every_group_reaches_counts_in_the_error():
    """A receiver without a direct sound (around a corner) whose earliest arrival within 20 dB of
    the peak is one deposit in one group: the whole bake's onset (ISO 3382-1 A.3.4) is 15 ms,
    the one every group reaches on its own 25 ms. Its parameters' SEs are widened to the change
    between the two over t(0.975, 7), so the 95 % interval holds the value at either onset; the
    leave-outs take their own onsets; the round's line and the summary say which receiver. A
    receiver with a direct sound in every group is untouched, and once the early arrival is in
    every group (more rays) the two onsets agree. (Measured in the L-room at 1,048,576 paper rays:
    with the whole bake's onset kept for every leave-out, C80 of the receiver around the corner
    lay 18.6 of its SEs from the 26 M-ray value.)"""
    rate, start, width = decay(0.5, peak=5000.0)
    shadowed = rate.copy()
    shadowed[:25] = 0.0  # no direct sound: the reverberation starts at 25 ms
    groups = np.stack([synthetic_groups(rate, np.random.default_rng(9))[:, 0],
                       synthetic_groups(shadowed, np.random.default_rng(10))[:, 0]], axis=1)
    early = np.uint64(2 * shadowed[25])  # one strong early arrival, 10 ms ahead
    groups[3, 1, 0, 15] += early
    total = groups.sum(axis=0, dtype=np.uint64)
    edges = np.append(start, start[-1] + width[-1])
    e = progressive.jackknife(total, groups, start, width, None)
    assert e.onset_s.tolist() == pytest.approx([0.005, 0.015])
    assert e.supported_onset_s.tolist() == pytest.approx([0.005, 0.025])
    assert accuracy.leave_out_onsets(total, groups, edges)[:, 1].tolist() == pytest.approx(
        [0.015] * 3 + [0.025] + [0.015] * 4)
    at = {k: progressive.parameters(total.astype(float), start, width, np.array([0.005, t]),
                                    None, fit_limits=False) for k, t in (("whole", 0.015),
                                                                         ("every", 0.025))}
    for name in progressive.PARAMETERS:
        shift = abs(at["every"][name][1, 0] - at["whole"][name][1, 0])
        assert e.standard_error[name][1, 0] >= shift / progressive.T_95 * (1 - 1e-12), name
        assert np.isfinite(e.standard_error[name]).all()
    assert abs(at["every"]["c80"][1, 0] - at["whole"]["c80"][1, 0]) > 1.0  # it matters (dB)
    assert "onset uncertain at receiver #1 (15.0 ms; 25.0 ms in every group)" in \
        progressive._describe(e, 0.25)
    assert e.summary()["c80"]["onset_uncertain"] == [1]
    groups[:, 1, 0, 15] = early  # the early arrival seen by every group
    e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width, None)
    assert e.onset_uncertain().size == 0 and e.supported_onset_s[1] == pytest.approx(0.015)
