"""The sound commands: bake, info, ir; stopping early; leaks reported with where they are."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import soundfile as sf

import sonolux
from sonolux import cli
from sonolux.engine import Geometry
from sonolux.sound.bake import bake
from sonolux.sound.info import format_info

pytestmark = pytest.mark.usefixtures("core")


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_bake_info_and_ir(capsys, tmp_path):
    h5 = tmp_path / "small.h5"
    code, out, err = run(capsys, "bake", "paper-small", "-o", h5, "--rays", "2000", "-q")
    assert code == 0, err
    assert "energy balance" not in err and "balance" in out and h5.exists()
    code, out, _ = run(capsys, "info", h5, "--json")
    info = json.loads(out)
    assert info["receivers"] == 15 and info["settings"]["rays"] == 2000
    assert max(abs(v) for v in info["energy_balance_relative_error"]) < 1e-9
    wav = tmp_path / "right.wav"
    code, out, err = run(capsys, "ir", h5, "--at", "3,1.25", "--direction", "right", "-o", wav)
    assert code == 0, err
    data, rate = sf.read(wav)
    assert rate == 48000 and data.ndim == 1 and np.max(np.abs(data)) > 0
    code, _, err = run(capsys, "ir", h5, "--at", "30,1", "-o", wav)
    assert code == 2 and "outside the sound field" in err

    # The paper's filters: one channel per direction and band, each the energy taps of
    # field.paper_filters (checked against the histogram in tests/sound/test_synthesis.py).
    taps = tmp_path / "paper.wav"
    code, out, err = run(capsys, "ir", h5, "--at", "3,1.25", "--paper-filters", "-o", taps)
    assert code == 0, err
    data, rate = sf.read(taps)
    field = sonolux.open(h5)
    r = field.cell_at(3, 1.25)
    want = field.paper_filters(r)
    assert data.shape == (3840, want.shape[0] * want.shape[1]) and rate == 48000
    np.testing.assert_allclose(data.T, want.reshape(-1, 3840).astype(np.float32), rtol=1e-6)
    assert "front 125 Hz" in out
    code, out, err = run(capsys, "ir", h5, "--at", "3,1.25", "--paper-filters", "--direction",
                         "left", "--length", "100", "-o", taps)
    assert code == 0, err
    data, _ = sf.read(taps)
    np.testing.assert_allclose(data.T, want[field.direction_names.index("left"), :, :100]
                               .astype(np.float32), rtol=1e-6)
    code, _, err = run(capsys, "ir", h5, "--at", "3,1.25", "--paper-filters", "--direction",
                       "upwards", "-o", taps)
    assert code == 2 and "unknown direction 'upwards'" in err


def test_bad_arguments_are_usage_errors(capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        cli.main(["bake", "paper-small", "-o", str(tmp_path / "x.h5"), "--rays", "-5"])
    assert e.value.code == 2
    assert "not a ray count" in capsys.readouterr().err
    code, _, err = run(capsys, "info", tmp_path / "nothing.h5")
    assert code == 2 and "no such file" in err


def test_a_progress_callback_can_stop_the_bake():
    scene = sonolux.load_scene("paper-small")
    seen = []

    def stop_at_once(done, total, elapsed_s):
        seen.append(done)
        return False

    field = bake(scene, rays=2_000_000, estimator="paper", progress=stop_at_once)
    assert field.stats["cancelled"] and seen
    assert field.stats["rays"] < 2_000_000


def test_a_leaking_room_is_reported_with_where_rays_left():
    # A shoebox without its ceiling: most upward rays leave through the hole.
    scene = sonolux.load_scene({
        "name": "open-top",
        "materials": {"m": {"absorption": 0.1}},
        "geometry": [{"type": "shoebox", "size_m": [4, 3, 2.5], "materials": {"default": "m"}}],
        "sources": [{"position_m": [2, 1.5, 1.2]}],
        "receivers": {"type": "points", "positions_m": [[1, 1, 1.2]], "radius_m": 0.3},
    })
    keep = np.array([t != "ceiling" for t in scene.surface_tag])
    tris = scene.triangles[keep]
    geometry = Geometry(scene.vertices_m, tris, scene.material_index[keep])
    leaky = replace(scene, triangles=tris, material_index=scene.material_index[keep],
                    surface_tag=scene.surface_tag[keep], geometry=geometry)
    field = bake(leaky, rays=5000)
    assert field.stats["escaped_rays"] > 0.1 * 5000
    text = format_info(field)
    assert "WARNING" in text and "escaped" in text and "from (" in text
    # Every escape starts inside the box and heads up and out.
    for _, _, start, direction in field.stats["escapes"]:
        assert 0 <= start[2] <= 2.5 and direction[2] > 0
