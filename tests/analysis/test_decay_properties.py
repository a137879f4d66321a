"""Property-based checks of the decay analysis on Monte-Carlo-like histograms (hypothesis).

A sound tracer's histogram is a sum of deposits: many per bin early on, fewer and heavier
later (rays die out or are sampled more thinly), and a few isolated deposits far down the
tail (down to 1e-17 of the peak). Here the deposits are Poisson counts whose weights keep the
expected energy of every bin exact, so the expected EDC is the closed form: whatever the
sampling, the analysis must find the closed form's times (within a stated tolerance) or say
why it cannot, never a finite wrong value. The sampling density before the thinning starts,
2 million deposits per second, puts 100 000 deposits or more into the shortest range (EDT of
T60 = 0.3 s: 50 ms). Over 20 draws at T60 = 0.3 s the fits scattered by 0.16 % (EDT), 0.08 %
(T20) and 0.06 % (T30) rms, at most 0.4 %: the 1 % tolerance checks the analysis, not the
noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sonolux.analysis.decay import (
    CURVATURE_LIMIT_PERCENT,
    DECAY_RANGES_DB,
    XI_LIMIT_PERMILLE,
    decay_times,
)
from tests.analysis.test_decay import decay_histogram, nonuniform_axis, tau_of

DENSE_RATE_PER_S = 2_000_000.0
PROPERTY_SETTINGS = settings(max_examples=30, deadline=None, derandomize=True,
                             suppress_health_check=[HealthCheck.too_slow])


def monte_carlo(expected, start, width, cutoff_s, thinning_s, isolated, seed):
    """One Monte-Carlo-like realisation of the bin totals ``expected``: Poisson counts with a
    mean of DENSE_RATE_PER_S × width before cutoff_s, thinning as exp(-(t - cutoff)/thinning_s)
    after; each deposit weighs expected / mean, so every bin's expectation is exact. Then
    ``isolated`` = [(time_s, fraction of the peak bin)] deposits are added on top."""
    rng = np.random.default_rng(seed)
    mean = DENSE_RATE_PER_S * width * np.exp(-np.clip(start - cutoff_s, 0.0, None) / thinning_s)
    mean = np.maximum(mean, 1e-300)
    counts = rng.poisson(mean)
    energy = counts * (expected / mean)
    peak = energy.max()
    for time_s, fraction in isolated:
        k = min(np.searchsorted(start, time_s), start.size - 1)
        energy[k] += fraction * peak
    return energy


def isolated_deposits():
    return st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(-17.0, -12.0)), max_size=6)


@PROPERTY_SETTINGS
@given(t60_s=st.floats(0.3, 3.0), drop_db=st.floats(75.0, 90.0),
       cutoff_db=st.floats(-70.0, -50.0), thinning=st.floats(0.03, 0.3),
       isolated=isolated_deposits(), float32=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_single_slope_with_sparse_tail_gives_exact_times(t60_s, drop_db, cutoff_db, thinning,
                                                        isolated, float32, seed):
    # EDT, T20 and T30 within 1 % of T60, from float32 or float64 bin totals, whatever the
    # thinning and the isolated deposits after the cut-off (the issue's -1e-13 dB/s fits).
    # Limits of the draw, so that the sampling's own noise stays well under 1 %: as counts
    # thin, each deposit weighs more, and a few heavy ones carry the energy after the cut-off.
    # A cut-off at -50 dB or lower keeps that energy under 5 % of the EDC at T30's end, a
    # thinning time of 3 % of T60 or more keeps thousands of deposits in it, and a record
    # 75 dB long or more keeps the record's end 20 dB below the truncation check's limit,
    # which a single heavy deposit in the last 10 % could otherwise reach (seen: -70 dB
    # records read -51 dB with a thinning time of 1.6 % of T60).
    duration_s = t60_s * drop_db / 60.0
    start, width = nonuniform_axis(duration_s)
    expected = decay_histogram(start, width, [(1.0, t60_s)])
    cutoff_s = t60_s * -cutoff_db / 60.0
    late = [(cutoff_s + u * (duration_s - cutoff_s), 10.0**v) for u, v in isolated]
    energy = monte_carlo(expected, start, width, cutoff_s, thinning * t60_s, late, seed)
    if float32:
        energy = energy.astype(np.float32)
    got = decay_times(energy, start, width)
    for name in DECAY_RANGES_DB:
        assert got[f"{name}_reason"] == ""
        assert got[f"{name}_s"] == pytest.approx(t60_s, rel=0.01), name


@PROPERTY_SETTINGS
@given(t60_s=st.floats(0.3, 3.0), end_db=st.floats(-60.0, -8.0), float32=st.booleans(),
       isolated=isolated_deposits(), seed=st.integers(0, 2**32 - 1))
def test_short_record_gives_exact_times_or_a_reason(t60_s, end_db, float32, isolated, seed):
    # A record that ends before the decay does (its power end_db below the start): each time
    # is within 1 % of T60 or NaN with a reason, never a finite wrong value.
    duration_s = t60_s * -end_db / 60.0
    start, width = nonuniform_axis(max(duration_s, 0.1))
    expected = decay_histogram(start, width, [(1.0, t60_s)])
    late = [(u * start[-1], 10.0**v) for u, v in isolated]
    energy = monte_carlo(expected, start, width, start[-1], 1.0, late, seed)
    got = decay_times(energy.astype(np.float32) if float32 else energy, start, width)
    for name in DECAY_RANGES_DB:
        value, reason = got[f"{name}_s"], got[f"{name}_reason"]
        assert (math.isnan(value) and reason) or (
            reason == "" and value == pytest.approx(t60_s, rel=0.01)), (name, value, reason)


def closed_form(slopes, duration_s):
    """ISO fits through the exact EDC of sum(A exp(-t/tau)) by plain least squares over
    400 000 uniform points per range: {name: (T, ξ ‰)} and the curvature C in %."""
    out = {}
    t_end = duration_s
    for name, (upper, lower) in DECAY_RANGES_DB.items():
        t = np.linspace(0.0, t_end, 400_001)
        edc = sum(a * tau_of(t60) * np.exp(-t / tau_of(t60)) for a, t60 in slopes)
        db = 10.0 * np.log10(edc / edc[0])
        sel = (db <= upper) & (db >= lower)
        t_sel = t[sel]
        t = np.linspace(t_sel[0], t_sel[-1], 400_001)  # refine over the range itself
        edc = sum(a * tau_of(t60) * np.exp(-t / tau_of(t60)) for a, t60 in slopes)
        db = 10.0 * np.log10(edc / sum(a * tau_of(t60) for a, t60 in slopes))
        slope = np.polyfit(t, db, 1)[0]
        r = np.corrcoef(t, db)[0, 1]
        out[name] = (-60.0 / slope, 1000.0 * (1.0 - r * r))
    return out, 100.0 * (out["t30"][0] / out["t20"][0] - 1.0)


@PROPERTY_SETTINGS
@given(t1_s=st.floats(0.3, 1.5), ratio=st.floats(1.2, 4.0), second_db=st.floats(-40.0, -10.0),
       thinning=st.floats(0.03, 0.3), isolated=isolated_deposits(), float32=st.booleans(),
       seed=st.integers(0, 2**32 - 1))
def test_double_slope_matches_closed_form_or_says_why(t1_s, ratio, second_db, thinning,
                                                     isolated, float32, seed):
    # Two exponentials, the second (slower) one second_db below the first in the EDC at t=0.
    # Where the closed form passes ISO 3382-2 Annex B's checks with 20 % to spare, the time
    # is defined and within 1 % of it; where it fails them by 20 %, the time is NaN with a
    # reason; in between either is right. The slower slope sets the record: 80 dB of it;
    # the thinning starts 60 dB or more down (limits as in the single-slope test).
    t2_s = ratio * t1_s
    a2 = 10.0 ** (second_db / 10.0) * tau_of(t1_s) / tau_of(t2_s)
    slopes = [(1.0, t1_s), (a2, t2_s)]
    duration_s = t2_s * (80.0 + second_db) / 60.0 + 0.5
    start, width = nonuniform_axis(duration_s)
    expected = decay_histogram(start, width, slopes)
    cutoff_s = duration_s * 0.7
    late = [(cutoff_s + u * (duration_s - cutoff_s), 10.0**v) for u, v in isolated]
    energy = monte_carlo(expected, start, width, cutoff_s, thinning * t2_s, late, seed)
    got = decay_times(energy.astype(np.float32) if float32 else energy, start, width)
    exact, curvature = closed_form(slopes, duration_s)
    for name in DECAY_RANGES_DB:
        t_exact, xi_exact = exact[name]
        # EDT has no linearity check (decay.py): it is always defined here.
        passes = name == "edt" or xi_exact < 0.8 * XI_LIMIT_PERMILLE
        fails = name != "edt" and xi_exact > 1.2 * XI_LIMIT_PERMILLE
        if name == "t30":
            passes = passes and abs(curvature) < 0.8 * CURVATURE_LIMIT_PERCENT
            fails = fails or abs(curvature) > 1.2 * CURVATURE_LIMIT_PERCENT
        value, reason = got[f"{name}_s"], got[f"{name}_reason"]
        if passes:
            assert reason == "" and value == pytest.approx(t_exact, rel=0.01), (name, reason)
        elif fails:
            assert math.isnan(value) and reason, (name, value)
        else:
            assert (math.isnan(value) and reason) or value == pytest.approx(t_exact, rel=0.01)


@PROPERTY_SETTINGS
@given(t60_s=st.floats(0.3, 3.0), n_directions=st.integers(2, 16),
       seed=st.integers(0, 2**32 - 1))
def test_summation_order_does_not_matter(t60_s, n_directions, seed):
    # A receiver's direction bins, float32 as the field stores them, summed in float32 in
    # one order and in float64 in another: the parameters agree within 0.1 % (the issue's
    # case flipped with the order).
    start, width = nonuniform_axis(t60_s * 80.0 / 60.0)
    expected = decay_histogram(start, width, [(1.0, t60_s)]) / n_directions
    rng = np.random.default_rng(seed)
    parts = np.stack([monte_carlo(expected, start, width, t60_s * 50 / 60, 0.05 * t60_s,
                                  [(t60_s * 1.2, 1e-15)], int(s))
                      for s in rng.integers(0, 2**32, n_directions)]).astype(np.float32)
    forward = parts.sum(axis=0, dtype=np.float32)
    backward = parts[::-1].sum(axis=0, dtype=np.float64)
    a, b = decay_times(forward, start, width), decay_times(backward, start, width)
    for name in DECAY_RANGES_DB:
        assert a[f"{name}_s"] == pytest.approx(b[f"{name}_s"], rel=0.001)
