"""The checkpoint side file: exact round trip, damage detected anywhere, fingerprints that follow
the scene's content (mesh files included) and nothing else."""

from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux import checkpoint as side
from sonolux.ranges import scene_content

from .conftest import EXAMPLES


@pytest.fixture
def written(tmp_path):
    arrays = {"counts": np.arange(5000, dtype=np.uint64).reshape(10, 500) * 2**40,
              "bins": np.linspace(0, 1, 7)}
    path = side.write(tmp_path / "f.h5.checkpoint", {"kind": "sound", "done": [[0, 10]]}, arrays)
    return path, arrays


def test_round_trip_is_exact_and_leaves_no_temporary_file(written):
    path, arrays = written
    header, back = side.read(path)
    assert header["kind"] == "sound" and header["done"] == [[0, 10]]
    for k, a in arrays.items():
        assert back[k].dtype == a.dtype and np.array_equal(back[k], a)
    assert [p.name for p in path.parent.iterdir()] == [path.name]


@pytest.mark.parametrize("where", [0, 30, 200, -40, -1])
def test_a_changed_byte_anywhere_is_detected(written, where):
    path, _ = written
    data = bytearray(path.read_bytes())
    data[where] ^= 0x01
    path.write_bytes(bytes(data))
    with pytest.raises(side.CheckpointError, match="damaged") as err:
        side.read(path)
    assert err.value.reason == "damaged"


def test_a_truncated_or_foreign_file_is_detected(written, tmp_path):
    path, _ = written
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(side.CheckpointError, match="checksum"):
        side.read(path)
    other = tmp_path / "other"
    other.write_text("hello")
    with pytest.raises(side.CheckpointError, match="not a sonolux checkpoint"):
        side.read(other)


def test_leftovers_of_a_killed_write_are_removed(written):
    path, _ = written
    (path.parent / f".{path.name}.abc123.tmp").write_bytes(b"half")
    assert side.remove_leftovers(path) == 1
    assert [p.name for p in path.parent.iterdir()] == [path.name]


def test_side_file_sits_beside_the_output(tmp_path):
    assert side.side_file(tmp_path / "room.h5") == tmp_path / "room.h5.checkpoint"


@pytest.mark.usefixtures("core")
def test_fingerprint_follows_content_not_threads_or_origin(tmp_path):
    a = sonolux.load_scene("paper-small")
    b = sonolux.load_scene("paper-small")
    fa = side.fingerprint(scene_content(a))
    assert fa == side.fingerprint(scene_content(b))
    threads = replace(a, settings=replace(a.settings, threads=1), origin="elsewhere.toml")
    assert side.fingerprint(scene_content(threads)) == fa
    seed = replace(a, settings=replace(a.settings, seed=a.settings.seed + 1))
    assert side.fingerprint(scene_content(seed)) != fa


@pytest.mark.usefixtures("core")
def test_fingerprint_follows_the_mesh_file(tmp_path):
    for name in ("mesh_room.toml", "l_room.obj", "l_room.mtl"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    before = side.fingerprint(scene_content(sonolux.load_scene(tmp_path / "mesh_room.toml")))
    obj = tmp_path / "l_room.obj"
    text = obj.read_text()
    obj.write_text(text + "\n# a comment changes no triangle\n")
    same = side.fingerprint(scene_content(sonolux.load_scene(tmp_path / "mesh_room.toml")))
    assert same == before
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("v "))
    x, y, z = (float(v) for v in lines[k].split()[1:4])
    lines[k] = f"v {x + 0.01} {y} {z}"
    obj.write_text("\n".join(lines) + "\n")
    moved = side.fingerprint(scene_content(sonolux.load_scene(tmp_path / "mesh_room.toml")))
    assert moved != before
