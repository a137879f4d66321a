"""The full example of docs/scene.md loads, so the documentation stays true."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from sonolux.scene import load_scene, materials

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

DOC = Path(__file__).resolve().parent.parent / "docs" / "scene.md"

# The example's furniture.obj: a closed box (x, y in 0..1, z in 0.05..0.8) facing out, its top
# in the group "Cushion" (left to the fallback material), the rest in "Chair".
FURNITURE_OBJ = """
v 0 0 0.05
v 1 0 0.05
v 0 1 0.05
v 1 1 0.05
v 0 0 0.8
v 1 0 0.8
v 0 1 0.8
v 1 1 0.8
usemtl Chair
f 4 2 1
f 3 4 1
f 1 2 6
f 1 6 5
f 2 4 8
f 2 8 6
f 4 3 7
f 4 7 8
f 3 1 5
f 3 5 7
usemtl Cushion
f 5 6 8
f 5 8 7
"""


def test_full_example_loads(core, tmp_path):
    if not materials.DEFAULT_PATH.is_file():
        pytest.skip("the shipped materials.json is not there yet")
    (block,) = re.findall(r"```toml\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.DOTALL)
    (tmp_path / "furniture.obj").write_text(FURNITURE_OBJ)
    scene = load_scene(tomllib.loads(block), base_dir=tmp_path)
    assert scene.name == "meeting room"
    tags = set(scene.surface_tag)
    assert {"floor", "east", "Chair", "Cushion"} <= tags
    names = {m.name for m in scene.materials}
    assert {"whiteboard-wall", "wood-panel", "foam"} <= names
    assert [light.kind for light in scene.lights] == ["rectangle", "surface"]
    assert scene.lights[1].area_m2 == pytest.approx(1.0)  # the cushion
    assert scene.volume_m3 == pytest.approx(7 * 5 * 2.8 - 0.75)
    assert not [w for w in scene.warnings if "face out" in w or "not closed" in w]
