"""Every number of every scene we ship, replaced by what a user might type by mistake (NaN,
infinities, overflow, text, a boolean, an empty list, a huge integer, the wrong sign): ``sonolux
check`` loads it or refuses it with exit status 2 and one line naming the file, the line and the
key. As a property: any value put in place of any leaf of a scene dict loads or raises a
SceneError naming its key, never another exception."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import sonolux
from sonolux.errors import SonoluxError

from .conftest import assert_usage_error, run

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
SCENES = [*sorted((REPO / "python/sonolux/data/scenes").glob("*.toml")),
          *sorted((REPO / "examples/scenes").glob("*.toml"))]
#: What replaces a number (TOML text).
BAD = ["nan", "inf", "-inf", '"12"', "true", "[]", "1e308", "-1e308", "123456789012345678901234567890",
       "-1"]
NUMBER_LINE = re.compile(r"^(\s*)([A-Za-z_]+)(\s*=\s*)(-?[0-9][0-9_.eE+-]*)\s*(#.*)?$")


def number_lines(path: Path) -> list[tuple[int, str]]:
    """(line index, key) of each `key = number` line."""
    out = []
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines()):
        m = NUMBER_LINE.match(line)
        if m:
            out.append((i, m.group(2)))
    return out


CASES = [(scene, i, key, bad) for scene in SCENES for i, key in number_lines(scene) for bad in BAD]


def test_the_corpus_covers_every_scene():
    assert {c[0] for c in CASES} == set(SCENES) and len(CASES) >= 300


@pytest.mark.parametrize(("scene", "line", "key", "bad"), CASES,
                         ids=[f"{s.stem}:{i + 1}:{k}={b}" for s, i, k, b in CASES])
def test_a_bad_scene_number_is_refused_by_name(capsys, tmp_path, scene, line, key, bad):
    lines = scene.read_text(encoding="utf-8").splitlines()
    m = NUMBER_LINE.match(lines[line])
    lines[line] = f"{m.group(1)}{m.group(2)}{m.group(3)}{bad}"
    target = tmp_path / scene.name
    target.write_text("\n".join(lines) + "\n", encoding="utf-8")
    for extra in scene.parent.glob("*.obj"):  # meshes and materials beside the scene
        (tmp_path / extra.name).write_bytes(extra.read_bytes())
    for extra in scene.parent.glob("*.mtl"):
        (tmp_path / extra.name).write_bytes(extra.read_bytes())
    code, _, err = run(capsys, "check", target)
    if code == 0:
        return  # the value is allowed there (a large power, a negative coordinate)
    line_text = assert_usage_error(code, err, target.name, key)
    assert f"{target.name}:" in line_text


def leaves(data, path=()):
    """Paths to every number of a nested dict/list."""
    if isinstance(data, dict):
        for k, v in data.items():
            yield from leaves(v, (*path, k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from leaves(v, (*path, i))
    elif isinstance(data, (int, float)) and not isinstance(data, bool):
        yield path


def built_in(name: str) -> dict:
    with open(REPO / f"python/sonolux/data/scenes/{name}.toml", "rb") as f:
        return tomllib.load(f)


SMALL = built_in("paper-small")
LEAVES = list(leaves(SMALL))
ODD = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                st.integers(min_value=-(10**40), max_value=10**40), st.text(max_size=5),
                st.booleans(), st.none(), st.lists(st.floats(), max_size=4),
                st.dictionaries(st.text(max_size=3), st.integers(), max_size=2))


@given(where=st.sampled_from(LEAVES), value=ODD)
def test_any_value_at_any_key_loads_or_names_the_key(where, value):
    import copy

    scene = copy.deepcopy(SMALL)
    node = scene
    for k in where[:-1]:
        node = node[k]
    if value is None:  # the key left out, or the list one item shorter
        node.pop(where[-1])
    else:
        node[where[-1]] = value
    try:
        sonolux.load_scene(scene)
    except SonoluxError as exc:
        # One line that names the scene and a key (not always the one changed: a smaller room
        # can leave a source outside it).
        text = str(exc)
        assert "\n" not in text and text.startswith("<dict>"), text
