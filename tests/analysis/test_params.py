"""ISO 3382-1 parameters of whole sound fields against closed forms, against the per-trace
functions of ``decay`` (already checked there), and against pyrato on the same impulse
responses. Every tolerance says why."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from sonolux.analysis import params as params_module
from sonolux.analysis.decay import decay_times, strength_g_db
from sonolux.analysis.params import lateral_weights, room_parameters
from tests.analysis.fields import decaying_grid, synthetic_field
from tests.analysis.test_decay import (
    FS_HZ,
    TWO_SLOPES,
    analytic_times,
    decay_histogram,
    nonuniform_axis,
    tau_of,
)

T60S = (0.6, 1.3, 2.0)


def test_exponential_decays_give_their_parameters_everywhere():
    field, start, width = decaying_grid(T60S)
    p = room_parameters(field, theory=False)
    assert p.columns == ["500", "1000", "broadband"]
    for k, t60 in enumerate(T60S):
        tau = tau_of(t60)
        # A pure exponential: every decay time is T60 (0.5 %, as for one trace in test_decay),
        # and the energy ratios are their closed forms (onset at 0, the first bin is the peak).
        for name in ("edt_s", "t20_s", "t30_s"):
            np.testing.assert_allclose(p.values[name][k], t60, rtol=0.005)
        np.testing.assert_allclose(p.values["c80_db"][k], 10 * math.log10(math.exp(0.08 / tau) - 1),
                                   atol=0.002)
        np.testing.assert_allclose(p.values["c50_db"][k], 10 * math.log10(math.exp(0.05 / tau) - 1),
                                   atol=0.002)
        np.testing.assert_allclose(p.values["d50"][k], 1 - math.exp(-0.05 / tau), atol=1e-4)
        np.testing.assert_allclose(p.values["ts_s"][k], tau, rtol=1e-4)
        # G: the total energy against W / (4π 10²); float32 storage, so 1e-5 dB.
        total = float(field.energy[k].sum(dtype=np.float64)) / 2  # 2 bands, each the whole
        np.testing.assert_allclose(p.values["g_db"][k], strength_g_db(total, 1.0), atol=1e-5)
    assert not any(r for reasons in p.reasons.values() for r in reasons.ravel())


def test_two_slope_decay_through_a_field():
    # The two-slope decay of test_decay, as a one-receiver field: EDT and T30 agree with the
    # dense independent regression within 0.5 % (the tolerance of the per-trace test).
    start, width = nonuniform_axis(5.0)
    e = decay_histogram(start, width, TWO_SLOPES)
    field = synthetic_field(np.broadcast_to(e / 8, (1, 8, 2, e.size)), start, width,
                            [(1.0, 1.25, 1.5)])
    p = room_parameters(field, theory=False)
    ref = analytic_times(TWO_SLOPES)
    np.testing.assert_allclose(p.values["edt_s"][0], ref["edt"], rtol=0.005)
    np.testing.assert_allclose(p.values["t30_s"][0], ref["t30"], rtol=0.005)


def test_broadband_is_the_mean_of_the_bands():
    # Band 500 Hz decays with T60 0.5 s, band 1 kHz with 2 s: the broadband histogram is their
    # mean (each band carries the source's full energy), a two-slope decay.
    start, width = nonuniform_axis(6.0)
    bands = np.stack([decay_histogram(start, width, [(1.0, 0.5)]),
                      decay_histogram(start, width, [(1.0, 2.0)])])
    field = synthetic_field(np.broadcast_to(bands / 8, (1, 8, *bands.shape)), start, width,
                            [(1.0, 1.25, 1.5)])
    p = room_parameters(field, theory=False)
    mean = field.energy[0].sum(axis=0, dtype=np.float64).mean(axis=0)
    direct = decay_times(mean, start, width)
    assert p.values["t30_s"][0, -1] == pytest.approx(direct["t30_s"], rel=1e-12)
    ref = analytic_times([(0.5, 0.5), (0.5, 2.0)])
    assert p.values["edt_s"][0, -1] == pytest.approx(ref["edt"], rel=0.005)
    assert p.values["t30_s"][0, -1] == pytest.approx(ref["t30"], rel=0.005)
    np.testing.assert_allclose(p.values["t30_s"][0, :2], [0.5, 2.0], rtol=0.005)
    assert p.values["g_db"][0, -1] == pytest.approx(strength_g_db(mean.sum(), 1.0), abs=1e-9)


def test_receivers_at_once_equal_one_at_a_time(monkeypatch):
    # Chunks of 2 receivers, 5 receivers: the same numbers as each alone (to rounding).
    monkeypatch.setattr(params_module, "_CHUNK", 2)
    field, _, _ = decaying_grid((0.5, 0.9, 1.3, 1.7, 2.1), duration_s=2.5)
    field.energy[:, 2] *= 3.0  # some direction dependence, for JLF
    every = room_parameters(field, theory=False)
    for k in range(field.n_receivers):
        one = room_parameters(field, [k], theory=False)
        for name, values in every.values.items():
            np.testing.assert_allclose(one.values[name][0], values[k], rtol=1e-12, err_msg=name)
    assert every.values["t30_s"].shape == (5, 3)


# --- the lateral fraction ---------------------------------------------------------------------


def test_lateral_weights_closed_forms():
    h = math.pi / 8  # half of a 45° sector
    spread = math.sin(2 * h) / (4 * h)  # mean of cos 2x over the sector, halved
    w = lateral_weights(8, 1, 0.0)  # source straight ahead (+x)
    # Mean of sin² over a sector centred at c: 1/2 - cos(2c) sin(2h) / (4h); elevation 2/3.
    np.testing.assert_allclose(w[2], (0.5 + spread) * 2 / 3, rtol=1e-4)  # left
    np.testing.assert_allclose(w[0], (0.5 - spread) * 2 / 3, rtol=1e-3)  # front
    np.testing.assert_allclose(w[1], 1 / 3, rtol=1e-4)  # front-left: c = 45°
    # A diffuse field gives 1/3 (cos²) and 1/2 (|cos|) for any source direction and bins.
    for az in (0.0, 0.3, 2.0):
        for n_el in (1, 3):
            assert lateral_weights(8, n_el, az).mean() == pytest.approx(1 / 3, rel=1e-4)
            assert lateral_weights(8, n_el, az, power=1).mean() == pytest.approx(0.5, rel=1e-3)
    # Three elevation bands of equal solid angle: mean cos² of the middle one is 26/27.
    w3 = lateral_weights(8, 3, 0.0).reshape(3, 8)
    np.testing.assert_allclose(w3[1] / w3[0], (26 / 27) / (14 / 27), rtol=1e-4)
    # Vectorised over receivers.
    assert lateral_weights(8, 1, np.zeros(4)).shape == (4, 8)


def arrivals_field(events, receiver=(1.0, 1.25, 1.5), source=(3.0, 1.25, 1.5)):
    """One receiver; events = [(time_s, direction index, energy)] in one-sample bins."""
    start, width = nonuniform_axis(0.5)
    e = np.zeros((1, 8, 1, start.size))
    for t, d, energy in events:
        e[0, d, 0, np.searchsorted(start, t + 0.1 / FS_HZ) - 1] += energy
    return synthetic_field(e, start, width, [receiver], source_m=source, bands_hz=(1000.0,))


def test_early_lateral_fraction_of_known_arrivals():
    # Source ahead (+x). Direct sound 1 at 5.8 ms from the front; 0.5 from the left 20 ms
    # later, 0.25 from the front-right 40 ms later, 0.3 from the right 100 ms later (outside
    # the 80 ms window). JLF = (0.5 w_left + 0.25 w_front-right) / 1.75.
    t0 = round(2.0 / 343.2 * FS_HZ) / FS_HZ
    field = arrivals_field([(t0, 0, 1.0), (t0 + 0.020, 2, 0.5), (t0 + 0.040, 7, 0.25),
                            (t0 + 0.100, 6, 0.3)])
    p = room_parameters(field, theory=False)
    w2, w1 = lateral_weights(8, 1, 0.0), lateral_weights(8, 1, 0.0, power=1)
    assert p.values["jlf"][0, 0] == pytest.approx((0.5 * w2[2] + 0.25 * w2[7]) / 1.75, rel=1e-6)
    assert p.values["jlfc"][0, 0] == pytest.approx((0.5 * w1[2] + 0.25 * w1[7]) / 1.75, rel=1e-6)
    # An arrival within 5 ms of the direct sound is not lateral energy (ISO 3382-1 A.2.4).
    early = arrivals_field([(t0, 0, 1.0), (t0 + 0.004, 2, 0.5)])
    assert room_parameters(early, theory=False).values["jlf"][0, 0] == pytest.approx(0.0, abs=1e-12)


def test_lateral_fraction_is_undefined_where_the_source_is_inside_the_receiver():
    field = arrivals_field([(0.0, 0, 1.0), (0.02, 2, 0.5)], receiver=(3.0, 1.25, 1.5))
    p = room_parameters(field, theory=False)
    assert np.isnan(p.values["jlf"][0, 0]) and np.isnan(p.values["jlfc"][0, 0])
    assert any("sphere holds the source" in n for n in p.notes)


def test_directional_strengths_add_up_to_the_total():
    field, _, _ = decaying_grid((0.8,), duration_s=2.0)
    field.energy[0] *= np.arange(1, 9, dtype=np.float32)[:, None, None]
    p = room_parameters(field, directional=True, theory=False)
    g_dir = p.directional["g_db"][0]  # [direction, column]
    np.testing.assert_allclose(10 * np.log10((10 ** (g_dir / 10)).sum(axis=0)), p.values["g_db"][0],
                               atol=1e-9)
    np.testing.assert_allclose(p.directional["t30_s"][0], 0.8, rtol=0.005)


def test_summary_over_receivers_skips_undefined_values():
    field, _, _ = decaying_grid(T60S)
    p = room_parameters(field, theory=False)
    p.values["t30_s"][1, 0] = np.nan
    s = p.summary()["t30_s"]
    assert s["count"][0] == 2 and s["mean"][0] == pytest.approx(np.mean(p.values["t30_s"][[0, 2], 0]))
    assert s["min"][1] == pytest.approx(0.6, rel=0.005) and s["max"][1] == pytest.approx(2.0, rel=0.005)


def test_theory_comes_from_the_scene_when_it_can_be_loaded(core):
    from sonolux.scene import load_scene
    from sonolux.scene.summary import summarize

    field, _, _ = decaying_grid((0.8,), duration_s=1.0, bands=7)  # paper-small's 125 Hz-8 kHz
    field.scene_name, field.scene_origin = "paper-small", "built-in paper-small"
    p = room_parameters(field)
    expected = summarize(load_scene("paper-small"))
    assert p.theory["sabine_t60_s"] == expected["sabine_t60_s"]
    assert p.theory["eyring_t60_s"] == expected["eyring_t60_s"]
    field.scene_origin = "/nowhere/room.toml"
    p = room_parameters(field)
    assert p.theory == {} and any("could not be loaded" in n for n in p.notes)
    field.scene_origin, field.settings["volume_m3"] = "built-in paper-small", 99.0
    assert any("changed since the bake" in n for n in room_parameters(field).notes)


# --- an independent implementation on the same impulse responses ------------------------------


def _pyrato(pf, ra, signal):
    """pyrato's parameters of a pyfar Signal, one value per channel."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # Per channel (channel_independent), else every channel is normalised to the loudest.
        edc = ra.edc.energy_decay_curve_chu_lundeby(signal, time_shift=False,
                                                    channel_independent=True)
        iso = ra.edc.energy_decay_curve_chu_lundeby(signal, channel_independent=True)
        out = {f"{k.lower()}_s": ra.parameters.reverberation_time_linear_regression(
            edc, k).ravel() for k in ("EDT", "T20", "T30")}
        out.update(c50_db=ra.parameters.clarity(iso, 50).ravel(),
                   c80_db=ra.parameters.clarity(iso, 80).ravel(),
                   d50=ra.parameters.definition(iso, 50).ravel(),
                   ts_s=ra.parameters.center_time(iso).ravel())
    return out


def _ours(samples, fs, position_m, source_m, compensation="lundeby"):
    """sonolux's parameters of signals float[channel, n] as a one-receiver field whose bands
    are the channels, on the tracer's non-uniform axis: {name: float[channel]}. The signals
    carry a noise floor (added below), so Lundeby's compensation is chosen explicitly."""
    n = samples.shape[-1]
    start, width = nonuniform_axis(n / fs)
    idx = np.round(np.append(start, n / fs) * fs).astype(int)
    e = np.add.reduceat(samples**2 / fs, idx[:-1], axis=1)
    same = synthetic_field(e[None, None], start, width, [position_m], source_m=source_m,
                           bands_hz=tuple(125.0 * 2**k for k in range(e.shape[0])),
                           azimuth_bands=1)
    p = room_parameters(same, theory=False, compensation=compensation)
    return {k: v[0, :-1] for k, v in p.values.items()}


@pytest.mark.slow
def test_parameters_match_pyrato_on_the_fields_impulse_responses(core):
    # The pressure IR of a baked paper room (field.impulse_response) with a noise floor 10 dB
    # under its last 100 ms and 0.5 s more of it: whole, and split into octaves by pyfar.
    # pyrato sees the signals (Chu + Lundeby per channel; the ISO start for the energy ratios);
    # sonolux sees the same signals as energy histograms on its non-uniform axis, in a
    # SoundField. Measured: T20 and T30 agree within 0.1 %, EDT within 2 % (5.6 % at 125 Hz,
    # see below), C50/C80 within 0.01 dB, D50 within 0.001, Ts within 0.1 ms: far below the
    # JNDs (5 %, 1 dB, 0.05, 10 ms). The energy ratios are compared on the whole IR only: in
    # octaves pyrato finds a later start per band (the filter's delay), sonolux one per cell.
    pf = pytest.importorskip("pyfar", reason="pyfar/pyrato not installed: pip install pyrato")
    ra = pytest.importorskip("pyrato", reason="pyrato not installed: pip install pyrato")
    import sonolux

    field = sonolux.bake(sonolux.load_scene("paper-medium"), estimator="paper", rays=40_000)
    fs = field.sample_rate_hz
    n = int(round((field.settings["max_time_s"] + 0.5) * fs))
    rng = np.random.default_rng(5)
    for xy in ((2.0, 0.5), (10.0, 4.0)):
        r = field.cell_at(*xy)
        ir = field.impulse_response(r, seed=3)
        x = np.zeros(n)
        x[: ir.size] = ir
        x += rng.standard_normal(n) * math.sqrt(0.1 * np.mean(ir[-int(0.1 * fs):] ** 2))
        where = (field.positions_m[r], field.source_positions_m[0])
        whole = pf.Signal(x, fs)
        ours, theirs = _ours(x[None], fs, *where), _pyrato(pf, ra, whole)
        tolerance = {"t20_s": 0.001, "t30_s": 0.001, "edt_s": 0.02, "c50_db": 0.02,
                     "c80_db": 0.02, "d50": 0.001, "ts_s": 2e-4}
        for name, tol in tolerance.items():
            print(f"{xy} whole {name}: sonolux {ours[name][0]:.5f}, pyrato {theirs[name][0]:.5f}")
            if name == "t30_s" and not np.isfinite(ours[name][0]):
                # sonolux refuses a T30 whose decay is curved (ISO 3382-2 Annex B: C =
                # 100 (T30/T20 - 1) above 10 %); pyrato gives a number. The refusal must be
                # justified by pyrato's own T30 and T20 (above 0.8 of the limit; measured at
                # (10, 4): 10.8 %).
                curvature_pct = 100 * (theirs["t30_s"][0] / theirs["t20_s"][0] - 1)
                assert curvature_pct > 8.0, (xy, curvature_pct)
                continue
            rel = name.startswith(("t", "e")) and name != "ts_s"
            assert ours[name][0] == pytest.approx(theirs[name][0], **(
                {"rel": tol} if rel else {"abs": tol})), (xy, name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            octaves = pf.dsp.filter.fractional_octave_bands(whole, 1, frequency_range=(125, 4000))
        ours = _ours(octaves.time.reshape(-1, n), fs, *where)
        theirs = _pyrato(pf, ra, octaves)
        for name in ("edt_s", "t20_s", "t30_s"):
            print(f"{xy} octaves {name}: sonolux {np.round(ours[name], 4)}, "
                  f"pyrato {np.round(theirs[name], 4)}")
        # Where sonolux refuses a fit (here T30 at 250 Hz: a curved decay, ξ > 10 ‰, or a
        # double slope), pyrato still gives a number; the rest agree.
        for name in ("t20_s", "t30_s"):
            ok = np.isfinite(ours[name])
            assert ok.sum() >= ok.size - 1, (name, ours[name])
            np.testing.assert_allclose(ours[name][ok], theirs[name][ok], rtol=0.001)
        # EDT spans only 10 dB, where the start of the fit (pyrato: from t = 0; sonolux: from
        # where the curve leaves 0 dB) weighs most: measured within 2 %, so 3 %.
        np.testing.assert_allclose(ours["edt_s"][1:], theirs["edt_s"][1:], rtol=0.03)
        # EDT at 125 Hz: the octave filter rounds the curve's first dB; pyrato regresses from
        # t = 0, sonolux from where the curve leaves 0 dB: 5.6 % apart here, so 10 %.
        assert ours["edt_s"][0] == pytest.approx(theirs["edt_s"][0], rel=0.10)


# --- checks and the consistency across receivers ------------------------------------------------


def scattered_grid(t60_s, scatter, odd=None, size=5, seed=0):
    """A size × size grid (1 m) whose receivers decay with T60 t60_s × (1 + scatter × N(0, 1)),
    like Monte Carlo noise; ``odd`` = (index, T60) gives one receiver another decay."""
    rng = np.random.default_rng(seed)
    start, width = nonuniform_axis(3.0)
    t60 = t60_s * (1.0 + scatter * rng.standard_normal(size * size))
    if odd is not None:
        t60[odd[0]] = odd[1]
    e = np.stack([decay_histogram(start, width, [(1.0, t)]) for t in t60])
    energy = np.broadcast_to(e[:, None, None, :] / 8, (e.shape[0], 8, 2, e.shape[-1]))
    index = [(i, j) for j in range(size) for i in range(size)]
    positions = [(1.0 + i, 1.0 + j, 1.5) for i, j in index]
    return synthetic_field(energy, start, width, positions, source_m=(0.3, 0.3, 1.5),
                           grid_index=index, spacing_m=1.0), t60


def test_a_receiver_that_stands_out_is_listed_with_a_cause():
    # 0.5 % scatter (Monte Carlo-like) around 1 s; receiver 12 decays in 1.3 s: 60 robust
    # sigmas off, and 30 % (over the 5 % JND). Without it, nothing is listed.
    field, _ = scattered_grid(1.0, 0.005)
    assert room_parameters(field, theory=False).outliers == []
    field, t60 = scattered_grid(1.0, 0.005, odd=(12, 1.3))
    p = room_parameters(field, theory=False)
    listed = {(o["receiver"], o["parameter"]) for o in p.outliers}
    assert {(12, "edt_s"), (12, "t20_s"), (12, "t30_s")} <= listed
    assert all(o["receiver"] == 12 for o in p.outliers)
    o = next(o for o in p.outliers if o["parameter"] == "t30_s")
    assert o["value"] == pytest.approx(1.3, rel=0.01)
    assert o["monte_carlo_sigma"] == pytest.approx(0.005, rel=0.6)  # the scatter, estimated
    assert "Monte Carlo" in o["cause"] or "local" in o["cause"]


def test_decay_slower_than_the_room_allows_is_refused():
    # T60 = 2 s in every receiver, but the room's bound says at most 1.5 s: refused, with the
    # reason in every cell; the parameters that need no fit are kept.
    field, _, _ = decaying_grid((2.0, 2.0, 2.0), duration_s=3.0)
    field.theory = {"air_attenuation_per_m": [0.0, 0.0], "min_absorption": [0.1, 0.1],
                    "max_chord_m": 343.2 * 1.5 * 0.1053605 / (6 * math.log(10)),
                    "speed_of_sound_m_s": 343.2, "sabine_t60_s": [1.0, 1.0],
                    "eyring_t60_s": [1.0, 1.0], "mean_absorption": [0.2, 0.2], "volume_m3": 30.0,
                    "area_m2": 64.0, "mean_free_path_m": 1.9}
    assert params_module.slowest_decay_s(field) == pytest.approx([1.5, 1.5, 1.5], rel=1e-5)
    p = room_parameters(field)
    assert np.isnan(p.values["t30_s"]).all()
    assert all(r.startswith("slower than physically possible") for r in p.reasons["t30"].ravel())
    assert np.isfinite(p.values["c80_db"]).all()
    assert any("undefined decay times" in n for n in p.notes)


def test_compensation_is_named_and_validated():
    field, _, _ = decaying_grid((1.0,), duration_s=2.0)
    assert room_parameters(field, theory=False).compensation == "none"
    assert room_parameters(field, theory=False, compensation="lundeby").compensation == "lundeby"
    with pytest.raises(ValueError, match="compensation must be one of"):
        room_parameters(field, compensation="chu")


def test_a_bake_carries_the_room_s_slowest_decay(core):
    # The bake's theory holds the least absorption and the bounding box's diagonal; the bound
    # they give is far above Sabine's T60 (every path a full diagonal long) and refuses none
    # of the paper room's fits.
    import sonolux
    from sonolux.scene.summary import theory

    scene = sonolux.load_scene("paper-small")
    t = theory(scene)
    span = scene.vertices_m.max(axis=0) - scene.vertices_m.min(axis=0)
    assert t["max_chord_m"] == pytest.approx(float(np.linalg.norm(span)))
    assert len(t["min_absorption"]) == len(t["bands_hz"])
    assert all(0 < a <= m for a, m in zip(t["min_absorption"], t["mean_absorption"]))
    field = sonolux.bake(scene, rays=3000)
    bound = params_module.slowest_decay_s(field)
    assert np.all(bound[:-1] > 2 * np.asarray(t["sabine_t60_s"]))
    p = room_parameters(field)
    assert not any(r.startswith("slower than") for r in p.reasons["t20"].ravel())
