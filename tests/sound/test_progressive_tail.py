"""The progressive bake's heavy-tail diagnostic (sonolux.sound.tail, docs/progressive.md "The late
decay of rare long-lived rays"): the generalized Pareto fit against distributions of known shape,
the core's largest late contributions (the same whatever the threads and ray ranges; the field's
bits unchanged), and the rule: T30 whose late decay rests on a heavy tail is waited for."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux.sound import progressive, tail
from sonolux.sound.accuracy import Errors
from sonolux.sound.bake import bake as bake_whole
from tests.sound.test_progressive import room


@pytest.mark.parametrize("shape", [0.0, 0.3, 0.5, 0.8])
def test_the_pareto_fit_finds_the_shape_of_a_known_tail(shape):
    """k̂ of 100,000 draws of a generalized Pareto distribution of shape ξ (inverse transform of
    uniforms) is ξ within 0.1 (its sampling SD at M = 949 exceedances is about (1 + ξ)/√M ≈
    0.03–0.06, and the prior's pull to 1/2 is 10/(M + 10) of the gap)."""
    rays = 100_000
    u = np.random.default_rng(7).random(rays)
    draws = -np.log(u) if shape == 0 else (u ** -shape - 1) / shape
    k = tail.pareto_k(np.sort(draws)[::-1], rays)
    assert abs(k - shape) < 0.1, k


def test_a_lognormal_tail_looks_heavier_the_wider_it_is():
    """A product of many reflections' factors is about lognormal: with σ = 1 its largest draws
    are a light tail (k̂ < 0.5), with σ = 3 a heavy one, past 0.7 (Vehtari et al. 2024 discuss
    the same pre-asymptotic behaviour)."""
    rng = np.random.default_rng(3)
    rays = 200_000
    light = tail.pareto_k(np.sort(rng.lognormal(0, 1, rays))[::-1], rays)
    heavy = tail.pareto_k(np.sort(rng.lognormal(0, 3, rays))[::-1], rays)
    assert light < 0.5 < tail.K_LIMIT < heavy, (light, heavy)


def test_too_few_contributions_give_no_fit_and_zeros_count_as_draws():
    assert np.isnan(tail.pareto_k(np.array([3.0, 2.0, 1.0]), 10_000))
    assert np.isnan(tail.pareto_ks(np.zeros((1, 2, 0)), 10_000)).all()  # no late energy at all
    # 40 positive draws among 10,000: the threshold is 0 and the fit uses all 40.
    top = np.sort(np.random.default_rng(1).pareto(2.0, 40) + 1.0)[::-1]
    assert np.isfinite(tail.pareto_k(top, 10_000))
    assert tail.tail_draws(10_000) == 300 and tail.kept_per_entry(10_000) == 301
    assert tail.reliable_below(10**6) == pytest.approx(0.7)
    assert tail.reliable_below(1000) == pytest.approx(1 - 1 / 3)
    # The lists' memory: 385 entries at 1 M rays fit on 2 threads, 10,000 do not.
    assert tail.affordable(385, tail.kept_per_entry(10**6), 2)
    assert not tail.affordable(10_000, tail.kept_per_entry(10**6), 2)


def test_tail_sums_merge_to_the_same_values_however_a_round_is_cut():
    rng = np.random.default_rng(2)
    values = rng.pareto(1.5, (2, 3, 60))
    whole = tail.TailSum((0, 60), -np.sort(-values, axis=-1)[..., :20], np.full((2, 3), 60, np.uint64))
    parts = [tail.TailSum((0, 60), -np.sort(-values[..., a:b], axis=-1)[..., :20],
                          np.full((2, 3), b - a, np.uint64)) for a, b in ((0, 7), (7, 41), (41, 60))]
    merged = parts[2].add(parts[0]).add(parts[1])
    assert np.array_equal(merged.values, whole.values)
    assert np.array_equal(merged.contributing, whole.contributing)


def test_the_late_part_starts_where_the_decay_has_fallen_35_db():
    """An exponential decay of T = 1 s from an onset at 10 ms: the energy still to come falls
    35 dB at 10 ms + 35/60 s (to a bin)."""
    width = np.full(2000, 1e-3)
    start = np.arange(2000) * 1e-3
    omni = np.where(start >= 0.01, 10 ** (-6 * (start - 0.01)), 0.0)[None, None, :]
    from_s = tail.late_from_s(omni, start, width, np.array([0.01]))
    assert from_s[0, 0] == pytest.approx(0.01 + 35 / 60, abs=2e-3)
    assert tail.late_from_s(np.zeros((1, 1, 2000)), start, width, np.array([0.0]))[0, 0] == np.inf


def test_t30_on_a_heavy_tail_is_reported_and_not_waited_for():
    """Measured (docs/progressive.md): waiting for k̂ < 0.7 stalled paper-medium (313 entries
    above it at 16,384 rays) and every defined L-room T30; the rule reports it."""
    value = {"t30": np.full((2, 2), 1.0), "edt": np.full((2, 2), 1.0), "c80": np.zeros((2, 2))}
    se = {"t30": np.full((2, 2), 0.001), "edt": np.full((2, 2), 0.001), "c80": np.full((2, 2), 0.01)}
    k = np.array([[0.2, 0.75], [np.nan, 0.69]])
    errors = Errors(value, se, tail_k=k, tail_rays=1_000_000)
    assert errors.heavy_tail("t30").tolist() == [[False, True], [False, False]]
    assert not errors.heavy_tail("edt").any()
    assert errors.worst_over_target(0.25) < 1 and not errors.waiting("t30").any()
    t30 = errors.summary()["t30"]
    assert t30["tail"]["heavy"] == [[0, 1, 0.75]] and t30["undefined"] == 0
    assert "heavy tail at 1 receiver-bands" in tail.describe(t30["tail"])
    light = Errors(value, se, tail_k=np.minimum(k, 0.5), tail_rays=1_000_000)
    assert light.worst_over_target(0.25) < 1
    assert "reliable below 0.7" in tail.describe(light.summary()["t30"]["tail"])


def test_the_core_keeps_the_same_tail_whatever_the_threads_and_ranges_and_the_field_stays():
    """The largest late contributions of 24,576 rays: on 1 thread in one range, on 2 threads in
    three ranges (merged), the same values; the field's counts equal a bake not watching."""
    scene = room(threads=1)
    n = 24_576
    watch = tail.first_round_settings(scene, n)
    assert watch is not None and np.isfinite(watch[0]).all()
    options = sonolux.SoundOptions(rays=n, estimator="paper")
    watched = bake_whole(scene, replace(options, ray_range=(0, n)), tail=watch)
    plain = bake_whole(scene, replace(options, ray_range=(0, n)))
    assert np.array_equal(watched.counts, plain.counts)
    one = tail.of_core(watched.stats["tail"], watch[0].shape, (0, n))
    assert (one.contributing > 100).all() and (one.values[..., 0] > 0).all()
    two = None
    for a, b in ((0, 5000), (5000, 17_000), (17_000, n)):
        part = bake_whole(room(threads=2), replace(options, ray_range=(a, b)), tail=watch)
        t = tail.of_core(part.stats["tail"], watch[0].shape, (0, n))
        two = t if two is None else two.add(t)
    assert two is not None
    assert np.array_equal(one.values, two.values)
    assert np.array_equal(one.contributing, two.contributing)


def test_a_progressive_bake_records_its_tail_and_keeps_its_bits():
    """The record says the fit (rays, bound, largest k̂); the shoebox's late tail is light, so
    the bake stops where the jackknife alone stops it (its rounds' sizes are those of the
    errors), and resumes and threads give the same bits (test_progressive)."""
    field, errors = progressive.bake(room(threads=2), accuracy=progressive.Accuracy(0.3))
    record = field.settings["progressive"]["errors"]["t30"]["tail"]
    assert record["rays"] > 0 and record["heavy"] == []
    assert record["k_max"] < tail.K_LIMIT
    assert errors.tail_k is not None and not errors.heavy_tail("t30").any()
