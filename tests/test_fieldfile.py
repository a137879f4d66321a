"""The field file: the previous format still opens, one axis order for every sound array, and
files are written whole and with the permissions of the umask."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from sonolux.errors import FieldFileError
from sonolux.fieldfile import SCHEMA, contents, open_field, open_light_field, save_fields

V1 = Path(__file__).resolve().parent / "data" / "field-v1.h5"


def test_a_format_1_file_opens_with_its_counts_in_todays_axis_order():
    assert contents(V1)["schema"] == "sonolux-field/1"
    f = open_field(V1)
    assert f.energy.shape == (2, 4, 6, 216)  # [receiver, direction, band, time]
    assert f.counts is not None and f.counts.shape == f.energy.shape
    # Format 1 kept counts as [time, receiver, direction, band]; read, they rebuild the energy.
    assert f.quantum > 0 and np.any(f.counts)
    np.testing.assert_allclose(f.counts * f.quantum, f.energy, rtol=1e-6, atol=0)
    assert f.theory is None
    light = open_light_field(V1)
    assert light.flux_w.shape[1] == 3


def test_rewritten_in_format_2_the_field_reads_back_the_same(tmp_path):
    f = open_field(V1)
    path = save_fields(tmp_path / "v2.h5", sound=f, light=open_light_field(V1))
    assert contents(path)["schema"] == SCHEMA
    g = open_field(path)
    assert np.array_equal(g.energy, f.energy) and np.array_equal(g.counts, f.counts)
    assert g.settings == f.settings


def test_files_follow_the_umask_and_leave_nothing_beside_them(tmp_path):
    old = os.umask(0o027)
    try:
        path = save_fields(tmp_path / "u.h5", sound=open_field(V1))
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["u.h5"]


def test_a_foreign_or_missing_file_is_named(tmp_path):
    with pytest.raises(FieldFileError, match="no such file"):
        open_field(tmp_path / "none.h5")
    (tmp_path / "x.h5").write_bytes(b"not hdf5")
    with pytest.raises(FieldFileError, match="x.h5: not an HDF5 file"):
        open_field(tmp_path / "x.h5")


def test_the_band_kind_is_kept_and_an_octave_file_without_it_reads_as_octaves(tmp_path):
    f = open_field(V1)  # written before third-octaves: no settings.bands
    assert f.band_set is not None and f.band_set.kind == "octave"
    np.testing.assert_allclose(f.synthesis_bands_hz[3], 1000.0)
    f.settings["bands"] = "octave"
    g = open_field(save_fields(tmp_path / "octave.h5", sound=f))
    assert g.settings["bands"] == "octave" and g.band_set.nominal_hz == f.band_set.nominal_hz
    f.settings["bands"] = "third-octave"  # 125, 250, ... are not neighbouring thirds
    bad = save_fields(tmp_path / "bad.h5", sound=f)
    with pytest.raises(FieldFileError, match="settings.bands"):
        open_field(bad)
