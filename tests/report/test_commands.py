"""``sonolux params``: tables, JSON, one cell, and clear errors for files that are not fields."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from sonolux import cli
from sonolux.fieldfile import save_fields
from tests.analysis.fields import decaying_grid


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def field_file(tmp_path):
    field, _, _ = decaying_grid((0.6, 1.3, 2.0), duration_s=2.5)
    return save_fields(tmp_path / "grid.h5", sound=field)


def test_params_of_the_grid(capsys, field_file):
    code, out, err = run(capsys, "params", str(field_file))
    assert code == 0 and err == ""
    assert "3 receivers" in out
    for label in ("EDT s", "T20 s", "T30 s", "C50 dB", "C80 dB", "D50", "Ts ms", "G dB", "JLF"):
        assert label in out
    t30 = [line for line in out.splitlines() if line.strip().startswith("T30 s")][0].split()
    assert t30[3:6] == ["1.30", "1.30", "1.30"]  # mean of 0.6, 1.3, 2.0 in each column
    assert "Sabine/Eyring left out" in out  # a synthetic field has no scene to load


def test_params_of_one_cell_and_its_directions(capsys, field_file):
    code, out, _ = run(capsys, "params", str(field_file), "--at", "2,1.25")
    assert code == 0
    assert "receiver #1 at (2, 1.25, 1.5) m" in out
    assert "per direction" in out and "front-right" in out
    row = [line for line in out.splitlines() if line.strip().startswith("T30 s")][0].split()
    assert row[2:] == ["1.30", "1.30", "1.30"]


def test_params_json(capsys, field_file):
    code, out, _ = run(capsys, "params", str(field_file), "--json")
    d = json.loads(out)
    assert d["columns"] == ["500", "1000", "broadband"]
    t30 = d["parameters"]["t30_s"]
    np.testing.assert_allclose(np.array(t30["per_receiver"])[:, 0], [0.6, 1.3, 2.0], rtol=0.005)
    assert t30["min"][0] == pytest.approx(0.6, rel=0.005)
    code, out, _ = run(capsys, "params", str(field_file), "--json", "--at", "1,1.25")
    d = json.loads(out)
    assert len(d["parameters"]["g_db"]["per_direction"][0]) == 8


def test_params_errors_are_clear(capsys, tmp_path, field_file):
    code, _, err = run(capsys, "params", str(tmp_path / "missing.h5"))
    assert code == 2 and "no such file" in err and "Traceback" not in err
    text = tmp_path / "text.h5"
    text.write_text("not hdf5")
    code, _, err = run(capsys, "params", str(text))
    assert code == 2 and "not an HDF5 file" in err
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["data"] = np.arange(3)
    code, _, err = run(capsys, "params", str(foreign))
    assert code == 2 and "not a sonolux field file" in err
    code, _, err = run(capsys, "params", str(field_file), "--at", "40,40")
    assert code == 2 and "outside the sound field" in err
    with pytest.raises(SystemExit):
        cli.main(["params", str(field_file), "--at", "1;2"])
