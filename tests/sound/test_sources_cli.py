"""The commands on a field of several sources: --source picks one (by name or index) or mixes
several (NAME=GAIN_DB) on params, info, report, export --sofa and auralize; auralize plays
each source its own dry signal with --dry NAME=DRY; unknown names exit 2 naming the sources."""

from __future__ import annotations

import json

import numpy as np
import pytest
import soundfile as sf

from sonolux import cli
from sonolux.analysis.params import room_parameters
from sonolux.fieldfile import open_field, save_fields
from sonolux.sound.bake import bake
from sonolux.sound.lazy import SourceMix
from tests.sound.test_sources import NAMES, scene

pytestmark = pytest.mark.usefixtures("core")


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def h5(tmp_path_factory):
    path = tmp_path_factory.mktemp("sources") / "two.h5"
    save_fields(path, sound=bake(scene(), rays=2000))
    return path


def test_params_per_source_and_mix(capsys, h5):
    field = open_field(h5)
    code, out, err = run(capsys, "params", h5, "--source", "door", "--json")
    assert code == 0, err
    door = json.loads(out)
    code, out, err = run(capsys, "params", h5, "--source", "1", "--json")
    assert json.loads(out) == door  # by index: the same source
    code, out, err = run(capsys, "params", h5, "--json")
    everything = json.loads(out)
    assert everything != door
    code, out, err = run(capsys, "params", h5, "--source", "desk=0", "--source", "door=0",
                         "--source", "fan=0", "--json")
    assert json.loads(out) == everything  # the mix of all at 0 dB is the sum
    code, out, err = run(capsys, "params", h5, "--source", "door=-6")
    assert code == 0 and "mix of door -6.0 dB" in out
    # A source turned 10 dB down: its energy is 10 dB lower, and so is its power, so its
    # strength G (energy against the free field of the same power at 10 m) is unchanged.
    mixed = open_field(h5).mixed({"door": 0.1})
    door_alone = field.for_source("door")
    np.testing.assert_allclose(np.asarray(mixed.energy, np.float64),
                               0.1 * np.asarray(door_alone.energy, np.float64), rtol=1e-6)
    g_door = room_parameters(door_alone).values["g_db"]
    np.testing.assert_allclose(room_parameters(mixed).values["g_db"], g_door, atol=1e-4)


@pytest.mark.parametrize("argv", [
    ("params", "{h5}", "--source", "window"),
    ("info", "{h5}", "--source", "7"),
    ("report", "{h5}", "-o", "{out}", "--source", "window"),
    ("export", "{h5}", "--sofa", "{out}.sofa", "--source", "window"),
    ("auralize", "{h5}", "builtin:clicks:0.3", "--at", "3,2.5", "-o", "{out}.wav",
     "--source", "window"),
    ("auralize", "{h5}", "--dry", "window=builtin:clicks:0.3", "--at", "3,2.5", "-o",
     "{out}.wav"),
])
def test_an_unknown_source_exits_2_naming_the_sources(capsys, h5, tmp_path, argv):
    code, out, err = run(capsys, *(a.format(h5=h5, out=tmp_path / "x") for a in argv))
    assert code == 2
    assert "desk" in err and "door" in err and "fan" in err, err


@pytest.mark.parametrize("flag", ["door=loud", "door=200", "=3"])
def test_a_bad_source_spec_is_a_usage_error(capsys, h5, flag):
    code, out, err = run(capsys, "params", h5, "--source", flag)
    assert code == 2 and "--source" in err and "GAIN_DB" in err or "dB" in err


def test_info_lists_the_sources(capsys, h5):
    code, out, err = run(capsys, "info", h5)
    assert code == 0, err
    assert "3, a field each: 0 = desk, 1 = door, 2 = fan" in out
    code, out, err = run(capsys, "info", h5, "--source", "fan", "--json")
    assert json.loads(out)["sources"] == ["fan"]


def test_auralize_each_source_its_own_dry(capsys, h5, tmp_path):
    out_wav = tmp_path / "both.wav"
    common = ("--at", "3,2.5", "--layout", "stereo", "--gain-db", "0")
    code, out, err = run(capsys, "auralize", h5, "--dry", "desk=builtin:clicks:0.3",
                         "--dry", "door=builtin:noise:0.3", *common, "-o", out_wav)
    assert code == 0, err
    both, fs = sf.read(out_wav)
    parts = []
    for name, dry in (("desk", "builtin:clicks:0.3"), ("door", "builtin:noise:0.3")):
        one = tmp_path / f"{name}.wav"
        code, out, err = run(capsys, "auralize", h5, dry, "--source", name, *common, "-o", one)
        assert code == 0, err
        parts.append(sf.read(one)[0])
    n = max(p.shape[0] for p in parts)
    total = sum(np.pad(p, ((0, n - p.shape[0]), (0, 0))) for p in parts)
    # The same gain (0 dB) everywhere, FLOAT samples: the sum of the two renders, to float32.
    np.testing.assert_allclose(both, total, atol=1e-6)
    code, out, err = run(capsys, "auralize", h5, "--at", "3,2.5", "-o", out_wav)
    assert code == 2 and "--dry NAME=DRY" in err


def test_report_of_one_source(capsys, h5, tmp_path):
    code, out, err = run(capsys, "report", h5, "-o", tmp_path / "r", "--source", "door")
    assert code == 0, err
    assert (tmp_path / "r" / "index.html").exists()


def test_export_sofa_of_one_source(capsys, h5, tmp_path):
    code, out, err = run(capsys, "export", h5, "--sofa", tmp_path / "door.sofa", "--source",
                         "door", "--receiver", "0")
    assert code == 0, err
    code, out, err = run(capsys, "export", h5, "--web", tmp_path / "web", "--source", "door")
    assert code == 2 and "--sofa" in err


def test_compact_and_mixed_arrays_reduce_like_numpy(h5):
    field = open_field(h5)
    assert isinstance(field.energy, SourceMix)
    for a in (field.energy, field.for_source("desk").energy):
        dense = np.asarray(a)
        for axis in (None, 0, 1, (0, 3), -1, (1, 2, 3)):
            np.testing.assert_allclose(a.sum(axis=axis, dtype=np.float64),
                                       dense.sum(axis=axis, dtype=np.float64), rtol=1e-12)
            np.testing.assert_array_equal(a.max(axis=axis), dense.max(axis=axis))
        assert a.sum(axis=1, keepdims=True).shape == dense.sum(axis=1, keepdims=True).shape
        np.testing.assert_allclose(a.mean(axis=(0, 1)), dense.mean(axis=(0, 1)), rtol=1e-6)
        assert a.astype(np.float64).dtype == np.float64
    assert sorted(NAMES) == sorted(field.source_names)
