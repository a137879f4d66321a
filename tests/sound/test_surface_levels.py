"""Described surfaces (docs/scene.md ``surface``) with level-of-detail band groups
(:mod:`sonolux.sound.levels`): each group's rays and image sources take the α(θ)/s(θ) table cut
to its bands (:func:`sonolux.sound.surfaces.level_tables`), and a profiled surface that took in
the small features sitting on it carries them as the level adds them to its coefficients.

- one group over every band on the full geometry is the plain bake, bit for bit;
- a bake with groups has the same bits on 1 and 2 threads, and its ray ranges merge to the bits
  of one bake;
- the table of a group is in effect (its bits differ from the same scene's random-incidence
  coefficient), and a seat's table is the surface's with ΔA/S and s_add added as the level adds
  them (exact: the same floating-point operations).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.sound.bake import bake

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "furniture"))
from rooms import BOX_ROOM_M, boxes_on_wall, write_obj  # noqa: E402

pytestmark = pytest.mark.usefixtures("core")

BANDS = [63, 125, 250, 500, 1000, 2000, 4000]
#: A quadratic-residue profile (N = 7, designed for 500 Hz; Cox and D'Antonio, "Acoustic
#: Absorbers and Diffusers", §9.2) in 0.5 m patches: the west wall, on which 50 small boxes hang.
QRD = {"depths_m": [0.0, 0.049, 0.196, 0.098, 0.098, 0.196, 0.049], "patch_m": 0.5}


def room(tmp_path: Path, *, surface: bool = True, threads: int = 0, rays: str = "octave"):
    """8 × 6 × 3 m; the west wall (α 0.03) described by QRD wells with its boxes, the rest α 0.12,
    s 0.2; nine listeners at 1.2 m; every reflection the particles' (max_order 0)."""
    obj = tmp_path / "boxes.obj"
    if not obj.exists():
        write_obj(obj, {"boxes": boxes_on_wall()})
    west = {"absorption": 0.03}
    if surface:
        west["surface"] = QRD
    else:
        west["scattering"] = 0.1
    faces = ("floor", "ceiling", "west", "east", "south", "north")
    return sonolux.load_scene({
        "name": "qrd wall", "settings": {"bands_hz": BANDS, "seed": 4, "threads": threads},
        "materials": {"west": west, "room": {"absorption": 0.12, "scattering": 0.2}},
        "geometry": [{"type": "shoebox", "size_m": list(BOX_ROOM_M),
                      "materials": {f: "west" if f == "west" else "room" for f in faces}},
                     {"type": "mesh", "file": str(obj), "material": "west"}],
        "sources": [{"position_m": [6.5, 2.2, 1.5]}],
        "receivers": {"type": "points", "radius_m": 0.3,
                      "positions_m": [[x, y, 1.2] for x in (1.5, 3.5, 5.5) for y in (1.2, 3.0, 4.8)]},
        "early": {"max_order": 0, "diffraction": False, "level_of_detail": True,
                  "level_of_detail_rays": rays},
    }, base_dir=tmp_path)


KW = dict(air_absorption=False, max_time_s=0.3)


def test_a_group_over_every_band_is_the_plain_bake(tmp_path):
    """levels.trace with one group holding every band, the full geometry and the whole table
    cut to all its bands gives the plain trace's bits (the same rays, the same table)."""
    from sonolux.scene.simplify import Level
    from sonolux.sound import levels
    from sonolux.sound.bake import band_arrays
    from sonolux.sound.surfaces import level_tables, tables_by_angle
    scene = room(tmp_path)
    arrays = band_arrays(scene)
    tables = tables_by_angle(scene)
    assert tables is not None
    acoustics = engine.Acoustics(arrays["absorption"], arrays["scattering"], by_angle=tables)
    level = Level(slice(0, len(BANDS)), scene.triangles, scene.material_index,
                  arrays["absorption"], arrays["scattering"])
    one = [levels.LevelGeometry(level, scene.geometry, level_tables(tables, level))]
    grouped, plain, flat = one_group_and_plain(
        one, scene, scene.geometry, acoustics,
        engine.Acoustics(arrays["absorption"], arrays["scattering"]))
    np.testing.assert_array_equal(grouped["counts"], plain["counts"])
    np.testing.assert_array_equal(grouped["energy"], plain["energy"])
    # And the table is in effect: without it the bits differ.
    assert not np.array_equal(flat["counts"], plain["counts"])


def test_a_seat_on_a_described_surface_carries_what_its_features_add(tmp_path):
    """The low group (63-125 Hz, without the boxes) appends one material, the west wall that took
    in the boxes: its table is the wall's with ΔA/S added to α(θ) and s_add combined into s(θ)
    at every angle, cut to the group's bands; the wall's own table is cut unchanged."""
    from sonolux.sound import levels
    from sonolux.sound.bake import band_arrays
    from sonolux.sound.surfaces import tables_by_angle
    scene = room(tmp_path, rays="level")
    plan = levels.plan(scene, band_arrays(scene))
    assert plan is not None
    tables = tables_by_angle(scene)
    west = [m.name for m in scene.materials].index("west")
    low = plan[0]
    assert (low.level.bands.start, low.level.bands.stop, low.level.removed) == (0, 2, 50)
    seat = low.level.absorption.shape[0] - 1
    assert low.level.seats[0][0] == west and set(low.by_angle) == {west, seat}
    b = low.level.bands
    np.testing.assert_array_equal(low.by_angle[west], tables[west][:, :, b])
    _, extra_alpha, s_add = low.level.seats[0]
    alpha = np.minimum(tables[west][0] + extra_alpha[None, :], 1.0)[:, b]
    scattering = (1.0 - (1.0 - tables[west][1]) * (1.0 - s_add[None, :]))[:, b]
    np.testing.assert_array_equal(low.by_angle[seat], np.stack([alpha, scattering]))
    assert np.all(low.by_angle[seat][0] > low.by_angle[west][0])  # the boxes' absorption area
    # The high group keeps the full mesh: the wall's table only, cut to its bands.
    high = plan[1]
    assert high.level.removed == 0 and set(high.by_angle) == {west}
    np.testing.assert_array_equal(high.by_angle[west], tables[west][:, :, high.level.bands])


def test_a_bake_with_groups_has_the_same_bits_on_one_and_two_threads_and_over_ranges(tmp_path):
    scene = room(tmp_path)
    fields = [bake(replace(scene, settings=replace(scene.settings, threads=t)), rays=2000, **KW)
              for t in (1, 2)]
    np.testing.assert_array_equal(fields[0].energy, fields[1].energy)
    whole = bake(scene, rays=2000, ray_range=(0, 2000), **KW)
    a = bake(scene, rays=2000, ray_range=(0, 700), **KW)
    b = bake(scene, rays=2000, ray_range=(700, 2000), **KW)
    for merged in (a.merge(b), b.merge(a)):
        np.testing.assert_array_equal(merged.energy, whole.energy)
    # The surface is in effect in the groups: the same wall given as a coefficient differs.
    flat = bake(room(tmp_path, surface=False), rays=2000, **KW)
    assert not np.array_equal(flat.energy, fields[0].energy)


def one_group_and_plain(one, scene, geometry, acoustics, without):
    """(level-of-detail trace of the band groups ``one``, plain trace of ``geometry``, the plain
    trace with the acoustics ``without`` the table under test): the same sources, receivers,
    2,000 rays and seed, so that one group over every band must give the plain bake's bits, and
    the table must be in effect (``without`` gives other bits)."""
    from sonolux.sound import levels

    sources = [engine.SoundSource(tuple(s.position_m), s.power_w, engine.Directivity.omni())
               for s in scene.sources]
    receivers = engine.Receivers(np.ascontiguousarray(scene.receivers.positions_m, float),
                                 scene.receivers.radius_m)
    settings = dict(rays=2000, first_ray=0, end_ray=2000, seed=4, threads=2, estimator="paper",
                    speed_of_sound_m_s=343.0, air_attenuation_per_m=[0.0] * len(BANDS),
                    energy_drop_db=60.0, max_time_s=0.3, sample_rate_hz=8000.0, early_s=0.05,
                    late_bin_s=0.01, azimuth_bands=4, elevation_bands=1, max_field_bytes=1 << 30,
                    keep_counts=True)
    settings["quantum"] = engine.sound_quantum(sources, receivers)

    def parts(b: slice):
        return sources, None, [0.0] * (b.stop - b.start)
    grouped = levels.trace(one, scene, acoustics, sources, receivers, settings, None, None, parts)
    plain, flat = (engine.trace_sound(geometry, a, sources, receivers,
                                      engine.SoundSettings(**settings), None, None)
                   for a in (acoustics, without))
    return grouped, plain, flat
