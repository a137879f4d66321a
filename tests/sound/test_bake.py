"""The sound bake from Python: files, determinism, ranges, lookups and errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field, save_fields
from sonolux.sound.bake import auto_rays, bake, band_arrays
from sonolux.sound.options import SoundOptions

pytestmark = pytest.mark.usefixtures("core")


@pytest.fixture(scope="module")
def small():
    return sonolux.load_scene("paper-small")


def with_threads(scene, n):
    return replace(scene, settings=replace(scene.settings, threads=n))


def test_file_round_trip_keeps_every_array(small, tmp_path):
    field = bake(small, rays=2000)
    path = save_fields(tmp_path / "f.h5", sound=field)
    back = open_field(path)
    assert np.array_equal(back.energy, field.energy)
    assert np.array_equal(back.bin_start_s, field.bin_start_s)
    assert back.settings == field.settings
    assert back.direction_names[:3] == ["front", "front-left", "left"]
    # No temporary file is left beside the result.
    assert [p.name for p in tmp_path.iterdir()] == ["f.h5"]


def test_same_seed_same_bits_on_one_and_two_threads(small):
    a = bake(with_threads(small, 1), rays=3000)
    b = bake(with_threads(small, 2), rays=3000)
    assert np.array_equal(a.energy, b.energy)
    c = bake(replace(small, settings=replace(small.settings, seed=99)), rays=3000)
    assert not np.array_equal(a.energy, c.energy)


@pytest.mark.parametrize("estimator", ["rain", "paper"])
def test_ranges_merge_to_the_bits_of_one_bake(small, estimator):
    whole = bake(small, rays=3000, estimator=estimator)
    parts = [bake(small, rays=3000, estimator=estimator, ray_range=r)
             for r in [(0, 1000), (1000, 2500), (2500, 3000)]]
    merged = parts[2].merge(parts[0]).merge(parts[1])
    assert np.array_equal(merged.energy, whole.energy)
    assert merged.settings["ray_range"] == [0, 3000]
    with pytest.raises(SonoluxError, match="overlap"):
        merged.merge(parts[0])


def test_direct_sound_at_the_central_cell_is_the_sphere_mean(small):
    field = bake(small, rays=1000, air_absorption=False)
    k = field.cell_at(3.0, 1.25)
    assert np.allclose(field.positions_m[k], [3.0, 1.25, 1.5])
    r = field.radius_m
    first = field.omni_energy(k)[:, 0]  # the source sits inside this receiver: arrival at t = 0
    assert np.allclose(first, 3 / (4 * np.pi * r * r), rtol=1e-6)


def test_cell_lookup_and_its_errors(small):
    field = bake(small, rays=500)
    assert field.cell_at(1.2, 0.4) == field.cell_at(1.0, 0.25)
    with pytest.raises(SonoluxError, match="outside the sound field"):
        field.cell_at(40.0, 1.0)
    with pytest.raises(SonoluxError, match="not one of"):
        field.direction_index("upwards")


def test_auto_ray_count_explains_itself(small):
    n, why = auto_rays(small, SoundOptions(), band_arrays(small))
    assert n >= 1000 and f"{n:,} rays" in why and "paper's rule" in why


def test_bad_options_and_files_are_clear_errors(small, tmp_path):
    with pytest.raises(SonoluxError, match="estimator"):
        bake(small, estimator="magic")
    with pytest.raises(SonoluxError, match="no such file"):
        open_field(tmp_path / "missing.h5")
    (tmp_path / "junk.h5").write_text("not hdf5")
    with pytest.raises(SonoluxError, match="not an HDF5 file"):
        open_field(tmp_path / "junk.h5")
    import h5py

    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["x"] = 1
    with pytest.raises(SonoluxError, match="not a sonolux field file"):
        open_field(tmp_path / "foreign.h5")
