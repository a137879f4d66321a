"""The sound bake in ranges: checkpointed and resumed in this process, the same bits as one bake;
an existing, damaged or foreign checkpoint handled as documented."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import sonolux
from sonolux import checkpoint as side
from sonolux.errors import SonoluxError
from sonolux.range_bake import bake_ranges
from sonolux.ranges import join, missing, split
from sonolux.sound.bake import bake as bake_whole
from sonolux.sound.ranges import SoundRanges, bake

pytestmark = pytest.mark.usefixtures("core")
RAYS = 3000
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def small():
    return sonolux.load_scene("paper-small")


@pytest.fixture(scope="module")
def whole(small):
    return bake_whole(small, rays=RAYS)


class Stop(Exception):
    """Stands for a kill: raised from the progress callback after some ranges."""


def stopped_after(small, path, ranges_done, **kw):
    """Bakes in ranges of 500 rays, checkpointing after each, and stops after ``ranges_done``."""
    finished = []

    def progress(done, total, elapsed):
        if done % 500 == 0 and done and done not in finished:
            finished.append(done)
            if len(finished) >= ranges_done:
                raise Stop
        return True

    with pytest.raises(Stop):
        bake_ranges(SoundRanges(small, sonolux.SoundOptions(rays=RAYS, **kw)), checkpoint=path,
                    checkpoint_every_s=0, range_rays=500, progress=progress)


def test_range_helpers():
    assert missing((0, 10), [(2, 4), (6, 8)]) == [(0, 2), (4, 6), (8, 10)]
    assert missing((0, 10), [(0, 10)]) == []
    assert join([(5, 9), (0, 5), (12, 13)]) == [(0, 9), (12, 13)]
    assert split([(0, 10), (20, 25)], 3) == [(0, 5), (5, 10), (20, 25)]


@pytest.mark.parametrize("estimator", ["paper", "rain"])
def test_ranges_with_checkpoints_give_the_bits_of_one_bake(small, tmp_path, estimator):
    one = bake_whole(small, rays=RAYS, estimator=estimator)
    path = tmp_path / "f.h5.checkpoint"
    field = bake(small, rays=RAYS, estimator=estimator, checkpoint=path, checkpoint_every_s=0,
                 range_rays=700)
    assert np.array_equal(field.energy, one.energy)
    assert field.counts is None and field.settings["ray_range"] == [0, RAYS]
    assert field.stats["rays"] == one.stats["rays"] and field.stats["segments"] == one.stats["segments"]
    assert not path.exists()


def test_a_stopped_bake_resumes_to_the_same_bits(small, whole, tmp_path):
    path = tmp_path / "f.h5.checkpoint"
    stopped_after(small, path, 3)
    header, _ = side.read(path)
    assert join([tuple(r) for r in header["done"]]) == [(0, 1000)]  # the third range was lost
    notes = []
    field, report = bake_ranges(SoundRanges(small, sonolux.SoundOptions(rays=RAYS)),
                                checkpoint=path, resume=True, range_rays=500, log=notes.append)
    assert report["restored"] == 1000 and report["ranges"][0] == [1000, 1500]
    assert "resuming" in notes[0]
    assert np.array_equal(field.energy, whole.energy)


def test_an_existing_checkpoint_stops_a_bake_without_resume(small, whole, tmp_path):
    path = tmp_path / "f.h5.checkpoint"
    stopped_after(small, path, 2)
    work = SoundRanges(small, sonolux.SoundOptions(rays=RAYS))
    with pytest.raises(SonoluxError, match=r"holds 17% of this bake.*--resume.*--restart"):
        bake_ranges(work, checkpoint=path)
    field, report = bake_ranges(work, checkpoint=path, restart=True)
    assert report["restored"] == 0 and np.array_equal(field.energy, whole.energy)


def test_a_damaged_checkpoint_is_reported_and_redone(small, whole, tmp_path):
    path = tmp_path / "f.h5.checkpoint"
    stopped_after(small, path, 3)
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    notes = []
    field, report = bake_ranges(SoundRanges(small, sonolux.SoundOptions(rays=RAYS)),
                                checkpoint=path, resume=True, log=notes.append)
    assert any("damaged checkpoint" in n and "from the start" in n for n in notes)
    assert report["restored"] == 0
    assert np.array_equal(field.energy, whole.energy)


@pytest.mark.parametrize("change, what", [("seed", "scene"), ("rays", "settings"),
                                          ("range", "ray range")])
def test_a_foreign_checkpoint_is_never_merged(small, tmp_path, change, what):
    path = tmp_path / "f.h5.checkpoint"
    stopped_after(small, path, 2)
    scene, options = small, sonolux.SoundOptions(rays=RAYS)
    if change == "seed":
        scene = replace(small, settings=replace(small.settings, seed=small.settings.seed + 1))
    elif change == "rays":
        options = replace(options, rays=RAYS + 1)
    else:
        options = replace(options, ray_range=(0, 2000))
    with pytest.raises(SonoluxError, match=f"another bake.*{what}.*--restart") as err:
        bake_ranges(SoundRanges(scene, options), checkpoint=path, resume=True)
    assert "nothing of it is merged" in str(err.value)
    assert path.exists()  # another bake's work is not thrown away unasked


def test_a_part_keeps_its_counts_and_merges(small, whole):
    a = bake(small, rays=RAYS, ray_range=(0, 1200), checkpoint=None, client=None)
    work = SoundRanges(small, sonolux.SoundOptions(rays=RAYS, ray_range=(1200, RAYS)))
    b, _ = bake_ranges(work, range_rays=600)
    assert b.counts is not None and b.settings["ray_range"] == [1200, RAYS]
    assert np.array_equal(a.merge(b).energy, whole.energy)


@pytest.mark.parametrize("estimator", ["paper", "rain", "nee"])
def test_a_mesh_room_has_the_bits_of_one_bake_on_two_threads_and_in_parts(estimator):
    """The example L-room (652 triangles traced through the BVH, its hull at the root; the
    other tests here bake paper-small, a shoebox traced through its planes): one bake on one
    thread, and the same rays on two threads in two parts merged, the same bits."""
    scene = sonolux.load_scene(EXAMPLES / "l-room" / "l-room.toml")
    on = lambda n: replace(scene, settings=replace(scene.settings, threads=n))  # noqa: E731
    one = bake_whole(on(1), rays=RAYS, estimator=estimator)
    parts = [bake(on(2), rays=RAYS, estimator=estimator, ray_range=r, checkpoint=None, client=None)
             for r in ((0, 1100), (1100, RAYS))]
    assert np.array_equal(parts[0].merge(parts[1]).energy, one.energy)
    assert one.stats["segments"] > 10 * RAYS


def test_sonolux_bake_is_the_plain_bake_without_client_or_checkpoint(small, whole):
    assert np.array_equal(sonolux.bake(small, rays=RAYS).energy, whole.energy)
    with pytest.raises(SonoluxError, match="checkpoint interval"):
        sonolux.bake(small, rays=RAYS, checkpoint="x.checkpoint", checkpoint_every_s=-1)
