"""Octave results from third-octave fields by adding energy (sonolux.analysis.octaves), and STI
of a third-octave field from those octaves."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.acoustics.bands import DEFAULT_THIRDS_HZ
from sonolux.analysis.octaves import _summed_t60, octave_field
from sonolux.analysis.params import room_parameters
from sonolux.analysis.sti import SpeechSettings, field_sti
from sonolux.errors import AnalysisError
from tests.analysis.fields import synthetic_field
from tests.analysis.test_decay import decay_histogram, nonuniform_axis

THIRDS_STI = (100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250, 1600, 2000, 2500,
              3150, 4000, 5000, 6300, 8000, 10000)


def thirds_field(t60_by_band_s, bands_hz):
    """One receiver, 8 directions, each third decaying with its own T60 from 1 J/m²."""
    start, width = nonuniform_axis(3.0)
    e = np.stack([decay_histogram(start, width, [(1.0, t)]) for t in t60_by_band_s])
    energy = np.broadcast_to(e[None, None] / 8, (1, 8) + e.shape)
    field = synthetic_field(energy, start, width, [(2.0, 1.25, 1.5)], bands_hz=bands_hz)
    field.settings["bands"] = "third-octave"
    return field


def test_octaves_are_the_sums_of_their_thirds_and_their_times_those_of_the_sum():
    # Three thirds of an octave decaying with T60 1.0, 1.2 and 1.5 s: the octave's histogram is
    # their sum exactly (float32 of a float64 sum: 1e-7), and its T30 is that of the summed
    # curve, which the closed form of _summed_t60 gives (the fit on the binned curve within
    # 1 %: the fit is a straight line through a slightly curved decay), not the mean of the
    # three times (1.233 s), which is 10 % short.
    t60 = [1.0, 1.2, 1.5] * 6
    field = thirds_field(t60, DEFAULT_THIRDS_HZ)
    octaves = octave_field(field)
    assert list(octaves.bands_hz) == [125, 250, 500, 1000, 2000, 4000]
    assert octaves.band_set.kind == "octave"
    np.testing.assert_allclose(octaves.energy[:, :, 0],
                               field.energy[:, :, 0:3].sum(axis=2, dtype=np.float64), rtol=1e-6)
    t30 = room_parameters(octaves, theory=False, sti=False).values["t30_s"][0, :-1]
    expected = _summed_t60([1.0, 1.2, 1.5])
    # The closed form against a numerical Schroeder integral of the sum on a 0.1 ms grid.
    t = np.arange(0, 6.0, 1e-4)
    e = sum(np.exp(-6 * np.log(10) * t / T) for T in (1.0, 1.2, 1.5))
    level = 10 * np.log10(np.cumsum(e[::-1])[::-1] / e.sum())
    crossing = [np.interp(-x, -level, t) for x in (-5.0, -35.0)]
    assert expected == pytest.approx(2 * (crossing[1] - crossing[0]), rel=1e-3)
    np.testing.assert_allclose(t30, expected, rtol=0.01)
    # Averaging the three times would say 1.233 s: 10 % short of the summed energy's 1.37 s.
    assert expected / np.mean([1.0, 1.2, 1.5]) - 1 > 0.09


def test_only_whole_octaves_are_kept_and_only_thirds_are_summed():
    # 80 Hz … 5 kHz: 63 Hz lacks its 50 and 63 Hz thirds and 8 kHz all of its own: left out.
    bands = (80,) + tuple(DEFAULT_THIRDS_HZ)
    octaves = octave_field(thirds_field([1.0] * len(bands), bands))
    assert list(octaves.bands_hz) == [125, 250, 500, 1000, 2000, 4000]
    octave = thirds_field([1.0] * 6, DEFAULT_THIRDS_HZ[:6])
    octave.settings["bands"] = "octave"
    with pytest.raises(AnalysisError, match="need a third-octave field"):
        octave_field(octave)


def test_sti_of_thirds_is_the_sti_of_their_summed_octaves():
    # The STI of a third-octave field uses octaves summed from thirds (IEC 60268-16 works on
    # octaves): it equals the STI of the octave field made by octave_field, to rounding; a
    # thirds field that stops at 5 kHz cannot make the 8 kHz octave and says so.
    t60 = np.linspace(1.6, 0.5, len(THIRDS_STI))
    field = thirds_field(t60, THIRDS_STI)
    sti_thirds, why = field_sti(field, [0])
    assert why == ""
    sti_octaves, _ = field_sti(octave_field(field), [0])
    np.testing.assert_allclose(sti_thirds, sti_octaves, rtol=1e-6)
    assert 0.3 < sti_thirds[0] < 0.8
    _, why = field_sti(thirds_field(t60[:18], DEFAULT_THIRDS_HZ), [0])
    assert "8000" in why
    p = room_parameters(field, theory=False)
    assert p.sti is not None and p.sti[0] == pytest.approx(sti_thirds[0])
    quiet, noisy = (room_parameters(field, theory=False, speech=s).sti[0]
                    for s in (None, SpeechSettings(noise_db=(60.0,) * 7)))
    assert noisy < quiet - 0.1  # background noise lowers STI (A.2.3)


def test_params_octaves_and_speech_options_on_the_command_line(capsys, tmp_path):
    import json

    from sonolux import cli
    from sonolux.fieldfile import save_fields

    path = save_fields(tmp_path / "thirds.h5",
                       sound=thirds_field(np.linspace(1.6, 0.5, len(THIRDS_STI)), THIRDS_STI))
    assert cli.main(["params", str(path), "--octaves", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bands_hz"] == [125, 250, 500, 1000, 2000, 4000, 8000]
    quiet = out["sti"]["mean"]
    assert cli.main(["params", str(path), "--json", "--noise-db", "60"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["bands_hz"]) == len(THIRDS_STI) and out["sti"]["mean"] < quiet - 0.1
    assert out["speech"] == {"speech_dba": 60.0, "noise_db": [60.0] * 7}
    assert cli.main(["params", str(path), "--noise-db", "1,2"]) == 2
    assert "--noise-db: '1,2' is not a noise level" in capsys.readouterr().err
    assert cli.main(["params", str(path), "--speech-dba", "200"]) == 2
    octave = thirds_field([1.0] * 6, DEFAULT_THIRDS_HZ[:6])
    octave.settings["bands"] = "octave"
    octave.bands_hz = np.array([125, 250, 500, 1000, 2000, 4000], float)
    path = save_fields(tmp_path / "octave.h5", sound=octave)
    assert cli.main(["params", str(path), "--octaves"]) == 2
    assert "need a third-octave field" in capsys.readouterr().err
