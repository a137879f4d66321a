"""The material library: the shipped file loads, lookups suggest close names, bad files fail."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sonolux.acoustics.bands import band_set_of
from sonolux.errors import SceneError
from sonolux.scene import materials
from tests.conftest import DATA


def test_fixture_library_loads(library):
    assert library.names() == ["carpet-on-concrete", "concrete-painted", "glass-window",
                               "plaster-smooth"]
    m = library.get("carpet-on-concrete")
    assert m.absorption.shape == (8,) and m.absorption.dtype == np.float64
    assert m.diffuse_rgb.shape == (3,)


def test_get_unknown_name_lists_close_matches(library):
    with pytest.raises(SceneError) as info:
        library.get("carpet-on-concret")
    assert info.value.matches == ["carpet-on-concrete"]


def test_shipped_library_is_the_default_and_is_cached():
    if not materials.DEFAULT_PATH.is_file():
        pytest.skip("the shipped materials.json is not there yet")
    lib = materials.library()
    assert lib is materials.library() and len(lib) > 0
    name = lib.names()[0]
    assert materials.get(name) is lib.materials[name]
    for m in lib.materials.values():
        assert np.all((m.absorption >= 0) & (m.absorption <= 1))


def test_bad_library_files(tmp_path):
    good = json.loads((DATA / "materials_fixture.json").read_text())
    bad = dict(good, schema="sonolux-materials/0")
    (tmp_path / "a.json").write_text(json.dumps(bad))
    with pytest.raises(SceneError, match="schema"):
        materials.load_library(tmp_path / "a.json")
    bad = json.loads(json.dumps(good))
    bad["materials"]["glass-window"]["absorption"][2] = 1.5
    (tmp_path / "b.json").write_text(json.dumps(bad))
    with pytest.raises(SceneError, match=r"materials\.glass-window\.absorption\[2\] = 1.5"):
        materials.load_library(tmp_path / "b.json")
    (tmp_path / "c.json").write_text("{\n  \"schema\": \n}")
    with pytest.raises(SceneError) as info:
        materials.load_library(tmp_path / "c.json")
    assert info.value.line == 3


def test_a_library_entry_may_give_its_own_third_octave_bands(tmp_path):
    thirds = [100, 125, 160, 200, 250, 315]
    data = {"schema": "sonolux-materials/1",
            "bands_hz": [63, 125, 250, 500, 1000, 2000, 4000, 8000],
            "materials": {"panel": {"bands_hz": thirds,
                                    "absorption": [0.1, 0.2, 0.6, 0.3, 0.3, 0.9],
                                    "scattering": 0.2, "diffuse_rgb": [0.5, 0.5, 0.5]}}}
    path = tmp_path / "lib.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    panel = materials.load_library(path).get("panel")
    assert panel.absorption_bands.kind == "third-octave" and panel.absorption.shape == (6,)
    np.testing.assert_allclose(panel.absorption_in(band_set_of([125, 250])), [0.3, 0.5],
                               rtol=1e-15)
    data["materials"]["panel"]["absorption"] = [0.1] * 5
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(SceneError, match=r"materials\.panel\.absorption .*list of 6"):
        materials.load_library(path)


def test_every_library_entry_says_how_it_becomes_thirds():
    shipped = json.loads(materials.DEFAULT_PATH.read_text(encoding="utf-8"))["materials"]
    for name, entry in shipped.items():
        assert "third_octaves" in entry["source"], name
