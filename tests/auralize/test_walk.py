"""Walk-throughs: no click at a change of cell, smooth turns, paths read and checked."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sonolux.auralize.offline import AuralizeSettings, run_blocks
from sonolux.auralize.stream import StreamRenderer
from sonolux.auralize.walk import (
    WalkPath,
    WalkSettings,
    auralize_walk,
    load_path,
    plot_walk,
    sample_path,
)
from sonolux.errors import SonoluxError

from .conftest import FS, synthetic_field


def two_cells():
    """Cells at x = 0.5 and 1.5 m: a front arrival at 3 ms, then a stronger left one at 7 ms."""
    return synthetic_field([(0.5, 0.5), (1.5, 0.5)], {(0, "front"): [(0.003, 1e-4)],
                                                      (1, "front-left"): [(0.007, 3e-4)]})


def sine(seconds=2.0, freq=150.0):
    t = np.arange(int(seconds * FS)) / FS
    return np.sin(2 * np.pi * freq * t) * np.clip(t / 0.05, 0, 1)


ACROSS = WalkPath(np.array([0.0, 2.0]), np.array([[0.6, 0.5], [1.4, 0.5]]), np.array([0.0, 0.0]))


def steps(y, a_s, b_s):
    return np.max(np.abs(np.diff(y[int(a_s * FS):int(b_s * FS)], axis=0)), axis=0)


@pytest.mark.parametrize("layout", ["stereo", "binaural"])
def test_crossing_a_cell_boundary_has_no_click(layout):
    # The boundary is at t = 1 s; the hysteresis (5 cm at 0.4 m/s) takes the new cell at
    # 1.0625 s. No sample-to-sample step around it may exceed the output's own steady steps
    # before and after by more than 10 % (measured: 1.00; an equal-power fade of two coherent
    # sines could raise the envelope by up to √2, these two are not in phase). A click is a
    # jump of the signal's whole amplitude: the hard switch below makes steps 20-75x larger.
    y, info = auralize_walk(two_cells(), sine(), ACROSS, AuralizeSettings(layout=layout,
                                                                          fade_s=0.02))
    assert [r for _, r in info["events"]] == [0, 1] and abs(info["events"][1][0] - 1.0625) < 2e-3
    steady = np.maximum(steps(y, 0.4, 0.9), steps(y, 1.2, 1.7))
    around = steps(y, 1.01, 1.11)
    assert np.all(around <= 1.1 * steady), (around, steady)
    # The same walk switched within one sample clicks: the test can see a click.
    r = StreamRenderer(two_cells(), layout, 1024, fade_s=0.0)
    r.set_cell(0)
    hard = run_blocks(r, sine(), 2 * FS, 0.0, [(int(1.0625 * FS), 1)])
    assert np.any(steps(hard, 1.01, 1.11) > 3 * steady)


def test_the_heading_turns_smoothly():
    # A right-angle corner without headings: the walker faces along each leg; the smoothed
    # heading moves by at most 90° / (0.25 s · fs) · 2 per sample and ends facing the new leg.
    path = WalkPath(np.array([0.0, 2.0, 4.0]), np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]),
                    None)
    _, h = sample_path(path, FS, 4 * FS, 0.25)
    assert h[0] == 0.0 and abs(h[-1] - 90.0) < 1e-9
    assert np.max(np.abs(np.diff(h))) < 2 * 90.0 / (0.25 * FS)


def test_paths_from_csv_and_json(tmp_path):
    csv = tmp_path / "walk.csv"
    csv.write_text("time,x,y,heading\n0,0.6,0.5,0\n# a comment\n2,1.4,0.5,350\n")
    p = load_path(csv)
    assert p.times_s.tolist() == [0, 2] and p.heading_deg.tolist() == [0, 350]
    _, h = sample_path(p, 100.0, 201, 0.0)
    assert abs(h[-1] - (-10.0)) < 1e-9  # the short way round
    js = tmp_path / "walk.json"
    js.write_text(json.dumps({"waypoints": [[0, 0], [3, 4]], "speed_m_s": 2.5}))
    assert load_path(js).duration_s == 2.0
    pts = tmp_path / "points.json"
    pts.write_text(json.dumps([{"t": 0, "x": 0, "y": 0}, {"t": 1, "x": 1, "y": 0}]))
    assert load_path(pts).heading_deg is None


def test_bad_paths_are_named(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,x,y\n0,0,0\n1,zero,0\n")
    with pytest.raises(SonoluxError, match=r"bad.csv:3: x = 'zero' is not a number"):
        load_path(bad)
    with pytest.raises(SonoluxError, match="no such path file"):
        load_path(tmp_path / "none.csv")
    back = tmp_path / "back.csv"
    back.write_text("t,x,y\n1,0,0\n0.5,1,0\n")
    with pytest.raises(SonoluxError, match="increase"):
        load_path(back)


def test_a_path_leaving_the_field_is_an_error_unless_clamped():
    out = WalkPath(np.array([0.0, 2.0]), np.array([[0.6, 0.5], [3.0, 0.5]]), None)
    with pytest.raises(SonoluxError, match=r"leaves the sound field at t = 1\.\d+ s"):
        auralize_walk(two_cells(), sine(), out)
    y, info = auralize_walk(two_cells(), sine(), out, walk=WalkSettings(outside="clamp"))
    assert [r for _, r in info["events"]] == [0, 1] and np.all(np.isfinite(y))


def test_the_plan_view_is_written(tmp_path):
    y, info = auralize_walk(two_cells(), sine(), ACROSS, AuralizeSettings(layout="stereo"))
    png = plot_walk(two_cells(), ACROSS, info, tmp_path / "walk.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
