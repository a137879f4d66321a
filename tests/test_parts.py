"""``sonolux merge``: parts of one bake (ray ranges baked apart, a checkpoint) add up to the bits
of the bake done at once; parts of other bakes, overlaps and missing rays are named."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux import cli
from sonolux.sound.bake import bake as bake_whole

pytestmark = pytest.mark.usefixtures("core")
RAYS = 3000


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def part(capsys, tmp_path, rng, *extra):
    out = tmp_path / f"part-{rng.replace(':', '-')}{'-'.join(extra)}.h5"
    code, _, err = run(capsys, "bake", "paper-small", "--rays", RAYS, "--no-light", "-q",
                       "--range", rng, "-o", out, *extra)
    assert code == 0, err
    return out


def test_parts_merge_to_the_bits_of_one_bake_and_missing_rays_are_named(capsys, tmp_path):
    a = part(capsys, tmp_path, "0:1000")
    c = part(capsys, tmp_path, "2200:3000")
    out = tmp_path / "merged.h5"
    code, _, err = run(capsys, "merge", a, c, "-o", out)
    assert code == 2 and "rays 1000..2200 of the bake's 0..3000 are in no part" in err
    assert "--range 1000:2200" in err and not out.exists()
    code, stdout, err = run(capsys, "merge", a, c, "-o", out, "--partial")
    assert code == 0 and "missing rays 1000..2200" in stdout
    b = part(capsys, tmp_path, "1000:2200")
    code, stdout, err = run(capsys, "merge", c, b, a, "-o", out)
    assert code == 0, err
    merged = sonolux.open(out)
    assert np.array_equal(merged.energy, bake_whole(sonolux.load_scene("paper-small"),
                                                    rays=RAYS).energy)
    assert merged.counts is None and merged.settings["ray_range"] == [0, RAYS]
    # The partial merge is a part itself.
    code, _, err = run(capsys, "merge", tmp_path / "merged.h5", a, "-o", tmp_path / "x.h5")
    assert code == 2 and "whole bake" in err


def test_overlaps_and_foreign_parts_are_refused(capsys, tmp_path):
    a = part(capsys, tmp_path, "0:1500")
    b = part(capsys, tmp_path, "1000:3000")
    code, _, err = run(capsys, "merge", a, b, "-o", tmp_path / "m.h5")
    assert code == 2 and "rays 1000..1500 are in two parts" in err
    other = part(capsys, tmp_path, "1500:3000", "--elevation-bands", "3")
    code, _, err = run(capsys, "merge", a, other, "-o", tmp_path / "m.h5")
    assert code == 2 and "a part of another bake" in err


def test_a_checkpoint_is_a_part(capsys, tmp_path):
    from sonolux.checkpoint import write
    from sonolux.sound.ranges import SoundRanges, SoundSum

    scene = sonolux.load_scene("paper-small")
    work = SoundRanges(scene, sonolux.SoundOptions(rays=RAYS))
    meta, arrays = work.encode(SoundSum.of(bake_whole(scene, rays=RAYS, ray_range=(0, 1800))))
    ckpt = tmp_path / "f.h5.checkpoint"
    write(ckpt, {"kind": "sound", "fingerprint": work.fingerprint, "stamp": work.stamp,
                 "target": [0, RAYS], "done": [[0, 1800]], "meta": meta}, arrays)
    rest = part(capsys, tmp_path, "1800:3000")
    code, _, err = run(capsys, "merge", ckpt, rest, "-o", tmp_path / "m.h5")
    assert code == 0, err
    assert np.array_equal(sonolux.open(tmp_path / "m.h5").energy,
                          bake_whole(scene, rays=RAYS).energy)
