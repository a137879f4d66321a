"""A field per source: a scene with several sources keeps each source's field, and each is,
bit for bit, what a bake of that source alone gives (whole, in ray ranges, compact or full,
hybrid); files hold them in /sound/sources/<k>/ and read back the same; mixes are sums."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field, save_fields
from sonolux.range_bake import bake_ranges
from sonolux.sound.bake import bake as bake_whole
from sonolux.sound.ranges import SoundRanges
from sonolux.sound.ranges import bake as in_ranges

pytestmark = pytest.mark.usefixtures("core")
RAYS = 2000

ROOM = {
    "name": "two talkers",
    "settings": {"sample_rate_hz": 8000, "bands_hz": [500, 1000, 2000], "seed": 7,
                 "max_time_s": 0.5},
    "geometry": [{"type": "shoebox", "size_m": [6.0, 5.0, 3.0],
                  "materials": {"walls": "plaster-smooth", "floor": "carpet-on-concrete",
                                "ceiling": "concrete-painted"}}],
    "sources": [{"name": "desk", "position_m": [1.5, 1.5, 1.2], "power_w": 0.01},
                {"name": "door", "position_m": [4.5, 3.5, 1.6], "power_w": 0.02,
                 "directivity": "cardioid", "forward": [-1.0, 0.0, 0.0]},
                {"name": "fan", "position_m": [3.0, 4.2, 2.5]}],
    "receivers": {"type": "points", "positions_m": [[3.0, 2.5, 1.2], [5.0, 1.0, 1.2], [1.0, 4.0, 1.5]],
                  "radius_m": 0.3},
}
NAMES = ["desk", "door", "fan"]


class Stop(Exception):
    """Stands for a kill, raised from the progress callback."""


def scene(**changes):
    return sonolux.load_scene({**ROOM, **changes})


def same(a, b):
    """Bit-equal [receiver, direction, band, time] arrays, dense or compact."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8))


@pytest.fixture(scope="module")
def room():
    return scene()


@pytest.mark.parametrize("storage", ["compact", "full"])
@pytest.mark.parametrize("estimator", ["paper", "rain"])
def test_each_source_equals_a_bake_of_that_source_alone(room, storage, estimator):
    both = bake_whole(room, rays=RAYS, storage=storage, estimator=estimator)
    assert both.source_names == NAMES
    for k, name in enumerate(NAMES):
        alone = bake_whole(room, rays=RAYS, storage=storage, estimator=estimator,
                           sources=(name,))
        assert alone.source_names == [name] and alone.per_source is None
        mine = both.for_source(name)
        same(mine.energy, alone.energy)
        same(both.for_source(k).energy, alone.energy)
        np.testing.assert_array_equal(mine.source_positions_m, alone.source_positions_m)
        assert alone.stats["rays"] == RAYS


def test_the_sum_is_the_mix_of_unit_gains_and_differs_per_source(room):
    field = bake_whole(room, rays=RAYS)
    parts = [np.asarray(field.for_source(k).energy, np.float64) for k in range(3)]
    total = np.asarray(field.energy)
    # float32 of the float64 sum, in source order: exact to the one rounding.
    np.testing.assert_array_equal(total, (parts[0] + parts[1] + parts[2]).astype(np.float32))
    same(field.mixed([1, 1, 1]).energy, total)
    half = field.mixed({"door": 0.5})
    np.testing.assert_array_equal(np.asarray(half.energy),
                                  (0.5 * parts[1]).astype(np.float32))
    assert half.source_names == ["mix"]
    # The sources really differ: the desk's direct sound reaches receiver 0 first.
    assert not np.array_equal(parts[0], parts[1])
    # Energy adds (each source's total over the receivers is a share of the whole).
    np.testing.assert_allclose(sum(p.sum() for p in parts), total.astype(np.float64).sum(),
                               rtol=1e-6)


def test_unknown_source_and_bad_gains_are_named(room):
    field = bake_whole(room, rays=500)
    with pytest.raises(SonoluxError, match="desk.*door.*fan"):
        field.for_source("window")
    with pytest.raises(SonoluxError, match="3"):
        field.for_source(3)
    with pytest.raises(SonoluxError, match="2 given for 3 sources"):
        field.mixed([1, 1])
    with pytest.raises(SonoluxError, match="gain"):
        field.mixed([1, -1, 1])
    with pytest.raises(SonoluxError, match="its sources are desk, door, fan"):
        bake_whole(room, rays=500, sources=("window",))


@pytest.mark.parametrize("storage", ["compact", "full"])
def test_a_field_per_source_round_trips_through_the_file(room, storage, tmp_path):
    field = bake_whole(room, rays=RAYS, storage=storage)
    path = save_fields(tmp_path / "f.h5", sound=field)
    import h5py
    with h5py.File(path) as f:
        assert sorted(f["sound/sources"]) == ["0", "1", "2"]
        assert "energy" not in f["sound"]
        assert f["sound/sources/1"].attrs["name"] == "door"
    back = open_field(path)
    assert back.source_names == NAMES
    for k in range(3):
        same(back.for_source(k).energy, field.for_source(k).energy)
    same(back.energy, field.energy)


def test_ranges_resume_give_the_bits_of_one_bake_per_source(room, tmp_path):
    whole = bake_whole(room, rays=RAYS)
    seen = []

    def stop_after_two(done, total, elapsed):
        if done % 700 == 0 and done and done not in seen:
            seen.append(done)
            if len(seen) == 2:
                raise Stop
        return True

    with pytest.raises(Stop):  # killed after two ranges, then resumed
        bake_ranges(SoundRanges(room, sonolux.SoundOptions(rays=RAYS)), checkpoint=tmp_path / "c",
                    checkpoint_every_s=0, range_rays=700, progress=stop_after_two)
    ranged = in_ranges(room, sonolux.SoundOptions(rays=RAYS), checkpoint=tmp_path / "c",
                       resume=True, checkpoint_every_s=0, range_rays=700)
    assert ranged.source_names == NAMES
    for k in range(3):
        same(ranged.for_source(k).energy, whole.for_source(k).energy)
    parts = [bake_whole(room, rays=RAYS, ray_range=r) for r in ((0, 900), (900, RAYS))]
    merged = parts[1].merge(parts[0])
    for k in range(3):
        same(merged.for_source(k).energy, whole.for_source(k).energy)


def test_hybrid_arrivals_go_to_their_source(room):
    hybrid = scene(early={"max_order": 2})
    both = bake_whole(hybrid, rays=RAYS)
    for k, name in enumerate(NAMES):
        alone = bake_whole(hybrid, rays=RAYS, sources=(name,))
        mine = both.for_source(k)
        same(mine.energy, alone.energy)
        for key in alone.early:
            np.testing.assert_array_equal(mine.early[key], alone.early[key])
        assert mine.early["receiver"].max() < 3


def test_one_source_files_and_old_files_keep_their_layout(tmp_path):
    one = scene(sources=[ROOM["sources"][0]])
    field = bake_whole(one, rays=500)
    assert field.source_names == ["desk"] and field.for_source("desk") is field
    path = save_fields(tmp_path / "one.h5", sound=field)
    import h5py
    with h5py.File(path) as f:
        assert "sources" not in f["sound"] and "energy" in f["sound"]
    old = open_field("tests/data/field-v1.h5")
    assert old.source_names == ["all"] and old.for_source("all") is old


def test_a_progressive_bake_keeps_a_field_per_source_with_the_bits_of_a_whole_bake(room):
    from sonolux.sound import progressive

    cap = 6000
    field, _ = progressive.bake(room, accuracy=progressive.Accuracy(0.01, max_rays=cap))
    assert field.source_names == NAMES
    rays = field.settings["rays"]
    whole = bake_whole(room, rays=rays)
    for k in range(3):
        same(field.for_source(k).energy, whole.for_source(k).energy)


def test_the_sources_counts_add_up_to_a_bake_of_all_at_once(room, monkeypatch):
    """Each deposit's rounding is keyed by (seed, source, ray, receiver, event) and the
    fixed-point counts are integers, so the sources traced one by one add up, count for count,
    to the core tracing them all in one pass (only_source None): nothing is lost or doubled."""
    from sonolux import engine

    calls = []
    real = engine.trace_sound

    def together(geometry, acoustics, sources, receivers, settings, progress, early):
        calls.append(settings)
        return real(geometry, acoustics, sources, receivers, settings, progress, early)

    monkeypatch.setattr(engine, "trace_sound", together)
    split = bake_whole(room, rays=RAYS, ray_range=(0, RAYS), storage="full")
    assert len(calls) == 3  # one pass a source
    n = split.n_receivers
    per_source = np.asarray(split.counts).reshape(3, n, *split.counts.shape[1:])
    from sonolux.sound.bake import _directivity, band_arrays

    arrays = band_arrays(room)
    sources = [engine.SoundSource(tuple(s.position_m), s.power_w,
                                  _directivity(s, room.settings.band_set.edges_hz))
               for s in room.sources]
    settings = engine.SoundSettings(
        rays=RAYS, first_ray=0, end_ray=RAYS, seed=room.settings.seed, threads=2,
        estimator="paper", speed_of_sound_m_s=room.settings.speed_of_sound_m_s,
        air_attenuation_per_m=arrays["air"].tolist(),
        energy_drop_db=room.settings.energy_drop_db, max_time_s=split.settings["max_time_s"],
        sample_rate_hz=float(room.settings.sample_rate_hz), early_s=split.settings["early_s"],
        late_bin_s=split.settings["stored_late_bin_s"], azimuth_bands=8, elevation_bands=1,
        max_field_bytes=2_000_000_000, keep_counts=True)
    out = real(room.geometry, engine.Acoustics(arrays["absorption"], arrays["scattering"]),
               sources, engine.Receivers(np.ascontiguousarray(room.receivers.positions_m, float),
                                         room.receivers.radius_m), settings, None, None)
    assert out["quantum"] == split.quantum
    np.testing.assert_array_equal(per_source.sum(axis=0, dtype=np.uint64), out["counts"])


def test_one_and_two_threads_give_each_source_the_same_bits():
    fields = [bake_whole(scene(settings={**ROOM["settings"], "threads": n}), rays=RAYS)
              for n in (1, 2)]
    for k in range(3):
        same(fields[0].for_source(k).energy, fields[1].for_source(k).energy)


def test_octaves_of_a_third_octave_field_keep_a_field_per_source():
    from sonolux.analysis.octaves import octave_field

    thirds = scene(settings={**{k: v for k, v in ROOM["settings"].items() if k != "bands_hz"},
                             "bands": "third-octave", "band_range_hz": [400, 2500]})
    field = bake_whole(thirds, rays=500)
    octaves = octave_field(field)
    assert octaves.source_names == NAMES and octaves.energy.shape[2] == 3
    for k in range(3):
        same(octaves.for_source(k).energy, octave_field(field.for_source(k)).energy)


def test_a_sources_field_keeps_its_own_directivity_for_sti(room):
    # STI refers the speech level to the talker's own axis (docs/sti.md): the field of the
    # cardioid "door" must carry the cardioid's on-axis gain, not the omni "desk"'s.
    field = bake_whole(room, rays=RAYS)
    assert field.settings["source_directivity"] == ["omni", "cardioid", "omni"]
    door = field.for_source("door")
    assert door.settings["source_directivity"] == ["cardioid"]
    assert door.settings["source_axis_gain"] == [field.settings["source_axis_gain"][1]]
    # a cardioid's Q, 3, from its tabulated pattern (measured 2.99976)
    assert door.settings["source_axis_gain"][0][0] == pytest.approx(3.0, rel=1e-3)
