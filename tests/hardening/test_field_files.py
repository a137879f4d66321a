"""Damaged field files: every dataset of /sound and /light removed, filled with NaN, made
negative, cut to the wrong shape or turned into text; attributes spoiled; the file truncated
at many lengths. Every reader command (info, params, ir, auralize, render, export, report)
refuses each with exit status 2 and one line naming the file, never a traceback or a WAV of
NaN. As a property: any value written into any dataset opens or is a FieldFileError."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sonolux.errors import FieldFileError
from sonolux.fieldfile import open_field, open_light_field

from .conftest import assert_usage_error, run

#: The sound field is stored compact (docs/fieldfile.md, format 3): its energy is a group.
SOUND = ["energy/late", "energy/early", "energy/cell", "energy/offset", "energy/envelope",
         "energy/onset", "bin_start_s", "bin_width_s", "bands_hz", "receivers_m", "grid_index",
         "sources_m", "source_powers_w"]
LIGHT = ["patch_resolution", "patch_offset", "patch_area_m2", "flux_w", "hits",
         "scene/vertices_m", "scene/triangles", "scene/material_index", "scene/rho",
         "emitters/triangles_m", "emitters/radiance", "lights/power_w"]
DAMAGE = ["missing", "nan", "negative", "shape", "text"]


def damage(path, name: str, how: str) -> None:
    with h5py.File(path, "r+") as f:
        if isinstance(f[name], h5py.Group):  # only removed whole
            del f[name]
            return
        data = f[name][...]
        del f[name]
        if how == "missing":
            return
        if how == "nan":
            data = np.full(data.shape, np.nan)
        elif how == "negative":
            data = -1 - np.abs(data.astype(np.float64))
        elif how == "shape":
            data = np.concatenate([data.reshape(-1), data.reshape(-1)[:1]]) if data.size else np.ones(3)
        elif how == "text":
            data = np.array(["x"] * max(data.size, 1), dtype=h5py.string_dtype())
        f[name] = data


def command_for(group: str, path) -> list[str]:
    if group == "sound":
        return ["params", path]
    return ["render", path, "-o", path.with_suffix(".png"), "--size", "32x16", "--samples", "1"]


#: Coordinates may be negative; a field of listed receivers has no grid index.
VALID = {("sound", "receivers_m", "negative"), ("sound", "sources_m", "negative"),
         ("light", "scene/vertices_m", "negative"), ("light", "emitters/triangles_m", "negative"),
         ("sound", "grid_index", "missing")}
CASES = [c for c in [("sound", n, h) for n in SOUND for h in DAMAGE]
         + [("light", n, h) for n in LIGHT for h in DAMAGE] if c not in VALID]


CASES.append(("sound", "energy", "missing"))


@pytest.mark.parametrize(("group", "name", "how"), CASES, ids=[f"{g}/{n}-{h}" for g, n, h in CASES])
def test_a_damaged_dataset_is_named(capsys, field_copy, group, name, how):
    damage(field_copy, f"{group}/{name}", how)
    code, _, err = run(capsys, *command_for(group, field_copy))
    assert_usage_error(code, err, str(field_copy))
    assert not field_copy.with_suffix(".png").exists()


#: The readers of each part of the file.
READERS = {
    "sound": [["info", "{f}"], ["params", "{f}"], ["params", "{f}", "--at", "1,1"],
              ["ir", "{f}", "--at", "1,1", "-o", "{d}/x.wav"],
              ["auralize", "{f}", "builtin:clicks:0.5", "--at", "1,1", "-o", "{d}/y.wav"],
              ["export", "{f}", "--web", "{d}/web"], ["report", "{f}", "-o", "{d}/rep"]],
    "light": [["info", "{f}"], ["render", "{f}", "-o", "{d}/v.png", "--size", "16x8"],
              ["export", "{f}", "--gltf", "{d}/s.glb"]],
}
READERS["/"] = READERS["sound"] + READERS["light"][1:]
ATTRS = [("sound", "settings", "{not json"), ("sound", "stats", "[1, 2"),
         ("sound", "radius_m", np.nan), ("sound", "radius_m", -1.0), ("sound", "quantum", "x"),
         ("light", "patch_size_m", 0.0), ("light", "settings", "{"), ("/", "schema", "nonsense")]
ATTR_CASES = [(g, a, v, argv) for g, a, v in ATTRS for argv in READERS[g]]


@pytest.mark.parametrize(("group", "attr", "value", "argv"), ATTR_CASES,
                         ids=[f"{g}.{a}={v}-{' '.join(c[:1] + c[2:3])}" for g, a, v, c in ATTR_CASES])
def test_a_spoiled_attribute_is_refused_by_every_reader(capsys, field_copy, tmp_path, argv,
                                                        group, attr, value):
    with h5py.File(field_copy, "r+") as f:
        f[group].attrs[attr] = value
    code, _, err = run(capsys, *[a.format(f=field_copy, d=tmp_path) for a in argv])
    assert_usage_error(code, err, str(field_copy))
    assert not any(p.suffix in (".wav", ".png", ".glb") for p in tmp_path.iterdir())


@pytest.mark.parametrize("fraction", [0.0, 0.001, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.9999])
@pytest.mark.parametrize("command", ["info", "params"])
def test_a_truncated_field_file_is_named(capsys, field_file, tmp_path, fraction, command):
    data = field_file.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: int(len(data) * fraction)])
    code, _, err = run(capsys, command, cut)
    assert_usage_error(code, err, str(cut))


@given(name=st.sampled_from([f"sound/{n}" for n in SOUND] + [f"light/{n}" for n in LIGHT]),
       values=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=0,
                       max_size=8))
def test_any_values_in_any_dataset_open_or_are_a_field_file_error(field_file, tmp_path_factory,
                                                                  name, values):
    path = tmp_path_factory.mktemp("prop") / "f.h5"
    path.write_bytes(field_file.read_bytes())
    with h5py.File(path, "r+") as f:
        old = f[name][...]
        flat = old.astype(np.float64).reshape(-1).copy()
        flat[: len(values)] = values[: flat.size]
        del f[name]
        # Stored as float64 where the values do not fit the dataset's own type.
        fits = old.dtype.kind == "f" or bool(np.all(np.abs(flat) < 2**31))
        f[name] = flat.reshape(old.shape).astype(old.dtype if fits else np.float64)
    try:
        (open_field if name.startswith("sound") else open_light_field)(path)
    except FieldFileError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc)
