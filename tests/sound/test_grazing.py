"""The rays' grazing modes of parallel surface pairs (wall model "locally-reacting-modes";
python/sonolux/sound/grazing.py, sonolux_core::sound::grazing): the pairs a mesh has, the
grazing mode's wavenumber against the exact rooms' independent solver, and the flat paper room's
decay against its exact modes (docs/waves-grazing.md)."""

from __future__ import annotations

import numpy as np
import pytest
import tomllib

import sonolux
from sonolux.scene import builtin
from sonolux.sound.bake import bake
from sonolux.sound.grazing import (
    PROFILE_NODES,
    grazing_profile,
    grazing_wavenumber_squared,
    modes_table,
    parallel_pairs,
)
from tests.sound.test_waves_paper_room import (
    axis_wavenumbers,
    iso_3382_2_sigma,
    mean_times,
    mode_shapes,
    paper_room_modes,
)

pytestmark = pytest.mark.usefixtures("core")


def _box(size_m, offset_m=(0.0, 0.0, 0.0)):
    """The 12 triangles of an axis-aligned box (vertices, triangles)."""
    v = np.array([[(i & 1) * size_m[0], (i >> 1 & 1) * size_m[1], (i >> 2 & 1) * size_m[2]]
                  for i in range(8)], float) + offset_m
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    t = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return v, np.array(t)


def test_a_shoebox_has_three_pairs_and_a_box_inside_removes_them():
    """A shoebox's three pairs of opposite walls, their spacings; a table (a second, inner box)
    makes the room's projected surface larger than any single plane, so no plane covers the
    room along any axis and no pair is left (the grazing mode of a gap needs the gap clear)."""
    v, t = _box((6.0, 2.5, 2.0))
    pairs = parallel_pairs(v, t)
    assert sorted(p.spacing_m for p in pairs) == [2.0, 2.5, 6.0]
    assert all(len(a) == 2 and len(b) == 2 for a, b in (p.triangles for p in pairs))
    inner_v, inner_t = _box((1.0, 1.0, 0.75), (2.0, 1.0, 0.0))
    both_v = np.concatenate([v, inner_v])
    both_t = np.concatenate([t, inner_t + len(v)])
    assert parallel_pairs(both_v, both_t) == []
    assert modes_table(both_v, both_t, np.zeros(24, int), np.full((1, 1), 0.3), [500.0],
                       343.0) is None


def test_the_grazing_wavenumber_is_the_exact_rooms_and_first_order_for_small_admittance():
    """κ₀² from :func:`grazing_wavenumber_squared` (Newton on κ, the boundary conditions as
    written in the module) against ``axis_wavenumbers`` of the paper room's exact modes (Newton
    on another form of the same equation): 1e-9 relative, rounding and the two stopping rules.
    For k(β_a + β_b)D = 0.01 first-order perturbation, jk(β_a + β_b)/D, holds to 1 % (its error
    is of the order of that product); for paper-small's floor at 1 kHz (2.1) the exact κ₀²'s
    imaginary part is well below it (the grazing mode avoids the absorbing floor)."""
    for k, d, ba, bb in [(9.15, 2.0, 0.0506, 0.00665), (18.3, 2.0, 0.0506, 0.00665),
                         (4.58, 8.0, 0.0506, 0.00665), (9.15, 6.0, 0.00665, 0.00665)]:
        mine = grazing_wavenumber_squared(k, d, ba, bb)
        theirs = complex(axis_wavenumbers(np.array([0]), d, k, (ba, bb))[0] ** 2)
        assert abs(mine - theirs) <= 1e-9 * abs(theirs), (k, d, mine, theirs)
    k, d = 1.0, 0.01
    small = grazing_wavenumber_squared(k, d, 0.6, 0.4)
    assert abs(small - 1j * k * 1.0 / d) < 0.01 * abs(1j * k / d)
    large = grazing_wavenumber_squared(18.3, 2.0, 0.0506, 0.00665)
    assert large.imag < 0.8 * 18.3 * (0.0506 + 0.00665) / 2.0


def test_the_grazing_profile_is_the_exact_rooms_mode_shape_over_its_mean():
    """The profile the rays carry (:func:`grazing_profile`, |ψ₀|² over its mean across the gap)
    against the exact room's mode shape (``mode_shapes`` of tests/sound/test_waves_paper_room.py:
    ψ from ``axis_wavenumbers``' κ, its own closed form), the mean of |ψ|² taken there by the
    trapezoid rule on 20,481 points: 1e-6 relative (the two quadratures). Paper-large's first
    ray band (250 Hz, D = 8 m, floor g 0.0506 under a ceiling of 0.00665): lower by the floor
    (0.73 of the mean), higher by the ceiling (1.24), 0.78 at the talker's 1.5 m; its mean 1 by
    construction. Rigid planes: uniform."""
    for k, d, ba, bb in [(4.58, 8.0, 0.0506, 0.00665), (18.3, 2.0, 0.0506, 0.00665),
                         (9.15, 6.0, 0.00665, 0.00665)]:
        mine = grazing_profile(k, d, ba, bb)
        assert mine.shape == (PROFILE_NODES,)
        kap = axis_wavenumbers(np.array([0]), d, np.array([k + 0j]), (ba, bb))
        z = np.linspace(0.0, d, 320 * (PROFILE_NODES - 1) + 1)
        points = np.zeros((z.size, 3))
        points[:, 2] = z
        adm = {0: (0.0, 0.0), 1: (0.0, 0.0), 2: (ba, bb)}
        psi, _ = mode_shapes(np.array([[0.0, 0.0, kap[0]]]), np.array([k + 0j]), adm,
                             (1.0, 1.0, d), points)
        density = np.abs(psi[0]) ** 2
        theirs = density / np.trapezoid(density, z) * d
        assert np.allclose(mine, theirs[::320], rtol=1e-6, atol=0), (k, d)
    large = grazing_profile(4.58, 8.0, 0.0506, 0.00665)
    assert 0.70 < large[0] < 0.76 and 1.2 < large[-1] < 1.28
    assert 0.76 < np.interp(1.5, np.linspace(0, 8.0, PROFILE_NODES), large) < 0.81
    assert np.array_equal(grazing_profile(4.58, 8.0, 0.0, 0.0), np.ones(PROFILE_NODES))


def _paper_small_flat(band_hz):
    """paper-small with one band and no scattering coefficient: the flat room its exact modes
    and its waves model."""
    data = tomllib.loads(builtin.path("paper-small").read_text())
    data["settings"]["bands_hz"] = [band_hz]
    for m in data["materials"].values():
        m["scattering"] = 0.0
    return sonolux.load_scene(data)


def test_flat_rooms_rays_with_the_grazing_modes_decay_as_its_exact_modes():
    """paper-small at 500 Hz with flat walls (no scattering), rays alone: T30 against the same
    room's exact modes (the reference the waves meet within 2 %, test_waves_paper_room.py),
    within 3σ of ISO 3382-2 annex A at 4 points. Measured (2026-11-27): with the grazing modes
    0.852 s against the modes' 0.848 (+0.5 %); the locally reacting rays without them 1.657 s
    (+94 %: a specular ray parallel to the floor is never absorbed by it, the floor's grazing
    mode is). Asserted: with them inside the tolerance, without them outside it."""
    scene = _paper_small_flat(500)
    modes = bake(scene, rays=20_000, wall_model="locally-reacting-modes")
    rays = bake(scene, rays=20_000, wall_model="locally-reacting")
    far = np.linalg.norm(modes.positions_m - modes.source_positions_m[0], axis=1) > 0.5
    exact = paper_room_modes(scene, modes, far, [500.0], 0, fit_limits=False)["t30_s"][0]
    with_them = mean_times(modes, far, fit_limits=False)["t30_s"][0]
    without = mean_times(rays, far, fit_limits=False)["t30_s"][0]
    tol = 3 * iso_3382_2_sigma("t30_s", exact, 354.0, 4)
    print("T30 with the grazing modes", with_them, "without", without, "exact modes", exact,
          "tolerance", tol)
    assert abs(with_them / exact - 1) < tol
    assert abs(without / exact - 1) > tol


def test_grazing_modes_keep_the_bits_on_one_and_two_threads():
    """Same seed, same bits: the table is read per segment and per bounce, nothing shared."""
    data = tomllib.loads(builtin.path("paper-small").read_text())
    data["settings"]["bands_hz"] = [250, 500]
    fields = []
    for threads in (1, 2):
        data["settings"]["threads"] = threads
        scene = sonolux.load_scene(data)
        fields.append(bake(scene, rays=3000, wall_model="locally-reacting-modes"))
    assert fields[0].settings["wall_model"] == "locally-reacting-modes"
    assert np.array_equal(np.asarray(fields[0].energy), np.asarray(fields[1].energy))


def test_the_wall_model_is_validated_and_its_table_built():
    """The name is one of the scene's wall models (validated where the others are); the core
    gets the locally reacting walls plus the table (level-of-detail band groups each take their
    own: tests/sound/test_grazing_levels.py)."""
    from sonolux.scene.schema import WALL_MODELS
    from sonolux.sound import walls
    from sonolux.sound.options import SoundOptions

    assert "locally-reacting-modes" in WALL_MODELS
    SoundOptions(wall_model="locally-reacting-modes").validate()
    assert walls.core_model("locally-reacting-modes") == "locally-reacting"
    assert walls.core_model("random-incidence") == "random-incidence"
    scene = _paper_small_flat(500)
    assert walls.grazing_table(scene, "locally-reacting", np.zeros((2, 1))) is None
    table = walls.grazing_table(scene, "locally-reacting-modes", np.array([[0.05], [0.3]]))
    assert table is not None and table[0].shape == (3, 3) and table[2].shape == (3, 1)
    assert table[4].shape == (3, 1, PROFILE_NODES)


def _split_floor_room(floor_alphas, ceiling_alpha, bands_hz):
    """An 8 × 6 × 3 m room whose floor is half one material, half another (along x), the
    ceiling and walls a third: (vertices, triangles, material index, absorption[3, band])."""
    length, width, height = 8.0, 6.0, 3.0
    v: list = []
    t: list = []
    m: list = []

    def quad(corners, material):
        i = len(v)
        v.extend(corners)
        t.extend([[i, i + 1, i + 2], [i, i + 2, i + 3]])
        m.extend([material, material])
    quad([[0, 0, 0], [0, width, 0], [length / 2, width, 0], [length / 2, 0, 0]], 0)
    quad([[length / 2, 0, 0], [length / 2, width, 0], [length, width, 0], [length, 0, 0]], 1)
    quad([[0, 0, height], [length, 0, height], [length, width, height], [0, width, height]], 2)
    quad([[0, 0, 0], [length, 0, 0], [length, 0, height], [0, 0, height]], 2)
    quad([[0, width, 0], [0, width, height], [length, width, height], [length, width, 0]], 2)
    quad([[0, 0, 0], [0, 0, height], [0, width, height], [0, width, 0]], 2)
    quad([[length, 0, 0], [length, width, 0], [length, width, height], [length, 0, height]], 2)
    absorption = np.array([[a] * len(bands_hz) for a in (*floor_alphas, ceiling_alpha)], float)
    return np.array(v, float), np.array(t), np.array(m), absorption


def test_a_plane_of_several_materials_states_how_far_its_rate_may_be():
    """The rate of a pair whose plane holds several materials is taken from the area-weighted
    admittance (exact to first order in β: Kuttruff §3.5). ``mixed_plane_spread`` is its
    distance from the other limit (large patches, the mean of the patches' exact rates): 0 for
    planes of one material; for a split floor it falls faster than β itself (halving every α
    divides it by more than 3: the first-order terms are equal, the rest is at least second
    order; measured 9.0e-5 → 1.1e-5 at 250 Hz, α 0.01/0.04 under 0.02); and it is large where
    kDβ is (a floor of 0.05 and 0.3 at 1 kHz: measured 21 %), where the bake says so."""
    from types import SimpleNamespace

    from sonolux.sound import walls
    from sonolux.sound.grazing import interference_length_m, mixed_plane_spread
    bands = np.array([250.0, 1000.0])
    v, t, m, a = _split_floor_room((0.05, 0.05), 0.05, bands)
    assert np.all(mixed_plane_spread(v, t, m, a, bands, 343.0) == 0)
    small = [mixed_plane_spread(*_split_floor_room((x, 4 * x), 2 * x, [250.0]), [250.0],
                                343.0).max() for x in (0.01, 0.005)]
    assert 0 < small[1] < small[0] / 3, small
    v, t, m, a = _split_floor_room((0.05, 0.3), 0.05, bands)
    spread = mixed_plane_spread(v, t, m, a, bands, 343.0)
    assert 0.1 < spread.max() < 0.5
    said: list[str] = []
    settings = SimpleNamespace(band_set=SimpleNamespace(exact_hz=bands), speed_of_sound_m_s=343.0)
    scene = SimpleNamespace(vertices_m=v, triangles=t, material_index=m, settings=settings)
    assert walls.grazing_table(scene, "locally-reacting-modes", a, log=said.append) is not None
    assert len(said) == 1 and "several materials" in said[0] and "210 m" in said[0], said
    said.clear()
    walls.grazing_table(scene, "locally-reacting-modes", np.full_like(a, 0.05), log=said.append)
    assert said == []
    # The interference length: 4kD²/π far above mode 1's cut-on, none below it.
    k = 2 * np.pi * 1000 / 343
    assert abs(interference_length_m(k, 3.0) / (4 * k * 9 / np.pi) - 1) < 1e-3
    assert interference_length_m(0.9 * np.pi / 3.0, 3.0) == float("inf")


def test_the_image_sources_keep_the_plain_locally_reacting_walls():
    """Decided (docs/waves-grazing.md, "The image sources keep the locally reacting walls"): an
    image source is one term of the image series whose coherent sum the grazing mode is, so it
    keeps its own reflections' losses; the table does not reach it. A bake of paper-small with
    image sources up to order 2 (125 and 1000 Hz): the arrivals are the same with and without
    the grazing modes, bit for bit, while the particles' bits differ."""
    data = tomllib.loads(builtin.path("paper-small").read_text())
    data["settings"]["bands_hz"] = [125, 250]
    data["early"] = {"max_order": 2, "diffraction": False}
    scene = sonolux.load_scene(data)
    with_modes = bake(scene, rays=2000, wall_model="locally-reacting-modes", max_time_s=0.3)
    plain = bake(scene, rays=2000, wall_model="locally-reacting", max_time_s=0.3)
    a, b = with_modes.early, plain.early
    assert a is not None and len(np.asarray(a["energy"])) > 10
    for key in a:
        np.testing.assert_array_equal(np.asarray(a[key]), np.asarray(b[key]), err_msg=key)
    assert not np.array_equal(np.asarray(with_modes.energy), np.asarray(plain.energy))
