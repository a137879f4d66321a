"""EDT and T20 of synthesised pressure responses against pyrato (an independent implementation).

The three paper rooms and a mesh room (examples/scenes/mesh_room.toml: an L-shaped OBJ with a
cupboard) are baked; at three receivers each, more than 1 m from the source, the pressure
response is synthesised (``field.impulse_response``), split into octaves 125 Hz-4 kHz by pyfar,
and analysed by both: pyrato by its plain Schroeder integral and its linear regression, sonolux
by the same samples' energy histogram on its non-uniform axis, one channel at a time (each
with its own onset), with the default analysis (the plain integral: a synthesised response has
no noise floor). Where sonolux refuses a fit, it gives its reason, which is checked to exist.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from sonolux.analysis import decay
from tests.analysis.test_params import _ours

ROOMS = ("paper-small", "paper-medium", "paper-large", "examples/scenes/mesh_room.toml")
#: pyrato starts EDT's regression at -0.1 dB (and ends it at -10.1 dB), ISO 3382-1 at 0 dB.
PYRATO_EDT_RANGE_DB = (-0.1, -10.1)


def _pyrato(pf, ra, signal):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        edc = ra.edc.schroeder_integration(signal)
        edc = pf.TimeData(edc.time / edc.time[..., :1], edc.times)  # pyrato fits 10 log10(edc)
        return {k: ra.parameters.reverberation_time_linear_regression(edc, k).ravel()
                for k in ("EDT", "T20")}


def _iso_edt_s(pf, ra, signal):
    """ISO 3382-1's EDT of each channel, computed here on pyrato's Schroeder curve: from the
    onset (the first sample within 20 dB of the peak power, ISO 3382-1 A.3.4) a least-squares
    line over 0 to -10 dB. pyrato's own EDT starts at -0.1 dB, which skips the onset instead."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        edc = ra.edc.schroeder_integration(signal)
    t = np.asarray(edc.times)
    power = np.asarray(signal.time).reshape(-1, t.size) ** 2
    out = []
    for curve, p in zip(np.asarray(edc.time).reshape(-1, t.size), power):
        onset = int(np.argmax(p >= 0.01 * p.max()))
        db = 10 * np.log10(np.maximum(curve[onset:] / curve[onset], 1e-300))
        end = int(np.argmax(db < -10.0))
        out.append(-60.0 / np.polyfit(t[onset:onset + end], db[:end], 1)[0])
    return np.array(out)


def _xi_permille(pf, ra, signal, lo_db=-5.0, hi_db=-25.0):
    """ISO 3382-2 Annex B's non-linearity ξ = 1000 (1 − r²) of the T20 range of each channel's
    Schroeder curve, computed here from pyrato's curve (independently of sonolux's fit); inf
    where the curve does not reach the range."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        edc = ra.edc.schroeder_integration(signal)
    t = np.asarray(edc.times)
    out = []
    for curve in np.asarray(edc.time).reshape(-1, t.size):
        db = 10 * np.log10(np.maximum(curve / curve[0], 1e-300))
        sel = (db <= lo_db) & (db >= hi_db)
        out.append(1000 * (1 - np.corrcoef(t[sel], db[sel])[0, 1] ** 2)
                   if sel.sum() > 2 and db.min() < hi_db else np.inf)
    return np.array(out)


def _channels(pf, ir, fs):
    """float[7, n]: the whole response, then its octaves 125 Hz to 4 kHz (pyfar)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        octaves = pf.dsp.filter.fractional_octave_bands(pf.Signal(ir, fs), 1,
                                                       frequency_range=(125, 4000))
    return np.concatenate([ir[None], octaves.time.reshape(-1, ir.size)])


def _sonolux(x, fs, position_m, source_m):
    """EDT, T20 and their reasons of each channel of x, analysed as a one-band field."""
    out = {"edt_s": [], "t20_s": []}
    for k in range(x.shape[0]):
        got = _ours(x[k:k + 1], fs, position_m, source_m, compensation="none")
        for name in out:
            out[name].append(got[name][0])
    return {k: np.array(v) for k, v in out.items()}


@pytest.mark.slow
@pytest.mark.parametrize("room", ROOMS)
def test_edt_and_t20_match_pyrato(core, room, monkeypatch):
    # Measured (20 000 rays, seed 3 synthesis): with pyrato's EDT range, EDT within 0.5 % and
    # T20 within 0.05 % wherever sonolux defines them; tolerance 2 % (the issue's). With the
    # ISO range (0 dB start), EDT is compared with the same range fitted here to pyrato's curve
    # (pyrato's EDT starts at -0.1 dB: in the 125-500 Hz octaves the filter rounds the curve's
    # first tenth of a dB, and the two definitions differed by up to 5.3 % there); tolerance 2 %.
    # Some T20s are refused as curved (ξ > 10 ‰): in paper-large up to 10 of 21 (its walls
    # reflect 95 % and its floor 70 %: a non-diffuse room whose decays bend; the broadband
    # channel also mixes the 8 kHz octave's fast decay with the slow ones). So that refusing is
    # not a way out, every refusal must be justified by an independent ξ from pyrato's own
    # Schroeder curve above 0.8 of the limit (measured: every refused one at 10.3-41.8 ‰, every
    # defined one at most 9.8 ‰; the two curves differ in their first bins), and at
    # least one T20 per receiver must be defined.
    pf = pytest.importorskip("pyfar", reason="pyfar/pyrato not installed: pip install pyrato")
    ra = pytest.importorskip("pyrato", reason="pyrato not installed: pip install pyrato")
    import sonolux

    field = sonolux.bake(sonolux.load_scene(room), rays=20_000)
    fs = field.sample_rate_hz
    distance_m = np.linalg.norm(field.positions_m - field.source_positions_m[0], axis=1)
    far = np.nonzero(distance_m > 1.0)[0]
    for r in far[np.linspace(0, far.size - 1, 3).astype(int)]:
        x = _channels(pf, field.impulse_response(r, seed=3), fs)
        where = (field.positions_m[r], field.source_positions_m[0])
        theirs = _pyrato(pf, ra, pf.Signal(x, fs))
        iso = _sonolux(x, fs, *where)
        with monkeypatch.context() as m:
            m.setitem(decay.DECAY_RANGES_DB, "edt", PYRATO_EDT_RANGE_DB)
            same = _sonolux(x, fs, *where)
        print(f"{room} #{r}: EDT {np.round(iso['edt_s'], 3)} (pyrato's range "
              f"{np.round(same['edt_s'], 3)}), pyrato {np.round(theirs['EDT'], 3)}; "
              f"T20 {np.round(iso['t20_s'], 3)}, pyrato {np.round(theirs['T20'], 3)}")
        ok = np.isfinite(same["edt_s"])
        assert ok.all(), "EDT is defined for every channel of these rooms"
        np.testing.assert_allclose(same["edt_s"], theirs["EDT"], rtol=0.02)
        np.testing.assert_allclose(iso["edt_s"], _iso_edt_s(pf, ra, pf.Signal(x, fs)), rtol=0.02)
        ok = np.isfinite(iso["t20_s"])
        np.testing.assert_allclose(iso["t20_s"][ok], theirs["T20"][ok], rtol=0.02)
        xi = _xi_permille(pf, ra, pf.Signal(x, fs))
        assert np.all(xi[~ok] > 0.8 * decay.XI_LIMIT_PERMILLE), (xi, ok)
        assert ok.any()
