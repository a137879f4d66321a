"""Level of detail (docs/early-sound.md, crates/sonolux-core/src/early/lod.rs,
python/sonolux/scene/simplify.py): per band, features small against the wavelength (ka < 1)
replaced by the surface they sit on; on what remains, Rindel's finite-panel specular share K,
computed per reflection from the legs before and after it (Christensen and Rindel's
reflection-based scattering), applied alike by the image sources and the particles.

- no double counting with level of detail on: a hybrid (image sources to order 2) and a bake
  whose reflections are all the particles' agree in energy per band within the Monte Carlo
  error, in a room with furniture whose small faces make K < 1;
- what level of detail changes: the furniture's faces scatter more at low frequencies, so the
  early specular energy falls there and not at high frequencies;
- same bits on 1 and 2 threads.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import sonolux
from sonolux.sound.bake import bake

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "furniture"))
from rooms import boxes_on_wall, furniture, write_obj  # noqa: E402

pytestmark = pytest.mark.usefixtures("core")

BANDS = [125, 250, 500, 1000, 2000, 4000]
ROOM = (7.0, 5.0, 2.8)
SOURCE = (5.8, 1.2, 1.5)
#: The first sees a first-order reflection off the table top 2.5 cm from its edge (its ball
#: straddles the edge of the reflection's validity region).
RECEIVERS = ((3.5, 4.2, 1.2), (1.5, 1.2, 1.2), (3.0, 4.2, 1.5))


def furnished(tmp_path: Path, early: dict, seed: int = 1, threads: int = 0):
    obj = tmp_path / "furniture.obj"
    if not obj.exists():
        write_obj(obj, furniture())
    data = {
        "name": "furnished", "settings": {"bands_hz": BANDS, "seed": seed, "threads": threads},
        "materials": {"wood": {"absorption": 0.06, "scattering": [0.05] * 4 + [0.3] * 4},
                      "room": {"absorption": [0.25, 0.2, 0.15, 0.12, 0.1, 0.1, 0.12, 0.15],
                               "scattering": 0.1}},
        "geometry": [{"type": "shoebox", "size_m": list(ROOM), "materials": {"default": "room"}},
                     {"type": "mesh", "file": str(obj), "material": "wood"}],
        "sources": [{"position_m": list(SOURCE)}],
        "receivers": {"type": "points", "positions_m": [list(r) for r in RECEIVERS],
                      "radius_m": 0.3},
        "early": dict({"diffraction": False, "level_of_detail": True}, **early),
    }
    return sonolux.load_scene(data)


def totals(field, split_s):
    """Energy per receiver and band before and after split_s, float64[receiver, 2 · band]."""
    out = []
    for r in range(field.energy.shape[0]):
        e = field.omni_energy(r)
        before = field.bin_start_s < split_s
        out.append(np.concatenate([e[:, before].sum(axis=1), e[:, ~before].sum(axis=1)]))
    return np.array(out)


def test_level_of_detail_counts_nothing_twice(tmp_path):
    # Same seeds, hybrid (image sources to order 2 with K, particles leave those paths out)
    # against a bake whose reflections are all the particles' (order 0: the exact direct sound
    # only), both with level of detail. Before the transition the difference is (images' K-
    # weighted energy) − (particles' specular-only part with s' = 1 − (1 − s)K), zero in
    # expectation; the mean over seeds must lie within 4 standard errors of zero, per band and
    # receiver. After the transition both count the same paths. Sensitivity: at receiver 1 the
    # images lose 18 % (125 Hz) to 6 % (4 kHz) of the early energy to K; a tracer that did not
    # scatter it (the state before this change) fails by about 14 standard errors at 125 Hz.
    # Receiver 0's reflection off the table top lies 2.5 cm from the table's edge, so part of
    # its ball sees it: the images weigh each arrival by the share of the ball that sees it, as
    # the particles do (image_sources.rs, seen_over_ball). Measured there before that: +4.3 to
    # +6.6 % (6 to 8.5 standard errors, level of detail off); after: within 1.7 standard errors
    # (≤ 1.9 % on every receiver and band, with and without level of detail).
    diffs, ref = [], []
    for seed in (21, 22, 23, 24, 25):
        kw = dict(seed=seed)
        pure = bake(furnished(tmp_path, {"max_order": 0, "transition_ms": 30}, **kw),
                    rays=40_000, air_absorption=False, max_time_s=0.25)
        hybrid = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 30}, **kw),
                      rays=40_000, air_absorption=False, max_time_s=0.25)
        p, h = totals(pure, 0.030), totals(hybrid, 0.030)
        diffs.append(h - p)
        ref.append(p)
    diffs, ref = np.array(diffs), np.mean(ref, axis=0)
    mean, err = diffs.mean(axis=0), diffs.std(axis=0, ddof=1) / math.sqrt(len(diffs))
    assert np.all(np.abs(mean) <= 4 * err + 1e-6 * ref), (mean / ref, err / ref)
    assert np.all(np.abs(mean) / ref < 0.05), mean / ref


def test_level_of_detail_takes_specular_energy_from_small_faces_at_low_frequencies(tmp_path):
    # The image sources alone: with level of detail, reflections on the furniture (table top
    # 3 × 1.2 m, chair seats 0.45 m, shelves 0.35 m deep) lose their specular share where the
    # panel is small against the wavelength, reflections on the 7 × 5 m floor and ceiling do
    # not. So the early specular energy of the paths both bakes find falls more at 125 Hz than
    # at 4 kHz, and from 250 Hz (the full mesh) never rises. At 125 Hz the chairs and table legs
    # (ka < 1) are left out, so paths they blocked, wholly or over part of a receiver's ball,
    # may appear or grow there: new arrivals hold 125 Hz energy only.
    on = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 40}), rays=200,
              air_absorption=False, max_time_s=0.1)
    off = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 40,
                                    "level_of_detail": False}), rays=200,
               air_absorption=False, max_time_s=0.1)

    def keyed(early):
        keys = zip(early["receiver"].tolist(), np.round(early["time_s"] * 1e9).tolist(),
                   early["order"].tolist(), early["kind"].tolist())
        return {k: e for k, e in zip(keys, early["energy"])}
    e_on, e_off = keyed(on.early), keyed(off.early)
    assert set(e_off) <= set(e_on)
    for k in set(e_on) - set(e_off):
        assert np.all(e_on[k][1:] == 0.0) and e_on[k][0] > 0.0, (k, e_on[k])
    both_on = np.array([e_on[k] for k in e_off])
    both_off = np.array(list(e_off.values()))
    assert np.all(both_on[:, 1:] <= both_off[:, 1:] * (1 + 1e-12))
    ratio = both_on.sum(axis=0) / both_off.sum(axis=0)
    assert ratio[0] < ratio[-1] and ratio[0] < 0.999, ratio


def test_level_of_detail_is_the_same_on_one_and_two_threads(tmp_path):
    fields = [bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 30}, threads=t),
                   rays=3000, air_absorption=False, max_time_s=0.2) for t in (1, 2)]
    np.testing.assert_array_equal(fields[0].energy, fields[1].energy)
    for k, v in fields[0].early.items():
        np.testing.assert_array_equal(fields[1].early[k], v)


# --- a wall of small boxes against a flat wall ----------------------------------------------

BOX_BANDS = [63, 125, 250, 500, 1000, 2000, 4000]
BOX_ALPHA_HARD, BOX_ALPHA_ROOM = 0.03, 0.12


def box_room(tmp_path: Path, boxes: bool, level_of_detail: bool = True, rays: str = "octave",
             channels: list | None = None, connections: bool = True):
    """8 × 6 × 3 m; the west wall and its boxes hard (α 0.03, s 0.05), the rest α 0.12, s 0.2;
    nine listeners at 1.2 m. Level of detail applies to every reflection (max_order 0: the
    direct sound exact, every reflection the particles')."""
    from rooms import BOX_ROOM_M
    obj = tmp_path / "boxes.obj"
    if boxes and not obj.exists():
        write_obj(obj, {"boxes": boxes_on_wall()})
    faces = ("floor", "ceiling", "west", "east", "south", "north")
    data = {
        "name": "box wall" if boxes else "flat wall",
        "settings": {"bands_hz": BOX_BANDS, "seed": 2},
        "materials": {"hard": {"absorption": BOX_ALPHA_HARD, "scattering": 0.05},
                      "room": {"absorption": BOX_ALPHA_ROOM, "scattering": 0.2}},
        "geometry": [{"type": "shoebox", "size_m": list(BOX_ROOM_M),
                      "materials": {f: "hard" if f == "west" else "room" for f in faces}}],
        "sources": [{"position_m": [6.5, 2.2, 1.5]}],
        "receivers": {"type": "points", "radius_m": 0.3,
                      "positions_m": [[x, y, 1.2] for x in (1.5, 3.5, 5.5)
                                      for y in (1.2, 3.0, 4.8)]},
        "early": {"max_order": 0, "diffraction": False, "level_of_detail": level_of_detail,
                  "level_of_detail_rays": rays, "diffuse_connections": connections},
    }
    if boxes:
        data["geometry"].append({"type": "mesh", "file": str(obj), "material": "hard"})
    if channels is not None:
        data["receivers"]["channels"] = channels
    return sonolux.load_scene(data, base_dir=tmp_path)


def eyring_t60_s(boxes: bool) -> float:
    """Eyring's T60 (no air) of the box-wall room: 50 cubes of 0.3 m add 27 m² of hard surface
    and take 1.35 m³ of air."""
    from rooms import BOX_ROOM_M, BOX_SIZE_M
    lx, ly, lz = BOX_ROOM_M
    n = len(boxes_on_wall()) if boxes else 0
    volume = lx * ly * lz - n * BOX_SIZE_M ** 3
    hard = ly * lz + n * 6 * BOX_SIZE_M ** 2
    rest = 2 * (lx * ly + lx * lz + ly * lz) - ly * lz
    area = hard + rest
    mean_alpha = (hard * BOX_ALPHA_HARD + rest * BOX_ALPHA_ROOM) / area
    return 0.161 * volume / (-area * math.log(1.0 - mean_alpha))


@pytest.fixture(scope="module")
def box_and_flat(tmp_path_factory):
    """Mean T30 and EDT over the nine listeners, {boxes: {key: float[band]}}, 100,000 rays."""
    from sonolux.analysis.params import room_parameters
    tmp = tmp_path_factory.mktemp("boxes")
    means = {}
    for boxes in (False, True):
        field = bake(box_room(tmp, boxes), rays=100_000, air_absorption=False, max_time_s=2.0)
        v = room_parameters(field, theory=False, sti=False).values
        means[boxes] = {k: np.nanmean(v[k], axis=0)[:len(BOX_BANDS)] for k in ("t30_s", "edt_s")}
    return means


@pytest.mark.slow
def test_a_wall_of_small_boxes_decays_more_diffusely_at_4_khz(box_and_flat):
    # Measure of diffuseness: how far T30 lies from Eyring's diffuse-field T60 (Eyring assumes
    # a diffuse field; a specular room with one hard wall decays slower). Measured (100,000
    # rays, nine listeners, each octave its own rays): flat wall +8.4 %, box wall +4.4 … +4.6 %
    # over seeds 2-5 (its 0.3 m faces keep K ≈ 0.07 at 4 kHz, so they scatter). Asserted: the
    # flat wall's deviation is above the 5 % JND of T30, and the box wall's is below it by 2 %
    # of T30, ten times the seed-to-seed spread. (With rays shared by all bands the box wall
    # gave +2.3 … +6.1 %: K's per-band weights made it noisy.)
    flat = box_and_flat[False]["t30_s"][-1] / eyring_t60_s(False) - 1.0
    box = box_and_flat[True]["t30_s"][-1] / eyring_t60_s(True) - 1.0
    assert flat > 0.05 and box < flat - 0.02, (flat, box)


@pytest.mark.slow
def test_a_wall_of_small_boxes_is_a_flat_wall_at_low_frequencies(box_and_flat):
    # The issue's criterion: at 63 and 125 Hz the same T30 and EDT within 3 %, once the boxes'
    # own 27 m² of surface and 1.35 m³ of volume are accounted for by the ratio of Eyring's T60
    # of the two rooms (0.958: the boxes add 4 % of absorption area whatever the model).
    # With the per-band geometry (sonolux.scene.simplify) the 0.3 m cubes (ka < 1 up to 210 Hz)
    # are replaced at 63-125 Hz by the wall they hang on, which takes their absorption area.
    # Measured: T30 0.989/0.985, EDT 0.993/0.993 of that ratio (seed 2); the volume they give
    # back to the air (+0.9 %) is the largest known bias. With Rindel's K alone: 0.947-0.953.
    expected = eyring_t60_s(True) / eyring_t60_s(False)
    for key in ("t30_s", "edt_s"):
        ratio = box_and_flat[True][key][:2] / box_and_flat[False][key][:2] / expected
        assert np.all(np.abs(ratio - 1.0) < 0.03), (key, ratio)


# --- the per-band geometry (sonolux.scene.simplify) ------------------------------------------

def box_levels(tmp_path: Path):
    from sonolux.scene.simplify import band_levels
    from sonolux.sound.bake import band_arrays
    scene = box_room(tmp_path, True)
    arrays = band_arrays(scene)
    return scene, arrays, band_levels(scene.vertices_m, scene.triangles, scene.material_index,
                                      arrays["absorption"], arrays["scattering"],
                                      scene.settings.band_set.exact_hz,
                                      scene.settings.speed_of_sound_m_s)


def test_small_boxes_leave_the_low_bands_and_keep_their_absorption_area(tmp_path):
    # The 0.3 m cubes hold a radius a = 0.26 m: ka < 1 below 210 Hz, so 63 and 125 Hz see the
    # flat wall, 250 Hz and up the boxes. The absorption area Σ α S over every triangle is the
    # same in both geometries, band by band (to rounding: no α' reaches 1 here), the boxes'
    # volume (50 × 0.027 m³) goes back to the air, and the wall's added scattering grows as
    # Rayleigh's f⁴ (a 2× band ratio of 63 → 125 Hz gives 16×, to the exact centres' ratio).
    scene, arrays, levels = box_levels(tmp_path)
    assert [(lv.bands.start, lv.bands.stop, lv.removed) for lv in levels] == [(0, 2, 50), (2, 7, 0)]
    low = levels[0]
    v, t = scene.vertices_m, scene.triangles

    def area_alpha(tris, mats, alpha):
        c = v[tris]
        area = 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)
        return (area[:, None] * alpha[mats]).sum(axis=0)

    full = area_alpha(t, scene.material_index, arrays["absorption"])
    simple = area_alpha(low.triangles, low.material_index, low.absorption)
    np.testing.assert_allclose(simple, full, rtol=1e-12)
    assert low.volume_added_m3 == pytest.approx(50 * 0.3 ** 3, rel=1e-9)
    assert not np.any(low.area_lost_m2)
    wall = low.material_index.max()  # the west wall's new material
    s_hard = 0.05  # the west wall's own scattering
    added = 1.0 - (1.0 - low.scattering[wall]) / (1.0 - s_hard)
    f = scene.settings.band_set.exact_hz
    assert added[1] / added[0] == pytest.approx((f[1] / f[0]) ** 4, rel=1e-9)
    assert 0.0 < added[1] < 0.1


def test_what_is_traced_as_one_geometry(tmp_path):
    # Without level of detail, or with rays shared by a level and no small feature (the flat
    # wall's room is one piece, its shell), the bake is the plain one: the same bits as before.
    # With rays per octave (box_room's; the scene default shares rays) an octave bake traces
    # each band alone; the box wall's two levels (63-125 Hz without the boxes) then share one
    # simplified geometry.
    from sonolux.sound import levels
    from sonolux.sound.bake import band_arrays
    for scene in (box_room(tmp_path, True, level_of_detail=False),
                  box_room(tmp_path, False, rays="level")):
        assert levels.plan(scene, band_arrays(scene)) is None
    scene = box_room(tmp_path, True)
    plan = levels.plan(scene, band_arrays(scene))
    assert [(p.level.bands.start, p.level.bands.stop) for p in plan] == [(b, b + 1) for b in range(7)]
    assert plan[0].geometry is plan[1].geometry and plan[2].geometry is scene.geometry
    assert [p.level.removed for p in plan] == [50, 50, 0, 0, 0, 0, 0]


def test_bands_within_an_octave_share_rays():
    # Thirds: 63-80-100 Hz together, 125 Hz starts the next group (ratio 10^0.3, base 10).
    from sonolux.scene.simplify import Level
    from sonolux.sound.levels import by_octave
    f = 1000.0 * 10.0 ** (0.1 * np.arange(-12, 1))  # 63 Hz … 1 kHz in thirds, exact
    z = np.zeros((1, f.size))
    groups = by_octave([Level(slice(0, 13), np.zeros((0, 3), int), np.zeros(0, int), z, z)], f)
    assert [(g.bands.start, g.bands.stop) for g in groups] == [(0, 3), (3, 6), (6, 9), (9, 12),
                                                              (12, 13)]


def test_per_band_geometry_ranges_merge_to_the_bits_of_one_bake(tmp_path):
    # Each band group traces its own rays: ray ranges of a bake with levels still add up
    # exactly, whichever order they are merged in.
    kw = dict(air_absorption=False, max_time_s=0.3)
    scene = box_room(tmp_path, True)
    whole = bake(scene, rays=3000, ray_range=(0, 3000), **kw)
    a = bake(scene, rays=3000, ray_range=(0, 1100), **kw)
    b = bake(scene, rays=3000, ray_range=(1100, 3000), **kw)
    for merged in (a.merge(b), b.merge(a)):
        np.testing.assert_array_equal(merged.energy, whole.energy)


def test_per_band_geometry_is_the_same_on_one_and_two_threads(tmp_path):
    from dataclasses import replace
    scene = box_room(tmp_path, True)
    fields = [bake(replace(scene, settings=replace(scene.settings, threads=t)), rays=3000,
                   air_absorption=False, max_time_s=0.3) for t in (1, 2)]
    np.testing.assert_array_equal(fields[0].energy, fields[1].energy)


def test_per_band_geometry_holds_in_a_progressive_bake(tmp_path):
    # The progressive bake traces rounds of ray ranges and sums their counts: with levels it
    # ends with the field of a plain bake of as many rays, to float32 rounding (its energy is
    # counts × a rescaled quantum: 1.6e-7 relative without level of detail too).
    from sonolux.sound import progressive
    scene = box_room(tmp_path, True)
    options = sonolux.SoundOptions(air_absorption=False, max_time_s=0.3)
    field, _ = progressive.bake(scene, options, progressive.Accuracy(5.0))
    plain = bake(scene, rays=field.settings["rays"], air_absorption=False, max_time_s=0.3)
    np.testing.assert_allclose(np.asarray(field.energy), np.asarray(plain.energy), rtol=1e-6,
                               atol=0)


def test_the_memory_plan_counts_the_join_and_one_band_group(tmp_path):
    # With levels a tile holds its field joined over every band (float32, + u64 counts for a
    # ray range) and the tracer's ≈ 20-byte cells of one band group (sonolux.sound.levels.trace),
    # not the tracer's cells of every band: the plan's bytes a receiver are exactly that, and
    # the bake plans with its largest group (the octave bake's: one band) and says so.
    from sonolux.sound import levels
    from sonolux.sound.bake import band_arrays, memory_plan
    from sonolux.sound.budget import trace_bytes_per_cell
    scene = box_room(tmp_path, True)
    arrays = band_arrays(scene)
    assert levels.largest_group(levels.plan(scene, arrays)) == 1
    assert levels.largest_group(None) is None
    options = sonolux.SoundOptions(rays=3000, storage="full", max_time_s=0.3).validate()
    plain = memory_plan(scene, options, arrays, settings_of=(3000, 0.3))
    cells, bands = plain.shape.cells_per_receiver, plain.shape.bands
    assert plain.tile_bytes == plain.tile_receivers * math.ceil(cells * trace_bytes_per_cell(bands))
    for group, ray_range, value in ((1, None, 4), (bands - 1, (0, 1000), 12)):
        with_levels = memory_plan(scene, sonolux.SoundOptions(
            rays=3000, storage="full", max_time_s=0.3, ray_range=ray_range).validate(), arrays,
            settings_of=(3000, 0.3), group_bands=group)
        per_receiver = cells * value + math.ceil(cells * group // bands * trace_bytes_per_cell(group))
        assert with_levels.tile_bytes == with_levels.tile_receivers * per_receiver
    notes: list[str] = []
    bake(scene, rays=500, storage="full", max_time_s=0.3, log=notes.append)
    assert any(n.startswith("memory:") and "one group of 1 band(s)" in n for n in notes), notes


def sloped_array(path: Path) -> None:
    """A GeneralTF array of one capsule, the same in every direction, |H|² = (f / 1 kHz)²: its
    band gains differ by about 12 dB an octave (0.004 at 63 Hz, 16 at 4 kHz)."""
    import sofar
    az, el = np.meshgrid(np.arange(0, 360, 10.0), np.arange(-90, 91, 10.0))
    f = np.geomspace(20, 20000, 200)
    s = sofar.Sofa("GeneralTF")
    s.SourcePosition = np.stack([az.ravel(), el.ravel(), np.ones(az.size)], axis=1)
    s.SourcePosition_Type = "spherical"
    s.SourcePosition_Units = "degree, degree, metre"
    s.ReceiverPosition = np.zeros((1, 3))
    s.N = f
    s.Data_Real = np.broadcast_to(f / 1000.0, (az.size, 1, f.size)).copy()
    s.Data_Imag = np.zeros_like(s.Data_Real)
    sofar.write_sofa(str(path), s)


def test_sofa_receiver_channels_take_each_band_groups_own_gains(tmp_path):
    # A SOFA channel with level of detail: each band group's tracer and image sources see that
    # group's gains. A capsule the same in every direction weighs every arrival by its band's
    # gain, so beside an omni channel at the same point its energy is the band's gain times
    # the omni's, band by band (the library's own band means: sofa_receiver_gains). Tolerance
    # 1e-5: the two channels' deposits are rounded to the fixed-point quantum apart (~1e-12).
    # A mixed-up group (its gains from another band) would be off by 12 dB an octave. The
    # early diffuse connections are off: with 18 channels they draw 8 receivers a reflection,
    # independently for the two channels of a point, which would add Monte Carlo noise to the
    # ratio. Ray ranges and threads: see the next test.
    from sonolux.scene.receiver_channels import sofa_receiver_gains
    from sonolux.sound import levels
    from sonolux.sound.bake import band_arrays
    sloped_array(tmp_path / "sloped.sofa")
    scene = box_room(tmp_path, True, channels=["omni", {"sofa": "sloped.sofa", "name": "mic"}],
                     connections=False)
    assert len(levels.plan(scene, band_arrays(scene))) == len(BOX_BANDS)
    field = bake(scene, rays=1000, air_absorption=False, max_time_s=0.3)
    e = np.asarray(field.energy, float).sum(axis=(1, 3)).reshape(9, 2, -1)
    capsule = scene.receivers.channels[1].sofa
    gain = sofa_receiver_gains(capsule, scene.settings.band_set.edges_hz)[0, 0]
    assert gain[-1] / gain[0] > 1e3
    np.testing.assert_allclose(e[:, 1] / e[:, 0], np.broadcast_to(gain, e[:, 0].shape),
                               rtol=1e-5)


def test_band_groups_whose_gains_peak_differently_share_one_quantum(tmp_path):
    # The sloped capsule peaks at 0.004 in the lowest group and 16 in the highest: each group
    # alone would have its own fixed-point quantum (4000× apart) and ray ranges could not add
    # their counts. Every group takes the whole bake's quantum (engine.sound_quantum of every
    # band's sources and receivers): ranges merge to the bits of one bake in either order, one
    # and two threads give the same bits, and every range has the same quantum. Early diffuse
    # connections on (their draws are keyed like every other random number).
    from dataclasses import replace
    sloped_array(tmp_path / "sloped.sofa")
    scene = box_room(tmp_path, True, channels=["omni", {"sofa": "sloped.sofa", "name": "mic"}])
    kw = dict(air_absorption=False, max_time_s=0.3, storage="full")
    whole = bake(scene, rays=1200, ray_range=(0, 1200), **kw)
    a = bake(scene, rays=1200, ray_range=(0, 500), **kw)
    b = bake(scene, rays=1200, ray_range=(500, 1200), **kw)
    for merged in (a.merge(b), b.merge(a)):
        np.testing.assert_array_equal(merged.energy, whole.energy)
    two = bake(replace(scene, settings=replace(scene.settings, threads=2)), rays=1200,
               ray_range=(0, 1200), **kw)
    one = bake(replace(scene, settings=replace(scene.settings, threads=1)), rays=1200,
               ray_range=(0, 1200), **kw)
    np.testing.assert_array_equal(one.energy, two.energy)
    np.testing.assert_array_equal(one.energy, whole.energy)
    assert a.quantum == b.quantum == whole.quantum > 0


def test_receiver_tiles_whose_channels_peak_differently_share_one_quantum(tmp_path):
    # An omni channel (peak gain 1) and the sloped capsule (peak 16) at each point; a memory
    # budget that traces the 18 receivers in tiles. Each tile used to take the quantum of its
    # own receivers' peak, and a ray range's counts were joined under one of them: merged, the
    # field was off by 0.1 % of its largest value (silently). Every tile now takes the whole
    # bake's quantum: the merged tiled ranges are the untiled bake, bit for bit.
    sloped_array(tmp_path / "sloped.sofa")
    scene = box_room(tmp_path, False, level_of_detail=False,
                     channels=["omni", {"sofa": "sloped.sofa", "name": "mic"}])
    kw = dict(air_absorption=False, max_time_s=0.3, storage="full")
    whole = bake(scene, rays=1200, ray_range=(0, 1200), **kw)
    a = bake(scene, rays=1200, ray_range=(0, 500), memory_bytes=400_000_000, **kw)
    b = bake(scene, rays=1200, ray_range=(500, 1200), **kw)
    assert a.stats["tiles"] > 1
    np.testing.assert_array_equal(a.merge(b).energy, whole.energy)
