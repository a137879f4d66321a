"""Receiver grids: where the candidates are, and which are dropped for which reason."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.scene import load_scene
from sonolux.scene.receivers import grid_candidates
from tests.conftest import EXAMPLES


def test_grid_candidates_are_strictly_inside_the_bounding_box():
    pos, index = grid_candidates(np.zeros(3), np.array([6.0, 2.5, 2.0]), np.array([3.0, 1.25]),
                                 1.0, 1.5)
    # x = 3 + i for i in -2..2 (0 and 6 lie on the walls); y = 1.25 + j for j in -1..1.
    assert pos.shape == (15, 3) and index.shape == (15, 2)
    assert sorted(set(pos[:, 0])) == [1, 2, 3, 4, 5]
    assert sorted(set(pos[:, 1])) == [0.25, 1.25, 2.25]
    np.testing.assert_array_equal(pos[:, 2], 1.5)
    np.testing.assert_allclose(pos[:, :2], [3.0, 1.25] + index * 1.0)


def test_paper_small_grid(core):
    scene = load_scene("paper-small")
    r = scene.receivers
    assert (r.kind, r.count, r.candidates) == ("grid", 15, 15)
    assert (r.dropped_outside, r.dropped_inside_obstacle, r.dropped_near_surface) == (0, 0, 0)
    np.testing.assert_allclose(r.origin_m, [3.0, 1.25])
    assert (r.spacing_m, r.radius_m, r.height_m) == (1.0, 0.25, 1.5)
    # A cell at the centre, on the talker, as in the paper.
    centre = np.flatnonzero(np.all(r.grid_index == 0, axis=1))
    assert centre.shape == (1,)
    np.testing.assert_allclose(r.positions_m[centre[0]], scene.sources[0].position_m)
    assert r.positions_m.dtype == np.float64 and r.positions_m.flags.c_contiguous
    assert r.grid_index.dtype == np.int64


@pytest.mark.parametrize(("name", "count"), [("paper-medium", 11 * 5), ("paper-large", 23 * 9)])
def test_paper_grids_fill_the_room(core, name, count):
    r = load_scene(name).receivers
    assert r.count == r.candidates == count


def test_l_room_drops_outside_obstacle_and_near_surface(core):
    r = load_scene(EXAMPLES / "mesh_room.toml").receivers
    # 7 x 7 candidates at x = 1..7, y = 0.5..6.5. The 3 x 3 in the notch (x > 4.2, y > 4) are
    # outside; (6, 1.5) and (7, 1.5) are inside the cupboard; (4, 4.5..6.5) are 0.2 m from
    # the notch's west wall at x = 4.2, nearer than the 0.25 m radius.
    assert r.candidates == 49
    assert (r.dropped_outside, r.dropped_inside_obstacle, r.dropped_near_surface) == (9, 2, 3)
    assert r.count == 35
    kept = {tuple(p) for p in r.positions_m[:, :2]}
    assert (6.0, 1.5) not in kept and (4.0, 4.5) not in kept and (5.0, 1.5) in kept


def test_origin_and_spacing_move_the_grid(core):
    scene = load_scene({"geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                                      "materials": {"default": "paper"}}],
                        "materials": {"paper": {"absorption": 0.1}},
                        "receivers": {"origin_m": [0.25, 0.25], "spacing_m": 0.5,
                                      "radius_m": 0.1, "height_m": 1.0}})
    r = scene.receivers
    # x, y = 0.25 + 0.5 k for k = 0..7: 8 x 8, all at least 0.25 m from a wall.
    assert r.count == 64 and r.dropped_near_surface == 0
    assert r.grid_index.min() == 0 and r.grid_index.max() == 7


def test_points_outside_are_dropped_with_a_warning(core):
    scene = load_scene({"geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                                      "materials": {"default": "paper"}}],
                        "materials": {"paper": {"absorption": 0.1}},
                        "receivers": {"type": "points", "radius_m": 0.2,
                                      "positions_m": [[1, 1, 1], [5, 1, 1], [0.1, 2, 1]]}})
    r = scene.receivers
    assert r.kind == "points" and r.count == 1 and r.grid_index is None
    assert (r.dropped_outside, r.dropped_near_surface) == (1, 1)
    assert any("positions_m[1]" in w and "outside the room" in w for w in scene.warnings)
    assert any("positions_m[2]" in w and "nearer to a surface" in w for w in scene.warnings)


def test_too_many_receivers_is_an_error(core):
    from sonolux.errors import SceneError

    with pytest.raises(SceneError, match="at most"):
        load_scene({"geometry": [{"type": "shoebox", "size_m": [100, 100, 3],
                                  "materials": {"default": "paper"}}],
                    "materials": {"paper": {"absorption": 0.1}},
                    "receivers": {"spacing_m": 0.1, "radius_m": 0.05}})
