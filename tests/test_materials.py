"""The material library: the shipped file loads, lookups suggest close names, bad files fail."""

from __future__ import annotations

import json

import numpy as np
import pytest

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
