"""The ``sonolux`` command: help, ``check`` (text and JSON), and errors without tracebacks."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from sonolux import cli
from sonolux.acoustics.theory import air_energy_attenuation_per_m
from sonolux.cli import scene as cli_scene


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_help_lists_check(capsys):
    assert cli.main(["--help"]) == 0
    assert "check" in capsys.readouterr().out


def test_check_paper_large_json(capsys, core):
    code, out, err = run(capsys, "check", "paper-large", "--json")
    assert code == 0 and err == ""
    report = json.loads(out)
    for key in ("name", "triangles", "volume_m3", "area_m2", "area_by_material_m2",
                "mean_free_path_m", "bands_hz", "sabine_t60_s", "eyring_t60_s", "receivers",
                "sources", "lights", "warnings"):
        assert key in report
    assert report["volume_m3"] == pytest.approx(1920.0)
    assert report["area_m2"] == pytest.approx(1024.0)
    assert report["mean_free_path_m"] == pytest.approx(4 * 1920 / 1024)
    assert report["area_by_material_m2"] == pytest.approx({"paper-floor": 240.0,
                                                          "paper-wall": 784.0})
    assert report["receivers"] == {**report["receivers"], "kept": 207, "dropped_outside": 0,
                                   "dropped_inside_obstacle": 0, "dropped_near_surface": 0}

    # Eyring, computed here from the room alone: 24 x 10 x 8 m, floor (240 m²) absorbs 0.30,
    # the other 784 m² absorb 0.05; air at 20 °C, 50 % RH, 101.325 kPa.
    volume, surface = 24 * 10 * 8, 2 * (24 * 10 + 24 * 8 + 10 * 8)
    mean_alpha = (240 * 0.30 + 784 * 0.05) / surface
    c = 331.3 * math.sqrt(1 + 20 / 273.15)
    # The air at each band's exact mid-band frequency, 1000 · 10^(x/10) Hz (ISO 9613-1, 8).
    bands = np.array(report["bands_hz"], dtype=float)
    exact = 1000.0 * 10.0 ** (np.round(10 * np.log10(bands / 1000.0)) / 10.0)
    m = air_energy_attenuation_per_m(exact, 20.0, 50.0, 101.325)
    expected = 24 * math.log(10) * volume / (c * (-surface * math.log(1 - mean_alpha) + 4 * m
                                                  * volume))
    np.testing.assert_allclose(report["eyring_t60_s"], expected, rtol=1e-9)
    sabine = 24 * math.log(10) * volume / (c * (surface * mean_alpha + 4 * m * volume))
    np.testing.assert_allclose(report["sabine_t60_s"], sabine, rtol=1e-9)


def test_check_text(capsys, core):
    code, out, _ = run(capsys, "check", "paper-small")
    assert code == 0
    assert "volume 30 m³" in out and "Eyring T60 s" in out and "with air absorption" in out
    assert "15 kept of 15" in out


def test_scene_error_is_one_line_on_stderr(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[settings]\nseed = -1\n")
    code, out, err = run(capsys, "check", str(bad))
    assert code == 2 and out == ""
    assert err == (f"sonolux: error: {bad}:2: settings.seed = -1 is not allowed: an integer in "
                   "[0, 18446744073709551615]\n")


def test_unknown_builtin(capsys):
    code, _, err = run(capsys, "check", "paper-huge")
    assert code == 2 and err.startswith("sonolux: error: paper-huge: not a scene file")


def test_keyboard_interrupt_exits_130(capsys, monkeypatch):
    def interrupted(_args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_scene, "cmd_check", interrupted)
    code, _, _ = run(capsys, "check", "paper-small")
    assert code == 130


def test_bug_is_reported_without_traceback(capsys, monkeypatch):
    def broken(_args):
        raise ZeroDivisionError("oops")

    monkeypatch.setattr(cli_scene, "cmd_check", broken)
    monkeypatch.delenv("SONOLUX_DEBUG", raising=False)
    code, _, err = run(capsys, "check", "paper-small")
    assert code == 1 and "internal error: ZeroDivisionError: oops" in err
    assert "Traceback" not in err


def test_console_entry_point_runs():
    done = subprocess.run([sys.executable, "-m", "sonolux.cli", "check", "nowhere.toml"],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 2
    assert done.stderr == "sonolux: error: nowhere.toml: no such file\n"
    assert "Traceback" not in done.stderr
