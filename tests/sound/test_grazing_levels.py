"""The rays' grazing modes (wall model "locally-reacting-modes", :mod:`sonolux.sound.grazing`)
with level-of-detail band groups (:mod:`sonolux.sound.levels`): each group's rays take the table
of its own mesh, materials and bands (:func:`sonolux.sound.walls.grazing_table` with a level).

- one group over every band on the full mesh is the plain bake, bit for bit, and the table is
  in effect there (without it the bits differ);
- a group whose mesh folds the small features away finds the pairs they blocked: the room of
  test_surface_levels.py (50 boxes on its west wall) has no clear pair on the full mesh and its
  three in the low group;
- a bake with groups has the same bits on 1 and 2 threads, and its ray ranges merge to the bits
  of one bake.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sonolux import engine
from sonolux.sound.bake import bake
from tests.sound.test_surface_levels import BANDS, KW, one_group_and_plain, room

pytestmark = pytest.mark.usefixtures("core")

MODES = "locally-reacting-modes"


def test_a_group_over_every_band_is_the_plain_bake(tmp_path):
    """levels.trace with one group holding every band and the full mesh, its table built as a
    level's, gives the plain trace's bits with the whole bake's table."""
    from sonolux.scene.simplify import Level
    from sonolux.sound import levels, walls
    from sonolux.sound.bake import band_arrays
    scene = room(tmp_path, surface=False)
    # The boxes block every pair: take the bare shoebox (its first 12 triangles) so that the
    # table has the three pairs.
    bare = replace(scene, triangles=scene.triangles[:12], material_index=scene.material_index[:12])
    arrays = band_arrays(bare)
    whole = walls.grazing_table(bare, MODES, arrays["absorption"])
    assert whole is not None and whole[0].shape == (3, 3)
    level = Level(slice(0, len(BANDS)), bare.triangles, bare.material_index,
                  arrays["absorption"], arrays["scattering"])
    lv_table = walls.grazing_table(bare, MODES, level.absorption[:, level.bands], level)
    for mine, theirs in zip(lv_table, whole, strict=True):
        np.testing.assert_array_equal(mine, theirs)
    geometry = engine.Geometry(bare.vertices_m, bare.triangles, bare.material_index)
    one = [levels.LevelGeometry(level, geometry, None, lv_table)]
    acoustics = engine.Acoustics(arrays["absorption"], arrays["scattering"],
                                 wall_model="locally-reacting", grazing=whole)
    grouped, plain, flat = one_group_and_plain(
        one, bare, geometry, acoustics,
        engine.Acoustics(arrays["absorption"], arrays["scattering"], wall_model="locally-reacting"))
    np.testing.assert_array_equal(grouped["counts"], plain["counts"])
    np.testing.assert_array_equal(grouped["energy"], plain["energy"])
    # The table is in effect: the same walls without it give other bits.
    assert not np.array_equal(flat["counts"], plain["counts"])


def test_each_group_takes_the_pairs_of_its_own_mesh_and_bands(tmp_path):
    """The low group (63-125 Hz) folds the 50 boxes into the west wall: its mesh is the bare
    shoebox, so its table has the three pairs, each band's row the whole bake's of the same
    mesh (the seat's material carries the boxes' ΔA/S: the west wall's row is computed from
    it). The high group keeps the boxes, which block every pair: no table."""
    from sonolux.sound import levels, walls
    from sonolux.sound.bake import band_arrays
    scene = room(tmp_path, surface=False, rays="level")
    arrays = band_arrays(scene)
    plan = levels.plan(scene, arrays, None, MODES)
    assert plan is not None and len(plan) == 2
    low, high = plan
    assert low.level.removed == 50 and high.level.removed == 0
    assert high.grazing is None
    assert low.grazing is not None
    normals, offsets, cos_limit, rate, profile = low.grazing
    assert normals.shape == (3, 3) and cos_limit.shape == (3, 2)
    assert sorted(np.abs(offsets[:, 1] - offsets[:, 0]).round(9)) == [3.0, 6.0, 8.0]
    # A plain wall model has no table in any group.
    assert all(lg.grazing is None for lg in levels.plan(scene, arrays, None, "locally-reacting"))
    # Each band of the group is the whole bake's band of that mesh and those materials.
    full = walls.grazing_table(scene, MODES, low.level.absorption, replace(
        low.level, bands=slice(0, len(BANDS))))
    np.testing.assert_array_equal(full[2][:, low.level.bands], cos_limit)
    np.testing.assert_array_equal(full[3][:, low.level.bands], rate)
    np.testing.assert_array_equal(full[4][:, low.level.bands], profile)
    assert np.all(rate > 0)


def test_a_bake_with_groups_has_the_same_bits_on_one_and_two_threads_and_over_ranges(tmp_path):
    scene = room(tmp_path, surface=False)
    kw = dict(KW, wall_model=MODES)
    fields = [bake(replace(scene, settings=replace(scene.settings, threads=t)), rays=2000, **kw)
              for t in (1, 2)]
    assert fields[0].settings["wall_model"] == MODES
    np.testing.assert_array_equal(fields[0].energy, fields[1].energy)
    whole = bake(scene, rays=2000, ray_range=(0, 2000), **kw)
    a = bake(scene, rays=2000, ray_range=(0, 700), **kw)
    b = bake(scene, rays=2000, ray_range=(700, 2000), **kw)
    for merged in (a.merge(b), b.merge(a)):
        np.testing.assert_array_equal(merged.energy, whole.energy)
    # The low group's table is in effect: without the modes the bits differ.
    plain = bake(scene, rays=2000, **dict(KW, wall_model="locally-reacting"))
    assert not np.array_equal(plain.energy, fields[0].energy)
