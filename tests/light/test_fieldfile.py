"""One bake for both senses: the CLI writes sound and light into one file, and each reader
finds its own half."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sonolux.cli import main
from sonolux.errors import SonoluxError
from sonolux.fieldfile import contents, open_field, open_light_field, save_fields
from sonolux.fieldfile import open_field as open_sound
from sonolux.light.image import read_pfm


def test_light_field_round_trip_keeps_every_array(small_light, tmp_path):
    path = save_fields(tmp_path / "light.h5", light=small_light)
    back = open_light_field(path)
    for name in ("flux_w", "hits", "patch_area_m2", "patch_offset", "vertices_m", "triangles",
                 "rho", "emitter_triangles_m", "emitter_radiance", "emitted_radiance"):
        assert np.array_equal(getattr(back, name), getattr(small_light, name)), name
    assert list(back.surface_tag) == list(small_light.surface_tag)
    assert back.light_names == ["strip"] and back.light_kinds == ["rectangle"]
    assert back.stats == small_light.stats
    assert [p.name for p in tmp_path.iterdir()] == ["light.h5"]  # no temporary file left
    with pytest.raises(SonoluxError, match="no sound field.*--sound"):
        open_field(path)
    with pytest.raises(SonoluxError, match="no sound field"):
        open_sound(path)


def test_bake_both_senses_into_one_file_then_info_render_export(tmp_path, capsys, core):
    out = tmp_path / "both.h5"
    assert main(["bake", "paper-small", "-o", str(out), "--rays", "300", "--particles", "20000",
                 "-q"]) == 0
    text = capsys.readouterr().out
    assert "sound field of paper-small" in text and "light field of paper-small" in text
    assert "loaded and its BVH built once" in text and "saved" in text
    has = contents(out)
    assert has["sound"] and has["light"] and has["bake"]["senses"] == ["sound", "light"]
    assert has["bake"]["saved_s"] > 0
    assert open_field(out).settings["rays"] == 300
    assert open_light_field(out).settings["particles"] == 20_000

    assert main(["info", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["receivers"] == 15 and info["light"]["patches"] > 0
    assert abs(max(info["light"]["flux_balance_relative_error"], key=abs)) < 1e-9

    png, pfm = tmp_path / "v.png", tmp_path / "v.pfm"
    assert main(["render", str(out), "-o", str(png), "--hdr", str(pfm), "--size", "64x36"]) == 0
    assert "incident meter" in capsys.readouterr().out
    assert main(["render", str(out), "-o", str(png), "--size", "64x36", "--meter", "reflected",
                 "--yaw", "90", "--pitch", "20", "--fov", "90", "--tone-map", "reinhard"]) == 0
    from PIL import Image

    assert Image.open(png).size == (64, 36)
    assert read_pfm(pfm).shape == (36, 64, 3)
    assert main(["export", str(out), "--gltf", str(tmp_path / "s.glb")]) == 0
    assert "patch triangles" in capsys.readouterr().out


def test_no_sound_and_no_light_each_leave_their_half_out(tmp_path, capsys, core):
    light_only, sound_only = tmp_path / "l.h5", tmp_path / "s.h5"
    assert main(["bake", "paper-small", "-o", str(light_only), "--no-sound", "--particles",
                 "10000", "-q"]) == 0
    assert main(["bake", "paper-small", "-o", str(sound_only), "--no-light", "--rays", "200",
                 "-q"]) == 0
    capsys.readouterr()
    assert contents(light_only)["sound"] is False and contents(sound_only)["light"] is False
    assert main(["info", str(light_only)]) == 0 and "light field" in capsys.readouterr().out
    assert main(["render", str(sound_only), "-o", str(tmp_path / "x.png")]) == 2
    assert "no light field" in capsys.readouterr().err
    assert main(["bake", "paper-small", "-o", str(tmp_path / "n.h5"), "--no-sound",
                 "--no-light"]) == 2
    assert "nothing to bake" in capsys.readouterr().err


def test_cli_camera_errors_name_the_field(tmp_path, small_light, capsys):
    path = save_fields(tmp_path / "l.h5", light=small_light)
    for args, word in ((["--fov", "0"], "fov_deg"), (["--camera=-1,1,1"], "outside the room"),
                       (["--camera", "1,1,1", "--look-at", "1,1,1"], "look_at_m"),
                       (["--size", "0x10"], "width"), (["--hdr", "x.tiff"], ".pfm")):
        assert main(["render", str(path), "-o", str(tmp_path / "v.png"), *args]) == 2
        err = capsys.readouterr().err
        assert word in err and "Traceback" not in err
