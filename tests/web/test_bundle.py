"""``sonolux export FIELD --web DIR``: the files, their index, and what they hold."""

from __future__ import annotations

import json
import zlib

import numpy as np
import pytest
import trimesh

import sonolux
from sonolux import cli
from sonolux.errors import SonoluxError
from sonolux.web import WebExportOptions, export_web
from sonolux.web.bundle import direction_table
from sonolux.web.geometry import from_gltf, plan_segments, to_gltf
from sonolux.web.responses import cell_responses, decay_end, direct_bins, pack

# The bundle of responses (sonolux-web/2), where the reverberation's length does not matter.
SHORT = WebExportOptions(responses="pcm", max_length_s=0.1)


def read(bundle):
    index = json.loads((bundle / "field.json").read_text())
    data = (bundle / "responses.bin").read_bytes()
    return index, data


def block(index, data, cell):
    """A cell's block as stored, inflated when the bundle is compressed (as the viewer does)."""
    c = index["cells"][cell]
    stored = data[c["byte_offset"]:c["byte_offset"] + c["byte_length"]]
    assert zlib.crc32(stored) == c["crc32"]
    if index["encoding"] == "none":
        return stored
    raw = zlib.decompress(stored)
    assert len(raw) == c["raw_length"] and len(raw) % 8 == 0
    return raw


def response(index, data, cell, kind, d):
    """One response as float64 with its leading zeros, decoded as the viewer does."""
    delay, length, offset, scale = index["cells"][cell][kind][d]
    dtype = np.int16 if index["sample_format"] == "int16" else np.float32
    words = np.frombuffer(block(index, data, cell), dtype)
    return np.concatenate([np.zeros(delay), words[offset:offset + length] * scale])


def test_bundle_files_and_index(sound_field, tmp_path):
    summary = export_web(sound_field, tmp_path / "b", WebExportOptions(responses="pcm"))
    index, data = read(tmp_path / "b")
    field = sonolux.open(sound_field)
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["field.json", "responses.bin", "scene.glb"]
    assert index["format"] == "sonolux-web/2" and index["sample_rate_hz"] == 48000
    assert index["encoding"] == "deflate" and index["tail_db"] == 60
    assert len(index["cells"]) == field.n_receivers == summary.cells == 15
    assert [d["name"] for d in index["directions"]] == field.direction_names
    assert index["directions"][2] == {"name": "left", "azimuth_deg": 90.0, "elevation_deg": 0.0}
    assert index["responses_bytes"] == len(data)
    assert index["bounds_m"] == {"min": [0.0, 0.0, 0.0], "max": [6.0, 2.5, 2.0]}
    assert index["sources"][0]["position_m"] == [3.0, 1.25, 1.5]
    assert index["scene"]["source"] == "scene" and index["scene"]["lit"] is False
    end = 0
    for k, c in enumerate(index["cells"]):
        assert c["position_m"] == list(field.positions_m[k]) and c["grid_index"] == list(field.grid_index[k])
        assert c["byte_offset"] == end  # blocks follow each other
        end += c["byte_length"]
        assert zlib.crc32(data[c["byte_offset"]:end]) == c["crc32"]
        assert len(block(index, data, k)) == c["raw_length"] > c["byte_length"]
    assert end == len(data)
    raw = WebExportOptions(responses="pcm", compress=False)
    export_web(sound_field, tmp_path / "raw", raw)
    index_raw, data_raw = read(tmp_path / "raw")
    assert index_raw["encoding"] == "none" and "raw_length" not in index_raw["cells"][0]
    for k in (0, 14):  # the same blocks, compressed or not
        assert block(index_raw, data_raw, k) == block(index, data, k)


def test_responses_are_the_fields_impulse_responses(sound_field, tmp_path):
    """Full responses are SoundField.impulse_response with seed + cell × 8 + direction, to the
    int16 quantization (a step of peak / 32767)."""
    export_web(sound_field, tmp_path / "b", WebExportOptions(responses="pcm", seed=5, tail_db=None))
    index, data = read(tmp_path / "b")
    field = sonolux.open(sound_field)
    for cell, d in [(0, 0), (7, 3), (14, 6)]:
        ir = field.impulse_response(cell, d, seed=5 + cell * 8 + d)
        got = response(index, data, cell, "full", d)
        n = max(ir.size, got.size)
        ir, got = np.pad(ir, (0, n - ir.size)), np.pad(got, (0, n - got.size))
        assert np.max(np.abs(got - ir)) <= 0.5 * np.max(np.abs(ir)) / 32767 * 1.0001
    assert index["response_length_samples"] == max(
        field.impulse_response(r, d, seed=5 + r * 8 + d).size for r in range(15) for d in range(8))


def test_responses_end_where_the_decay_has_died_away(sound_field, tmp_path):
    """With tail_db, a cell's responses are the field's up to the fade, and end together where
    the energy still to come over all directions is tail_db below the cell's whole energy."""
    field = sonolux.open(sound_field)
    fs = field.sample_rate_hz
    for tail_db in (30.0, 60.0):
        export_web(sound_field, tmp_path / "b", WebExportOptions(responses="pcm", tail_db=tail_db, seed=2))
        index, data = read(tmp_path / "b")
        for cell in (0, 9):
            whole = [field.impulse_response(cell, d, seed=2 + cell * 8 + d) for d in range(8)]
            n = decay_end(whole, tail_db)
            total = sum(float(np.sum(x * x)) for x in whole)
            left = sum(float(np.sum(x[n:] ** 2)) for x in whole)
            last = sum(float(np.sum(x[n - 1:n] ** 2)) for x in whole)  # the cell's sample n - 1
            assert left <= total * 10 ** (-tail_db / 10) < left + last  # n is the first such sample
            fade = int(round(0.010 * fs))
            for d in (0, 4):
                got = response(index, data, cell, "full", d)
                assert got.size <= n
                m = min(got.size, n - fade)  # before the fade: the field's response
                peak = np.max(np.abs(whole[d]))
                assert np.max(np.abs(got[:m] - whole[d][:m])) <= 0.5 * peak / 32767 * 1.0001
    # Shorter for 30 dB than for the full field; the option is checked.
    assert index["response_length_samples"] < max(x.size for x in whole)
    for bad in (10, 500, float("nan"), "60"):
        with pytest.raises(SonoluxError, match="tail_db"):
            WebExportOptions(responses="pcm", tail_db=bad).validate()


def test_direct_only_is_the_direct_sound(sound_field, tmp_path):
    """Only the direction that faces the source has a direct response; it is the full
    response's direct arrival (same level), and nothing after it."""
    field = sonolux.open(sound_field)
    c = field.settings["speed_of_sound_m_s"]
    cell = field.cell_at(1, 1.25)  # the source, at (3, 1.25), is straight ahead (+x): "front"
    r = cell_responses(field, cell, seed=0, max_length_s=None)
    assert [x.size > 0 for x in r.direct] == [True] + [False] * 7
    t = np.linalg.norm(field.positions_m[cell] - field.source_positions_m[0]) / c
    n = int(t * field.sample_rate_hz)
    direct, full = r.direct[0], r.full[0]
    assert np.argmax(np.abs(direct)) == np.argmax(np.abs(full[:n + 5])) == n
    assert direct[n] == pytest.approx(full[n], rel=1e-3)
    assert direct.size < n + 100  # a spike with its band filter's ringing, no reverberation
    assert 1 <= np.count_nonzero(direct_bins(field, cell)) <= 2  # rain: the bin of t, ± half a sample


def test_bundle_options(sound_field, tmp_path):
    export_web(sound_field, tmp_path / "f",
               WebExportOptions(responses="pcm", max_length_s=0.25, sample_format="float32"))
    index, data = read(tmp_path / "f")
    assert index["sample_format"] == "float32" and index["response_length_samples"] == 12000
    x = response(index, data, 7, "full", 0)
    assert x.size <= 12000 and abs(x[-1]) < 1e-3 * np.max(np.abs(x))  # faded, not cut
    with pytest.raises(SonoluxError, match="max_length_s"):
        WebExportOptions(responses="pcm", max_length_s=-1).validate()
    with pytest.raises(SonoluxError, match="sample_format"):
        WebExportOptions(responses="pcm", sample_format="mp3").validate()


def test_packing():
    p = pack(np.array([0, 0, 0.5, -1.0, 0.25, 0, 0]), "int16")
    assert p.delay == 2 and list(p.samples) == [16384, -32767, 8192]
    assert p.scale == pytest.approx(1 / 32767)
    assert pack(np.zeros(5), "int16").samples.size == 0


def test_replacing_a_bundle_is_atomic_and_other_folders_are_left_alone(sound_field, tmp_path):
    out = tmp_path / "b"
    export_web(sound_field, out, WebExportOptions(responses="pcm", max_length_s=0.1))
    export_web(sound_field, out, WebExportOptions(responses="pcm", max_length_s=0.2))
    assert read(out)[0]["max_length_s"] == 0.2
    assert [p.name for p in tmp_path.iterdir()] == ["b"]  # no temporary folder left behind
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(SonoluxError, match="not a web bundle"):
        export_web(sound_field, mine, SHORT)
    assert (mine / "notes.txt").read_text() == "keep me"


def test_a_failed_export_leaves_the_old_bundle(sound_field, tmp_path, monkeypatch):
    out = tmp_path / "b"
    export_web(sound_field, out, SHORT)
    before = (out / "field.json").read_text()
    import sonolux.web.bundle as bundle

    def broken(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(bundle, "_index", broken)
    with pytest.raises(RuntimeError):
        export_web(sound_field, out, SHORT)
    assert (out / "field.json").read_text() == before
    assert [p.name for p in tmp_path.iterdir()] == ["b"]


def test_scene_glb_unlit_from_the_scene_and_lit_from_the_light_field(sound_field, lit_field, tmp_path):
    export_web(sound_field, tmp_path / "u", SHORT)
    export_web(lit_field, tmp_path / "l", SHORT)
    unlit, lit = read(tmp_path / "u")[0], read(tmp_path / "l")[0]
    assert (unlit["scene"]["source"], unlit["scene"]["lit"]) == ("scene", False)
    assert (lit["scene"]["source"], lit["scene"]["lit"]) == ("light-export", True)
    for b in ("u", "l"):
        scene = trimesh.load(tmp_path / b / "scene.glb", force="scene")
        lo, hi = from_gltf(scene.bounds).min(0), from_gltf(scene.bounds).max(0)
        assert lo == pytest.approx([0, 0, 0], abs=1e-6) and hi == pytest.approx([6, 2.5, 2], abs=1e-6)
    names = trimesh.load(tmp_path / "u" / "scene.glb", force="scene").geometry.keys()
    assert "light:strip" in names and "floor:paper-floor" in names
    # The walls at head height, whichever mesh they came from: the room's outline.
    for index in (unlit, lit):
        seg = np.array(index["plan_segments_m"])
        assert seg.size and np.all((seg[:, [0, 2]] >= -1e-9) & (seg[:, [0, 2]] <= 6 + 1e-9))
        length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]).sum()
        assert length == pytest.approx(2 * (6 + 2.5), rel=1e-6)


def test_a_moved_scene_file_gives_a_floor_and_a_warning(sound_field, tmp_path):
    import shutil

    import h5py

    moved = tmp_path / "moved.h5"
    shutil.copy(sound_field, moved)
    with h5py.File(moved, "a") as f:
        f.attrs["scene_origin"] = str(tmp_path / "gone.toml")
    summary = export_web(moved, tmp_path / "b", SHORT)
    assert summary.scene_source == "floor" and "could not be reloaded" in summary.warnings[0]
    index = read(tmp_path / "b")[0]
    assert index["bounds_m"]["max"][:2] == pytest.approx([5.5, 2.75])


def test_axes():
    p = np.array([[1.0, 2.0, 3.0]])
    assert to_gltf(p).tolist() == [[1.0, 3.0, -2.0]]
    assert from_gltf(to_gltf(p)) == pytest.approx(p)
    assert np.linalg.det(to_gltf(np.eye(3))) == pytest.approx(1.0)  # a rotation: windings kept


def test_plan_segments_of_a_triangle():
    tri = np.array([[[0, 0, 0], [2, 0, 0], [0, 0, 2]]], float)
    assert plan_segments(tri, 1.0).tolist() == [[1.0, 0.0, 0.0, 0.0]]
    assert plan_segments(tri, 3.0).size == 0


def test_direction_table_with_elevation_bands():
    class F:
        azimuth_bands, elevation_bands = 4, 3
        direction_names = [f"d{k}" for k in range(12)]

    t = direction_table(F())
    assert [d["azimuth_deg"] for d in t[:4]] == [0, 90, 180, 270]
    assert t[0]["elevation_deg"] == pytest.approx(-41.8103, abs=1e-4)  # asin(-2/3): equal solid angle
    assert t[4]["elevation_deg"] == 0 and t[8]["elevation_deg"] == pytest.approx(41.8103, abs=1e-4)


def test_cli_export_web(sound_field, tmp_path, capsys):
    code = cli.main(["export", str(sound_field), "--web", str(tmp_path / "b"), "--max-length-s", "0.3",
                     "--tail-db", "none", "--no-compress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    index = read(tmp_path / "b")[0]
    assert (index["tail_db"], index["encoding"]) == (None, "none")
    code = cli.main(["export", str(sound_field), "--web", str(tmp_path / "b"), "--tail-db", "5"])
    assert code == 2 and "--tail-db" in capsys.readouterr().err
    assert "15 cells × 8 directions" in out and "sonolux serve" in out
    assert (tmp_path / "b" / "field.json").exists()
    with pytest.raises(SystemExit):
        cli.main(["export", str(sound_field)])
    assert "--web" in capsys.readouterr().err
    code = cli.main(["export", str(tmp_path / "nothing.h5"), "--web", str(tmp_path / "c")])
    assert code == 2 and "no such file" in capsys.readouterr().err
