"""A hybrid bake (waves below the crossover, rays above) split into ray ranges: the part from
ray 0 carries the waves, computed once; the merge that completes the rays joins them. Every
check is exact: the bits of the bake done at once."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field, save_fields
from sonolux.sound.bake import bake
from tests.sound.test_waves import room

pytestmark = pytest.mark.usefixtures("core")


HYBRID = dict(rays=4_000, waves=True, crossover_hz=250, max_time_s=0.15)


@pytest.fixture(scope="module")
def small_hybrid():
    scene = room([[2.9, 2.1, 1.2], [2.5, 0.7, 1.6]])
    return scene, bake(scene, **HYBRID)


@pytest.mark.parametrize("storage", ["compact", "full"])
def test_ray_ranges_of_a_hybrid_merge_to_the_bits_of_one_bake(small_hybrid, storage):
    """The waves are deterministic and belong to the bake: the range from ray 0 computes them
    once and carries them unjoined; the merge that completes the rays joins them. Energy and
    wave pressure: the same bits as the bake done at once (exact, both storages)."""
    scene, _ = small_hybrid
    whole = bake(scene, **HYBRID, storage=storage)
    parts = [bake(scene, **HYBRID, storage=storage, ray_range=r)
             for r in ((1_500, 4_000), (0, 1_500))]
    assert parts[0].waves is None and parts[1].waves["energy"].shape[2] == 1
    assert all(p.settings["with_waves"] for p in parts)
    merged = parts[0].merge(parts[1])
    np.testing.assert_array_equal(np.asarray(merged.energy), np.asarray(whole.energy))
    np.testing.assert_array_equal(merged.waves["pressure"], whole.waves["pressure"])
    assert merged.settings["waves"] == whole.settings["waves"] and merged.counts is None
    # Two parts that both start at ray 0 would count their rays (and the waves) twice.
    with pytest.raises(SonoluxError, match="twice"):
        parts[1].merge(bake(scene, **HYBRID, storage=storage, ray_range=(0, 10)))


def test_command_line_ranges_of_a_hybrid_merge_to_the_bits_of_one_bake(small_hybrid, tmp_path,
                                                                         capsys):
    """Ranges of a hybrid and ``sonolux merge``: the files carry the waves' part (the one from
    ray 0) and merge to the bits of the one-piece bake; parts that make the whole without the
    waves' part are refused, naming it (the waves would be missing)."""
    from sonolux import cli
    from sonolux.sound import ranges

    scene, whole = small_hybrid
    # The part from ray 0 through the checkpointed range baker (what `sonolux bake --range`
    # runs), the other through the plain one.
    parts = [ranges.bake(scene, checkpoint=tmp_path / "p0.h5", range_rays=1_000,
                         ray_range=(0, 2_500), **HYBRID),
             bake(scene, **HYBRID, ray_range=(2_500, 4_000))]
    files = []
    for k, p in enumerate(parts):
        files.append(tmp_path / f"part{k}.h5")
        save_fields(files[-1], sound=p)
    out = tmp_path / "merged.h5"
    code = cli.main(["merge", str(files[1]), str(files[0]), "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    merged = open_field(out)
    np.testing.assert_array_equal(np.asarray(merged.energy), np.asarray(whole.energy))
    np.testing.assert_array_equal(merged.waves["pressure"], whole.waves["pressure"])
    # Without the part from ray 0 there are no waves to join: refused, naming them.
    alone = bake(scene, **HYBRID, ray_range=(0, 2_500))
    save_fields(tmp_path / "other.h5", sound=replace(alone, waves=None))
    code = cli.main(["merge", str(tmp_path / "other.h5"), str(files[1]), "-o",
                     str(tmp_path / "bad.h5")])
    assert code == 2 and "none holds its waves" in capsys.readouterr().err


def test_sonolux_bake_range_and_merge_of_a_hybrid_give_the_bits_of_one_bake(tmp_path, capsys):
    """The command line end to end: `sonolux bake --waves --range` twice and `sonolux merge`
    against `sonolux bake --waves` in one piece (same scene file, rays, crossover): same bits."""
    from sonolux.cli import main

    scene_file = tmp_path / "box.toml"
    scene_file.write_text(
        'name = "box"\n[settings]\nbands_hz = [125, 250, 500, 1000]\n'
        '[materials.m]\nabsorption = 0.15\n[[geometry]]\ntype = "shoebox"\nsize_m = [5, 4, 3]\n'
        '[geometry.materials]\ndefault = "m"\n[[sources]]\nposition_m = [1.3, 1.1, 1.4]\n'
        '[receivers]\ntype = "points"\npositions_m = [[2.9, 2.1, 1.2]]\n')
    common = ["--rays", "3000", "--waves", "--crossover-hz", "177",
              "--no-light", "--quiet"]
    out = {k: tmp_path / f"{k}.h5" for k in ("whole", "a", "b", "merged")}
    assert main(["bake", str(scene_file), *common, "-o", str(out["whole"])]) == 0
    assert main(["bake", str(scene_file), *common, "--range", "1000:3000", "-o", str(out["b"])]) == 0
    assert main(["bake", str(scene_file), *common, "--range", "0:1000", "-o", str(out["a"])]) == 0
    assert main(["merge", str(out["b"]), str(out["a"]), "-o", str(out["merged"])]) == 0, \
        capsys.readouterr().err
    whole, merged = open_field(out["whole"]), open_field(out["merged"])
    np.testing.assert_array_equal(np.asarray(merged.energy), np.asarray(whole.energy))
    np.testing.assert_array_equal(merged.waves["pressure"], whole.waves["pressure"])
