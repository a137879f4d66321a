"""The other files a user hands in, damaged: scene TOML (truncated at many lengths, binary),
meshes (OBJ, PLY, STL: empty, garbage, truncated), IES photometry (truncated at every token
line, garbage), dry signals (WAV: empty, garbage, truncated header, NaN samples), SOFA HRTFs
and walk paths (CSV and JSON). Each is exit status 2 and one line naming the file."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from sonolux.light.ies import format_ies

from .conftest import REPO_SCENES, assert_usage_error, run

GARBAGE = {
    "empty": b"",
    "binary": bytes(range(256)) * 4,
    "nul": b"\x00" * 100,
    "latin1": "température = 20\n".encode("latin-1"),
    "text": b"hello world\n",
}


def scene_text() -> str:
    return (REPO_SCENES / "paper-small.toml").read_text(encoding="utf-8")


TOML_CUTS = [round(f, 3) for f in np.linspace(0.02, 0.98, 25)]


@pytest.mark.parametrize("fraction", TOML_CUTS)
def test_a_truncated_scene_is_named(capsys, tmp_path, fraction):
    text = scene_text()
    path = tmp_path / "cut.toml"
    path.write_text(text[: int(len(text) * fraction)], encoding="utf-8")
    code, _, err = run(capsys, "check", path)
    if code != 0:  # a cut after the essential tables is still a scene
        assert_usage_error(code, err, "cut.toml")


@pytest.mark.parametrize("kind", sorted(GARBAGE))
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_a_garbage_scene_is_named(capsys, tmp_path, kind, suffix):
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(GARBAGE[kind])
    code, _, err = run(capsys, "check", path)
    assert_usage_error(code, err, path.name)


def mesh_scene(tmp_path, mesh_name: str) -> object:
    scene = tmp_path / "mesh.toml"
    scene.write_text(f'[[geometry]]\ntype = "mesh"\nfile = "{mesh_name}"\n', encoding="utf-8")
    return scene


OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"
PLY = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
       "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
MESHES = {".obj": OBJ, ".ply": PLY}
MESH_CASES = ([(suffix, kind, None) for suffix in (".obj", ".ply", ".stl", ".glb", ".off")
               for kind in GARBAGE]
              + [(suffix, "cut", f) for suffix in MESHES for f in (0.2, 0.5, 0.8, 0.95)]
              + [(".obj", "nan", None), (".obj", "index", None), (".ply", "nan", None)])


@pytest.mark.parametrize(("suffix", "kind", "fraction"), MESH_CASES, ids=str)
def test_a_damaged_mesh_is_named(capsys, tmp_path, suffix, kind, fraction):
    path = tmp_path / f"room{suffix}"
    if kind == "cut":
        text = MESHES[suffix]
        path.write_text(text[: int(len(text) * fraction)], encoding="ascii")
    elif kind == "nan":
        path.write_text(MESHES[suffix].replace("1 0 0\n", "nan 0 0\n", 1), encoding="ascii")
    elif kind == "index":
        path.write_text(OBJ + "f 1 2 99\n", encoding="ascii")
    else:
        path.write_bytes(GARBAGE[kind])
    code, _, err = run(capsys, "check", mesh_scene(tmp_path, path.name))
    assert_usage_error(code, err, "mesh.toml", path.name)


def ies_text() -> str:
    v = np.linspace(0, 90, 4)
    return format_ies(v, np.array([0.0]), np.full((1, v.size), 100.0))


def ies_scene(tmp_path, name: str):
    scene = tmp_path / "lamp.toml"
    scene.write_text(
        '[[geometry]]\ntype = "shoebox"\nsize_m = [4, 3, 3]\n'
        '[geometry.materials]\ndefault = "plaster"\n'
        f'[[lights]]\ntype = "ies"\nfile = "{name}"\nposition_m = [2, 1.5, 2.5]\n',
        encoding="utf-8")
    return scene


IES_LINES = len(ies_text().splitlines())
IES_CASES = ([("lines", n) for n in range(0, IES_LINES)]
             + [("garbage", k) for k in GARBAGE] + [("nan", 0), ("negative", 0)])


@pytest.mark.parametrize(("kind", "arg"), IES_CASES, ids=str)
def test_a_damaged_ies_file_is_named(capsys, tmp_path, kind, arg):
    path = tmp_path / "lamp.ies"
    text = ies_text()
    if kind == "lines":
        path.write_text("\n".join(text.splitlines()[:arg]) + "\n", encoding="ascii")
    elif kind == "garbage":
        path.write_bytes(GARBAGE[arg])
    elif kind == "nan":
        path.write_text(text.replace("100", "nan"), encoding="ascii")
    else:
        path.write_text(text.replace("100", "-100"), encoding="ascii")
    code, _, err = run(capsys, "check", ies_scene(tmp_path, "lamp.ies"))
    assert_usage_error(code, err, "lamp.ies")


def good_wav(path, samples=None):
    x = np.sin(np.linspace(0, 200, 4800)) if samples is None else samples
    sf.write(path, np.asarray(x, np.float32), 48000, subtype="FLOAT")
    return path


WAV_CASES = [*GARBAGE, "header-only", "half-header", "nan", "inf", "silent", "riff-junk"]


@pytest.mark.parametrize("kind", WAV_CASES)
def test_a_damaged_dry_signal_is_named(capsys, field_file, tmp_path, kind):
    path = tmp_path / "dry.wav"
    if kind in GARBAGE:
        path.write_bytes(GARBAGE[kind])
    elif kind in ("header-only", "half-header"):
        data = good_wav(tmp_path / "good.wav").read_bytes()
        path.write_bytes(data[:44] if kind == "header-only" else data[:20])
    elif kind == "riff-junk":
        path.write_bytes(b"RIFF\x00\x00\x00\x00WAVEjunk")
    elif kind in ("nan", "inf"):
        x = np.ones(4800)
        x[100] = np.nan if kind == "nan" else np.inf
        good_wav(path, x)
    else:
        good_wav(path, np.zeros(4800))
    out = tmp_path / "out.wav"
    code, _, err = run(capsys, "auralize", field_file, path, "--at", "1,1", "-o", out)
    if kind == "silent":  # allowed: a silent result, said so
        assert code == 0 and "silent" in err
        return
    assert_usage_error(code, err, "dry.wav")
    assert not out.exists()


@pytest.mark.parametrize("kind", sorted(GARBAGE))
def test_a_damaged_sofa_file_is_named(capsys, field_file, tmp_path, kind):
    path = tmp_path / "head.sofa"
    path.write_bytes(GARBAGE[kind])
    code, _, err = run(capsys, "auralize", field_file, "builtin:clicks:0.5", "--at", "1,1",
                       "--hrtf", path, "-o", tmp_path / "o.wav")
    assert_usage_error(code, err, "head.sofa")


PATHS = {
    "empty.csv": b"", "binary.csv": bytes(range(256)), "header.csv": b"time,x,y\n",
    "nan.csv": b"time,x,y\n0,nan,1\n1,1,1\n", "inf.csv": b"time,x,y\n0,1,1\n1,inf,1\n",
    "backwards.csv": b"time,x,y\n1,1,1\n0,1,1\n", "words.csv": b"time,x,y\n0,a,b\n",
    "columns.csv": b"a,b\n1,2\n", "outside.csv": b"time,x,y\n0,1,1\n1,900,900\n",
    "short.csv": b"time,x,y\n0,1\n", "bad.json": b"{\"points\": [", "list.json": b"[1, 2, 3]",
    "nan.json": b"[{\"time\": 0, \"x\": NaN, \"y\": 1}]", "latin1.csv": "x,y\n1,é\n".encode("latin-1"),
}


@pytest.mark.parametrize("name", sorted(PATHS))
def test_a_damaged_walk_path_is_named(capsys, field_file, tmp_path, name):
    path = tmp_path / name
    path.write_bytes(PATHS[name])
    code, _, err = run(capsys, "auralize", field_file, "builtin:clicks:0.5", "--path", path,
                       "-o", tmp_path / "o.wav")
    assert_usage_error(code, err, name)
