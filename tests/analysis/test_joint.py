"""One map for both senses: the work plane in the field file, the joint cells, criteria that
never pass or fail an undefined value, and ``sonolux maps``."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.analysis.joint import Criterion, joint_map, nearest_cells
from sonolux.analysis.params import room_parameters
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_light_field, save_fields
from sonolux.multisensory import bake_senses

SCENE = {
    "name": "joint",
    "materials": {"wall": {"absorption": 0.2, "diffuse_rgb": [0.6, 0.6, 0.6]},
                  "lamp": {"absorption": 0.2, "diffuse_rgb": [0.8, 0.8, 0.8]}},
    "geometry": [{"type": "shoebox", "size_m": [6, 4, 3],
                  "materials": {"default": "wall", "ceiling": "lamp"}}],
    "lights": [{"type": "surface", "material": "lamp", "power_w": 30.0}],
    "sources": [{"position_m": [1.5, 2, 1.5]}],
    "receivers": {"height_m": 1.2, "spacing_m": 1.0},
    "workplane": {"height_m": 0.8, "spacing_m": 0.5},
}


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    scene = sonolux.load_scene(SCENE)
    both = bake_senses(scene, sound_options=sonolux.SoundOptions(rays=6000),
                       light_options=sonolux.LightOptions(particles=60_000))
    path = save_fields(tmp_path_factory.mktemp("joint") / "f.h5", sound=both.sound,
                       light=both.light)
    return both, path


def test_the_work_plane_round_trips_through_the_field_file(baked):
    both, path = baked
    back = open_light_field(path).workplane
    wp = both.light.workplane
    for name in ("positions_m", "grid_index", "illuminance_lx", "hits"):
        assert np.array_equal(getattr(back, name), getattr(wp, name)), name
    assert back.height_m == 0.8 and back.spacing_m == 0.5


def test_each_receiver_reads_its_nearest_work_plane_cell(baked):
    both, _ = baked
    params = room_parameters(both.sound, theory=False)
    joint = joint_map(both.sound, params, both.light, [Criterion.parse("illuminance_lx>=0")])
    wp = both.light.workplane
    for k, p in enumerate(joint.positions_m):
        d = np.linalg.norm(wp.positions_m[:, :2] - p[:2], axis=1)
        assert joint.values["illuminance_lx"][k] == wp.illuminance_lx[d.argmin()]
    assert (joint.verdicts["illuminance_lx>=0"] == 1).all()
    # The single numbers are the mean of the 500 Hz and 1 kHz octaves (ISO 3382-1 A.1).
    cols = [list(params.bands_hz).index(b) for b in (500.0, 1000.0)]
    assert np.allclose(joint.values["c50_db"], params.values["c50_db"][:, cols].mean(axis=1),
                       equal_nan=True)


def test_undefined_values_neither_pass_nor_fail():
    c = Criterion.parse("sti >= 0.6")
    assert list(c.passes(np.array([0.7, 0.5, np.nan]))) == [1, 0, -1]
    assert list(Criterion.parse("t30_s<=1.2").passes(np.array([1.0, 1.3]))) == [1, 0]
    for bad in ("sti>0.6", "foo>=1", "sti>=nan", "sti>=inf", ""):
        with pytest.raises(SonoluxError, match="criterion"):
            Criterion.parse(bad)


def test_a_receiver_far_from_the_work_plane_is_undefined_not_a_number():
    class Plane:
        positions_m = np.array([[0.0, 0.0, 0.8], [0.5, 0.0, 0.8]])
        spacing_m = 0.5
    assert list(nearest_cells(np.array([[0.1, 0.0, 1.2], [3.0, 3.0, 1.2]]), Plane())) == [0, -1]


def test_sonolux_maps_writes_picture_csv_and_json(baked, tmp_path, capsys):
    from sonolux import cli

    both, path = baked
    n = both.sound.n_receivers
    png, table, js = tmp_path / "m.png", tmp_path / "m.csv", tmp_path / "m.json"
    code = cli.main(["maps", str(path), "-o", str(png), "--csv", str(table), "--json", str(js),
                     "--require", "illuminance_lx>=1e9", "--require", "c50_db>=-100"])
    out = capsys.readouterr().out
    assert code == 0 and png.stat().st_size > 10_000
    rows = list(csv.DictReader(io.StringIO(table.read_text())))
    assert len(rows) == n and all(r["illuminance_lx>=1e+09"] == "fail" for r in rows)
    summary = json.loads(js.read_text())["summary"]
    assert summary["criteria"]["c50_db>=-100"]["pass"] == n and summary["failing_any"] == n
    assert f"fail {n:>5}" in out


def test_sonolux_maps_refuses_bad_criteria_with_exit_2(baked, tmp_path, capsys):
    from sonolux import cli

    _, path = baked
    # main() returns the usage status (2) instead of raising SystemExit
    assert cli.main(["maps", str(path), "-o", str(tmp_path / "m.png"), "--require",
                     "lux>=300"]) == 2
    assert "criterion 'lux>=300' is not allowed" in capsys.readouterr().err
