"""The progressive bake (rays = auto): its error estimate against the real spread of independent
bakes, its stopping rules, the same bits however the rounds are traced, resumed after a kill."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux import cli
from sonolux.analysis.params import onsets_s
from sonolux.errors import SonoluxError
from sonolux.sound import progressive
from sonolux.sound.baking import bake

pytestmark = pytest.mark.usefixtures("core")


def room(**settings):
    """A 5 × 4 × 3 m shoebox, three receivers, octaves 250 Hz–2 kHz: small enough to bake often."""
    return sonolux.load_scene({
        "name": "progressive",
        "settings": {"bands_hz": [250, 500, 1000, 2000], "max_time_s": 1.2, **settings},
        "materials": {"wall": {"absorption": 0.12, "scattering": 0.3}},
        "geometry": [{"type": "shoebox", "size_m": [5, 4, 3], "materials": {"default": "wall"}}],
        "sources": [{"position_m": [1.2, 1.1, 1.5]}],
        "receivers": {"type": "points",
                      "positions_m": [[3.8, 2.9, 1.2], [2.5, 1.0, 1.7], [4.0, 1.0, 1.0]]},
    })


def test_jackknife_error_matches_the_spread_of_independent_estimates():
    """Synthetic decays with Poisson noise (each count one ray's crossing): over 120 independent
    replicates, the mean jackknife standard error of T30, EDT and C80 must match the replicates'
    own standard deviation. Tolerance 25 %: the standard deviation of 120 replicates is itself
    known to about ±6.5 % (1/√(2·119)), and the delete-a-group jackknife of a smooth statistic
    is unbiased to first order only (Shao and Tu 1995, §2.1), with 8 groups."""
    rng = np.random.default_rng(7)
    start = np.arange(1200) * 1e-3
    width = np.full(start.size, 1e-3)
    rate = np.exp(-13.82 * start / 0.5) * 2000.0  # T = 0.5 s, 2000 crossings per bin at first
    rate[:5] = 0.0
    rate[5] = 20_000.0  # the direct sound
    values, errors = {k: [] for k in progressive.PARAMETERS}, {k: [] for k in progressive.PARAMETERS}
    for _ in range(120):
        groups = rng.poisson(np.broadcast_to(rate / 8, (8, 1, 1, start.size))).astype(np.uint64)
        e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width, None)
        for k in progressive.PARAMETERS:
            values[k].append(e.value[k][0, 0])
            errors[k].append(e.standard_error[k][0, 0])
    for k in progressive.PARAMETERS:
        spread = np.std(values[k], ddof=1)
        assert np.mean(errors[k]) == pytest.approx(spread, rel=0.25), k


def test_the_error_estimate_scatters_as_its_degrees_of_freedom_say():
    """The stopping rule waits until the largest estimated SE is below target, so the estimate's
    own scatter sets how far past the need a bake runs (docs/progressive.md, "Why the L-room ran
    on to 26 M rays"). An SE from G groups has G − 1 degrees of freedom: across replicates its
    relative SD is about 1/√(2(G − 1)) (a χ variable's), 0.27 at 8 groups, 0.18 at 16. Checked
    on the synthetic decays above, 160 replicates, for C80 and EDT (smooth statistics; T30 adds
    the fit's range): within 30 % of that (the SD of 160 SDs is known to ±6 %, and the jackknife
    is a χ variable to first order only), and 16 groups below 8. The interval's t is Student's
    for GROUPS − 1 degrees of freedom (scipy)."""
    from scipy import stats

    assert progressive.T_95 == pytest.approx(stats.t.ppf(0.975, progressive.GROUPS - 1), abs=5e-4)
    rng = np.random.default_rng(11)
    start = np.arange(1200) * 1e-3
    width = np.full(start.size, 1e-3)
    rate = np.exp(-13.82 * start / 0.5) * 2000.0
    rate[:5], rate[5] = 0.0, 20_000.0
    scatter = {}
    for g in (8, 16):
        se = {k: [] for k in ("edt", "c80")}
        for _ in range(160):
            groups = rng.poisson(np.broadcast_to(rate / g, (g, 1, 1, start.size))).astype(np.uint64)
            e = progressive.jackknife(groups.sum(axis=0, dtype=np.uint64), groups, start, width,
                                      None)
            for k in se:
                se[k].append(e.standard_error[k][0, 0])
        for k in se:
            scatter[g, k] = np.std(se[k], ddof=1) / np.mean(se[k])
            assert scatter[g, k] == pytest.approx(1 / np.sqrt(2 * (g - 1)), rel=0.3), (g, k)
    assert all(scatter[16, k] < scatter[8, k] for k in ("edt", "c80"))


def test_onset_comes_from_the_whole_bake():
    edges = np.arange(11) * 0.1
    e = np.zeros((1, 10))
    e[0, 3] = 1.0
    assert onsets_s(e, edges)[0] == pytest.approx(0.3)


def test_a_coarse_accuracy_stops_after_the_first_round_and_says_so():
    field, errors = progressive.bake(room(), accuracy=progressive.Accuracy(9.0))
    p = field.settings["progressive"]
    assert p["stopped"] == "converged" and len(p["rounds"]) == 1
    assert field.settings["rays"] == p["rounds"][0]["rays"]
    assert errors.worst_over_target(9.0) <= 1.0
    assert set(p["errors"]) == {"t30", "edt", "c80"}


def test_the_ray_cap_stops_a_bake_that_has_not_converged():
    cap = 2 * progressive.GROUPS * progressive.FIRST_GROUP_RAYS
    field, errors = progressive.bake(room(), accuracy=progressive.Accuracy(0.01, max_rays=cap))
    p = field.settings["progressive"]
    assert p["stopped"] == "max_rays" and field.settings["rays"] == cap
    assert errors.worst_over_target(0.01) > 1.0


def test_rounds_end_where_the_error_says_and_energy_is_scaled_to_the_rays_traced():
    """Two rounds; the field equals (exactly) the counts of those rays × quantum × nominal / n,
    and its level matches a plain bake of as many rays (same rays, other scaling) to float32."""
    scene = room()
    field, _ = progressive.bake(scene, accuracy=progressive.Accuracy(0.3))
    n = field.settings["rays"]
    plain = sonolux.bake(scene, rays=n)
    np.testing.assert_allclose(np.asarray(field.energy).sum(), np.asarray(plain.energy).sum(),
                               rtol=1e-5)


def test_same_bits_on_one_and_two_threads_and_whatever_the_ranges():
    one, _ = progressive.bake(room(threads=1), accuracy=progressive.Accuracy(0.3))
    two, _ = progressive.bake(room(threads=2), accuracy=progressive.Accuracy(0.3),
                              range_rays=3001)
    assert one.settings["progressive"]["rounds"][-1]["rays"] == \
        two.settings["progressive"]["rounds"][-1]["rays"]
    assert np.array_equal(one.energy, two.energy)


class Stop(Exception):
    """Stands for a kill."""


def test_a_killed_progressive_bake_resumes_to_the_same_bits(tmp_path):
    scene = room()
    side = tmp_path / "p.h5.checkpoint"
    whole, _ = progressive.bake(scene, accuracy=progressive.Accuracy(0.3))
    rounds = whole.settings["progressive"]["rounds"]
    assert len(rounds) >= 2, "the test needs a second round to kill"
    first = rounds[0]["rays"]

    def kill_in_round_two(done, total, elapsed):
        if total != first and done > total // 3:
            raise Stop
        return True

    with pytest.raises(Stop):
        progressive.bake(scene, accuracy=progressive.Accuracy(0.3), checkpoint=side,
                         checkpoint_every_s=0, range_rays=2048, progress=kill_in_round_two)
    assert side.exists()
    again = bake(scene, accuracy=progressive.Accuracy(0.3), checkpoint=side, resume=True,
                 checkpoint_every_s=0, range_rays=2048)
    assert np.array_equal(again.energy, whole.energy)
    assert not side.exists()


def test_accuracy_needs_rays_auto_and_is_checked():
    with pytest.raises(SonoluxError, match="accuracy is for rays = 'auto'"):
        bake(room(), rays=5000, accuracy=0.5)
    with pytest.raises(SonoluxError, match="accuracy"):
        bake(room(), accuracy=-1.0)
    with pytest.raises(SonoluxError, match="ray range"):
        progressive.bake(room(), sonolux.SoundOptions(ray_range=(0, 100)))


@pytest.mark.parametrize("argv, message", [
    (["--rays", "5000", "--accuracy", "0.5"], "--accuracy steer a progressive bake"),
    (["--range", "0:1000"], "--range splits a bake of a known size"),
    (["--accuracy", "0"], "--accuracy"),
    (["--max-rays", "10"], "--max-rays"),
])
def test_cli_flags_of_the_progressive_bake_are_usage_errors(capsys, tmp_path, argv, message):
    code = cli.main(["bake", "paper-small", "--no-light", "-q", "-o", str(tmp_path / "x.h5"),
                     *argv])
    assert code == 2
    assert message in capsys.readouterr().err


def test_cli_bake_auto_is_progressive_and_info_reports_its_error(capsys, tmp_path):
    out = tmp_path / "p.h5"
    assert cli.main(["bake", "paper-small", "--no-light", "-q", "--accuracy", "4",
                     "-o", str(out)]) == 0
    text = capsys.readouterr()
    assert "progressive bake: converged" in text.err
    assert "accuracy    converged to 4 JND" in text.out
    assert not (tmp_path / "p.h5.checkpoint").exists()
    assert cli.main(["info", str(out)]) == 0
    assert "standard error at the worst receiver" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.parametrize("estimator", ["paper", "nee", "auto"])
def test_the_reported_error_brackets_the_real_error_against_ten_times_the_rays(estimator):
    """The issue's check of the stopping rule: the 95 % interval θ ± t(0.975, 7)·SE that a
    progressive bake reports holds the value of an independent bake (another seed) with 10× its
    rays in at least 90 % of receivers, bands and parameters. Four seeds × 3 receivers × 4 bands ×
    3 parameters = 144 cases. Expected coverage: 95 % less the reference's own noise (its SE is
    1/√10 of ours: the interval covers ±2.365/√1.1 = ±2.25 combined SE, 94 % for t with 7
    degrees of freedom); 90 % leaves room for the jackknife's first-order bias. For paper, nee
    (M = 2 of the 3 receivers: sampled) and auto (the reference: the estimator auto chose)."""
    inside, cases = 0, 0
    for seed in (1, 2, 3, 4):
        scene = room(seed=seed)
        options = sonolux.SoundOptions(estimator=estimator, nee_receivers=2)
        field, errors = progressive.bake(scene, options, accuracy=progressive.Accuracy(0.5))
        n = field.settings["rays"]
        reference = sonolux.bake(room(seed=seed + 100), rays=10 * n,
                                 estimator=field.settings["estimator"], nee_receivers=2)
        held, finite = bracketed(errors, reference)
        inside, cases = inside + held, cases + finite
    assert cases >= 130
    print(f"coverage {inside} of {cases}")
    assert inside / cases >= 0.90, f"{inside} of {cases}"


def test_decay_times_near_the_source_are_reported_but_not_waited_for():
    """ISO 3382's d_min = 2 √(V / (c T)): T30 and EDT of a receiver nearer the source are left
    out of the rule (counted as near_source), C80 is not; the values and SEs stay as they were."""
    value = {"t30": np.full((3, 2), 1.0), "edt": np.full((3, 2), 1.0), "c80": np.zeros((3, 2))}
    se = {"t30": np.array([[0.001, 0.001], [0.5, 0.5], [0.001, 0.001]]),
          "edt": np.array([[0.001, 0.001], [0.5, 0.5], [0.001, 0.001]]),
          "c80": np.array([[0.01, 0.01], [0.01, 0.01], [0.01, 0.01]])}
    errors = progressive.Errors(value, se)
    # V = 343 m³, c = 343 m/s, T = 1 s: d_min = 2 m. Receiver 1 is 1 m from the source.
    receivers = np.array([[5.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    out = progressive.near_source(errors, receivers, np.zeros((1, 3)), 343.0, 343.0)
    assert errors.worst_over_target(0.25) == pytest.approx(0.5 / 0.0125)
    assert out.worst_over_target(0.25) == pytest.approx(0.001 / 0.0125)
    summary = out.summary()
    assert summary["edt"]["near_source"] == 2 and summary["t30"]["near_source"] == 2
    assert summary["c80"]["near_source"] == 0
    assert np.array_equal(out.standard_error["edt"], se["edt"])
    assert progressive.minimum_distance_m(343.0, 343.0, np.array([1.0]))[0] == pytest.approx(2.0)
    # Nearer than d_min only for the band whose T makes d_min larger.
    value2 = dict(value, t30=np.array([[4.0, 0.25]] * 3))
    out2 = progressive.near_source(progressive.Errors(value2, se), receivers,
                                   np.array([[2.5, 0.0, 0.0]]), 343.0, 343.0)
    assert out2.excluded["edt"][1].tolist() == [False, True]  # d_min 1 m and 4 m, gap 1.5 m


def test_near_the_source_is_measured_from_each_rows_own_source_in_a_field_per_source():
    """A field per source has its rows source by source: receiver 1 is near source 0 only, so
    only its row of source 0 is left out (with all sources summed, the nearest source counts)."""
    receivers = np.array([[5.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    sources = np.array([[0.0, 0.0, 0.0], [9.0, 9.0, 0.0]])
    value = {"t30": np.ones((4, 1)), "edt": np.ones((4, 1)), "c80": np.zeros((4, 1))}
    se = {name: np.full((4, 1), 0.001) for name in value}
    out = progressive.near_source(progressive.Errors(value, se), receivers, sources, 343.0, 343.0)
    assert out.excluded["edt"][:, 0].tolist() == [False, True, False, False]
    summed = {name: v[:2] for name, v in value.items()}
    out = progressive.near_source(progressive.Errors(summed, {k: v[:2] for k, v in se.items()}),
                                  receivers, sources, 343.0, 343.0)
    assert out.excluded["edt"][:, 0].tolist() == [False, True]


def test_the_automatic_estimator_is_a_function_of_the_scene_and_seed_and_keeps_its_pilot():
    """estimator = "auto": a pilot of each candidate, ranked by counted work × (SE / target)²
    (integers and bits: the same choice on any machine), recorded in the field; the chosen
    pilot is the bake's first round, so the field is, bit for bit, the progressive bake pinned
    to the chosen estimator with that first round."""
    scene = room()
    accuracy = progressive.Accuracy(2.0)
    options = sonolux.SoundOptions(nee_receivers=2, estimator="auto")
    chosen, record, pilot = progressive.choose(scene, options, accuracy)
    again = progressive.choose(scene, options, accuracy)[1]
    assert chosen.estimator == record["chosen"] == again["chosen"] in progressive.CANDIDATES
    pilots = record["pilots"]
    assert set(pilots) == set(progressive.CANDIDATES)
    for name, p in pilots.items():  # the same counts and errors: the same projections
        assert p["work"] == again["pilots"][name]["work"] == progressive.counted_work(p["stats"])
        assert p["projected_work"] == again["pilots"][name]["projected_work"]
        assert p["rays"] % (progressive.GROUPS * progressive.BLOCK_RAYS) == 0
    best = min(p["projected_work"] for p in pilots.values())
    assert pilots[record["chosen"]]["projected_work"] == best
    # The others' pilots cost about the paper pilot's work, never more rays.
    assert all(p["rays"] <= pilots["paper"]["rays"] for p in pilots.values())
    assert pilot is not None and pilot.rays == pilots[record["chosen"]]["rays"]
    field, _ = progressive.bake(scene, options, accuracy)
    pinned, _ = progressive.bake(scene, chosen, accuracy, first_rays=pilot.rays)
    assert field.settings["estimator"] == record["chosen"]
    assert field.settings["estimator_choice"]["chosen"] == record["chosen"]
    assert field.settings["rays"] == pinned.settings["rays"]
    assert np.array_equal(np.asarray(field.energy), np.asarray(pinned.energy))
    # nee with at least as many draws as receivers is rain: not piloted twice.
    _, same, _ = progressive.choose(scene, replace(options, nee_receivers=3), accuracy)
    assert same["pilots"]["nee"] == {"same_as": "rain", "projected_work": float("inf")}
    fixed = bake(scene, rays=2048, estimator="auto")
    assert fixed.settings["estimator"] == fixed.settings["estimator_choice"]["chosen"]


@pytest.mark.parametrize("estimator", ["rain", "nee"])
def test_the_exact_direct_sound_is_counted_once_and_shared_by_the_groups(estimator):
    """Rain and nee deposit the exact direct sound (no noise) a share per block of rays, so a
    progressive bake of n rays (scaled by its nominal rays / n) holds it once, as a plain bake
    of n rays does (it used to hold it nominal / n times: +35 dB for 16k of 50 M rays), and every
    jackknife group holds its share: leaving a group out does not remove it. Tolerance 1e-6: the
    two bakes differ only in each deposit's stochastic rounding (quanta of ~1e-18 J)."""
    scene = room()
    options = sonolux.SoundOptions(estimator=estimator, nee_receivers=2)
    field, errors = progressive.bake(scene, options, progressive.Accuracy(10.0))
    plain = bake(scene, rays=field.settings["rays"], estimator=estimator, nee_receivers=2)
    ours = np.asarray(field.energy, np.float64).sum(axis=(1, 3))
    theirs = np.asarray(plain.energy, np.float64).sum(axis=(1, 3))
    assert np.allclose(ours, theirs, rtol=1e-6, atol=0)
    # The early decay is known to a fraction of a JND after one round (with the direct sound in
    # group 0 alone, a leave-out lost it: EDT and C80 errors of whole dB and seconds).
    assert errors.summary()["c80"]["max"] < 0.5


@pytest.mark.slow
def test_the_reported_error_brackets_the_real_error_where_the_deposits_have_a_tail():
    """The issue's check where it used to fail: the L-room (examples/l-room: the receiver around
    the corner has no direct sound, its onset is set by rare early arrivals) at 1,048,576 paper
    rays, the count at which session 11 measured 15.5 % of the 95 % intervals missing a 29.8 M-ray
    bake of the same seed (C80 at that receiver up to 18.6 SEs off: every leave-out kept the
    whole bake's onset). Each leave-out now takes its own onset, and an onset not every group
    reaches on its own widens the errors (accuracy.supported_onsets). Against an independent bake
    (another seed) of 10× the rays, the intervals θ ± t(0.975, 7)·SE must hold the reference in
    at least 90 % of receivers, bands and parameters where both are defined (expected about 94 %,
    as for the shoebox), at least 40 of the 72 entries. Known to miss (docs/progressive.md,
    "Rare large deposits"): T30 at 250–500 Hz
    around the corner, whose late decay is carried by rare long-lived rays."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples/l-room/l-room.toml"
    scene = sonolux.load_scene(str(path))
    scene = replace(scene, settings=replace(scene.settings, threads=2))
    n = 1_048_576
    # In two rounds (262,144, then to 1,048,576), as a progressive bake runs: the second watches
    # the late tail from the decay the first measured (sonolux.sound.tail).
    field, errors = progressive.bake(scene, sonolux.SoundOptions(estimator="paper"),
                                     accuracy=progressive.Accuracy(0.25, max_rays=n),
                                     first_rays=n // 4)
    assert field.settings["rays"] == n
    other = replace(scene, settings=replace(scene.settings, seed=scene.settings.seed + 100))
    reference = sonolux.bake(other, rays=10 * n, estimator="paper")
    inside, cases = bracketed(errors, reference, show=True)
    print(f"coverage {inside} of {cases}; onset uncertain at {errors.onset_uncertain().tolist()}"
          f"; late tail {field.settings['progressive']['errors']['t30'].get('tail')}")
    assert cases >= 40
    assert inside / cases >= 0.90, f"{inside} of {cases}"
    # The late tail's diagnostic (sonolux.sound.tail) flags every T30 whose interval misses:
    # measured, all 10 defined T30 entries have Pareto k̂ ≥ 0.7 (2.5–7; the misses 2.7–4.1).
    omni = np.asarray(reference.energy).sum(axis=1, dtype=np.float64)
    edges = np.append(reference.bin_start_s, reference.bin_start_s[-1] + reference.bin_width_s[-1])
    t30 = progressive.parameters(omni, reference.bin_start_s, reference.bin_width_s,
                                 onsets_s(omni.sum(axis=1), edges), None)["t30"]
    with np.errstate(invalid="ignore"):
        miss = np.abs(errors.value["t30"] - t30) > progressive.T_95 * errors.standard_error["t30"]
    assert not (miss & ~errors.heavy_tail("t30")).any()


def bracketed(errors, reference, show=False):
    """(entries whose 95 % interval θ ± t(0.975, 7)·SE holds the reference bake's value, entries
    where both are finite), over receivers, bands and T30/EDT/C80; the reference's parameters
    from its omni energies with its own onset (ISO 3382-1 A.3.4)."""
    omni = np.asarray(reference.energy).sum(axis=1, dtype=np.float64)
    edges = np.append(reference.bin_start_s, reference.bin_start_s[-1]
                      + reference.bin_width_s[-1])
    truth = progressive.parameters(omni, reference.bin_start_s, reference.bin_width_s,
                                   onsets_s(omni.sum(axis=1), edges), None)
    inside, cases = 0, 0
    for name in progressive.PARAMETERS:
        ok = np.isfinite(errors.standard_error[name]) & np.isfinite(truth[name])
        miss = np.abs(errors.value[name] - truth[name]) > progressive.T_95 * \
            errors.standard_error[name]
        inside += int((ok & ~miss).sum())
        cases += int(ok.sum())
        if show:
            print(name, "finite", int(ok.sum()), "outside", int((ok & miss).sum()))
    return inside, cases
