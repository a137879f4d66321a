"""Loading scenes: the three ways in give the same Scene, and what is loaded is what was said."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest

from sonolux.errors import SceneError
from sonolux.scene import builtin, load_scene
from sonolux.scene.load import weld
from tests.conftest import EXAMPLES

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

pytestmark = pytest.mark.usefixtures("core")

ROOM = """
name = "test room"
[[geometry]]
type = "shoebox"
size_m = [6, 4, 3]

[geometry.materials]
walls = "concrete-painted"
floor = "carpet-on-concrete"
default = "plaster-smooth"

[[sources]]
position_m = [3, 2, 1.5]
"""

# A 4 x 3 x 2.5 m box written per usemtl group with its own vertices (as exporters do), with
# normals facing in; the loader must weld the groups into one closed surface.
BOX_OBJ = """
mtllib missing.mtl
v 0 0 0
v 4 0 0
v 4 3 0
v 0 3 0
usemtl Floor
f 1 2 3
f 1 3 4
v 0 0 2.5
v 4 0 2.5
v 4 3 2.5
v 0 3 2.5
usemtl Ceiling
f 5 7 6
f 5 8 7
v 0 0 0
v 4 0 0
v 4 3 0
v 0 3 0
v 0 0 2.5
v 4 0 2.5
v 4 3 2.5
v 0 3 2.5
usemtl Wall
f 9 13 14
f 9 14 10
f 10 14 15
f 10 15 11
f 11 15 16
f 11 16 12
f 12 16 13
f 12 13 9
"""


def test_paper_large_volume_area_and_materials():
    scene = load_scene("paper-large")
    assert scene.origin == "built-in paper-large"
    assert scene.triangles.shape == (12, 3) and scene.triangles.dtype == np.int64
    assert scene.vertices_m.shape == (8, 3) and scene.vertices_m.flags.c_contiguous
    assert scene.volume_m3 == pytest.approx(1920.0, rel=1e-9)
    assert scene.area_m2 == pytest.approx(1024.0, rel=1e-9)
    assert scene.area_by_material_m2() == pytest.approx({"paper-floor": 240.0, "paper-wall": 784.0})
    assert scene.mesh_report["signed_volume_m3"] < 0  # normals face into the room
    assert scene.warnings == []


@pytest.mark.parametrize(("name", "size"), [("paper-small", (6, 2.5, 2)),
                                            ("paper-medium", (12, 5, 4)),
                                            ("paper-large", (24, 10, 8))])
def test_paper_scenes_follow_the_paper(name, size):
    length, width, height = size
    scene = load_scene(name)
    np.testing.assert_allclose(scene.mesh_report["bbox_max"], size)
    wall = next(m for m in scene.materials if m.name == "paper-wall")
    floor = next(m for m in scene.materials if m.name == "paper-floor")
    np.testing.assert_array_equal(wall.absorption, 0.05)  # 95 % of sound reflected
    np.testing.assert_array_equal(floor.absorption, 0.30)  # 70 % of sound reflected
    np.testing.assert_array_equal(wall.diffuse_rgb, 0.98)
    np.testing.assert_array_equal(floor.diffuse_rgb, 0.30)
    assert {tuple(m.scattering) for m in scene.materials} == {(0.1,) * 8}
    assert set(scene.surface_tag[scene.material_index == scene.materials.index(floor)]) == {
        "floor"}
    (talker,) = scene.sources
    np.testing.assert_allclose(talker.position_m, [length / 2, width / 2, 1.5])
    (strip,) = scene.lights
    assert strip.area_m2 == pytest.approx(0.5 * length * 0.02 * length)
    corners = strip.triangles_m.reshape(-1, 3)
    assert np.allclose(corners[:, 2], height - 0.001)
    normal = np.cross(strip.triangles_m[:, 1] - strip.triangles_m[:, 0],
                      strip.triangles_m[:, 2] - strip.triangles_m[:, 0])
    assert np.all(normal[:, 2] < 0)  # facing down


def test_builtin_names():
    assert builtin.names() == ["paper-large", "paper-medium", "paper-small"]


def test_toml_file_and_dict_give_the_same_scene(write, library):
    from_file = load_scene(write("room.toml", ROOM), library=library)
    from_dict = load_scene(tomllib.loads(ROOM), library=library)
    assert from_dict.origin == "<dict>" and from_file.name == from_dict.name == "test room"
    np.testing.assert_array_equal(from_file.vertices_m, from_dict.vertices_m)
    np.testing.assert_array_equal(from_file.triangles, from_dict.triangles)
    assert [m.name for m in from_file.materials] == [m.name for m in from_dict.materials]


def test_shoebox_face_materials_walls_and_default(library):
    scene = load_scene(tomllib.loads(ROOM), library=library)
    by_tag = {t: scene.materials[i].name for t, i in zip(scene.surface_tag, scene.material_index)}
    assert by_tag == {"floor": "carpet-on-concrete", "ceiling": "plaster-smooth",
                      "west": "concrete-painted", "east": "concrete-painted",
                      "south": "concrete-painted", "north": "concrete-painted"}
    assert scene.area_by_material_m2() == pytest.approx(
        {"carpet-on-concrete": 24.0, "plaster-smooth": 24.0, "concrete-painted": 60.0})


def test_settings_defaults_and_derived_values(library):
    scene = load_scene(tomllib.loads(ROOM), library=library)
    s = scene.settings
    assert s.bands_hz == (125, 250, 500, 1000, 2000, 4000) and s.bands == "octave"
    assert s.band_set.n_bands == 6
    assert s.sample_rate_hz == 48000 and s.energy_drop_db == 60 and s.seed == 1
    assert s.speed_of_sound_m_s == pytest.approx(343.21, abs=0.01)
    data = tomllib.loads(ROOM)
    data["settings"] = {"bands_hz": [63, 125], "air": {"temperature_c": 0}}
    s = load_scene(data, library=library).settings
    assert s.bands_hz == (63, 125) and s.bands == "octave"
    assert s.speed_of_sound_m_s == pytest.approx(331.3)


def test_material_override_base_and_new(library):
    data = tomllib.loads(ROOM)
    data["materials"] = {
        "plaster-smooth": {"scattering": 0.3},  # override of the library entry
        "whiteboard": {"base": "concrete-painted", "specular": 0.4},
        "foam": {"absorption": 0.9},  # new
    }
    data["geometry"][0]["materials"] = {"default": "plaster-smooth", "north": "whiteboard",
                                        "floor": "foam"}
    scene = load_scene(data, library=library)
    mats = {m.name: m for m in scene.materials}
    lib = library.materials
    np.testing.assert_array_equal(mats["plaster-smooth"].scattering, 0.3)
    np.testing.assert_array_equal(mats["plaster-smooth"].absorption,
                                  lib["plaster-smooth"].absorption)
    np.testing.assert_array_equal(mats["whiteboard"].absorption,
                                  lib["concrete-painted"].absorption)
    assert mats["whiteboard"].specular == 0.4
    np.testing.assert_array_equal(mats["foam"].absorption, 0.9)
    np.testing.assert_array_equal(mats["foam"].scattering, 0.1)  # documented default


def test_obj_usemtl_groups_map_to_materials(write, library):
    write("box.obj", BOX_OBJ)  # its .mtl is missing: the usemtl names must survive anyway
    path = write("scene.toml", """
        [[geometry]]
        type = "mesh"
        file = "box.obj"
        material = "plaster-smooth"
        [geometry.material_map]
        Floor = "carpet-on-concrete"
        Wall = "concrete-painted"
    """)
    scene = load_scene(path, library=library)
    by_tag = {t: scene.materials[i].name for t, i in zip(scene.surface_tag, scene.material_index)}
    assert by_tag == {"Floor": "carpet-on-concrete", "Wall": "concrete-painted",
                      "Ceiling": "plaster-smooth"}
    assert scene.area_by_material_m2() == pytest.approx(
        {"carpet-on-concrete": 12.0, "concrete-painted": 35.0, "plaster-smooth": 12.0})
    # Welded: 8 corners, closed, wound consistently inward.
    assert scene.vertices_m.shape == (8, 3)
    r = scene.mesh_report
    assert (r["n_open_edges"], r["n_inconsistent_edges"], r["n_nonmanifold_edges"]) == (0, 0, 0)
    assert r["signed_volume_m3"] == pytest.approx(-30.0)
    assert scene.warnings == ["the scene has no sound source"]


def test_mesh_group_named_like_a_material_needs_no_map(write, library, tmp_path):
    write("box.obj", BOX_OBJ.replace("usemtl Wall", "usemtl glass-window"))
    scene = load_scene({"geometry": [{"type": "mesh", "file": "box.obj",
                                      "material": "plaster-smooth"}]},
                       library=library, base_dir=tmp_path)
    assert "glass-window" in [m.name for m in scene.materials]


def test_unused_material_map_key_is_a_warning(write, library, tmp_path):
    write("box.obj", BOX_OBJ)
    scene = load_scene({"geometry": [{"type": "mesh", "file": "box.obj",
                                      "material": "plaster-smooth",
                                      "material_map": {"Wal": "concrete-painted"}}]},
                       library=library, base_dir=tmp_path)
    assert any('"Wal" matches no material group' in w and 'did you mean "Wall"' in w
               for w in scene.warnings)


def test_mesh_scale_translate_and_y_up(write, library, tmp_path):
    write("box.obj", BOX_OBJ)
    entry = {"type": "mesh", "file": "box.obj", "material": "plaster-smooth", "scale": 0.5,
             "translate_m": [10, 0, 0], "up": "y"}
    scene = load_scene({"geometry": [entry]}, library=library, base_dir=tmp_path)
    # y-up to z-up: (x, y, z) -> (x, -z, y); a 4 x 3 x 2.5 box at half scale, moved 10 m in x.
    np.testing.assert_allclose(scene.mesh_report["bbox_min"], [10, -1.25, 0])
    np.testing.assert_allclose(scene.mesh_report["bbox_max"], [12, 0, 1.5])
    assert scene.volume_m3 == pytest.approx(30 / 8)


def test_stl_and_ply_are_read(library, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=[2, 3, 4])  # normals facing out of the box
    for suffix in ("stl", "ply"):
        box.export(tmp_path / f"box.{suffix}")
        scene = load_scene({"geometry": [{"type": "mesh", "file": f"box.{suffix}",
                                          "material": "plaster-smooth"}]},
                           library=library, base_dir=tmp_path)
        assert scene.volume_m3 == pytest.approx(24.0)
        assert any("face out of the room" in w for w in scene.warnings)


def test_gltf_keeps_material_names_and_is_y_up_by_default(library, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=[1, 2, 3])
    box.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(name="Oak"))
    trimesh.Scene({"thing": box}).export(tmp_path / "thing.glb")
    scene = load_scene({"geometry": [{"type": "mesh", "file": "thing.glb",
                                      "material_map": {"Oak": "glass-window"}}]},
                       library=library, base_dir=tmp_path)
    assert set(scene.surface_tag) == {"Oak"} and scene.materials[0].name == "glass-window"
    # y-up to z-up: the 2 m side (y in the file) becomes z, the 3 m side (z) becomes y.
    np.testing.assert_allclose(scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"],
                               [1, 3, 2])


def test_open_mesh_warns_where(write, library, tmp_path):
    no_ceiling = BOX_OBJ.replace("f 5 7 6\nf 5 8 7\n", "")
    write("open.obj", no_ceiling)
    scene = load_scene({"geometry": [{"type": "mesh", "file": "open.obj",
                                      "material": "plaster-smooth"}]},
                       library=library, base_dir=tmp_path)
    (warning,) = [w for w in scene.warnings if "not closed" in w]
    assert "4 open edge(s)" in warning and "near (" in warning and "2.5)" in warning


def test_lights_rectangle_and_surface(library):
    data = tomllib.loads(ROOM)
    data["lights"] = [
        {"name": "panel", "center_m": [3, 2, 2.9], "size_m": [2, 0.5], "normal": [0, 0, -2],
         "tangent": [1, 0, 0.3], "power_w": 50},
        {"name": "glowing floor", "type": "surface", "material": "carpet-on-concrete"},
    ]
    panel, glow = load_scene(data, library=library).lights
    assert panel.area_m2 == pytest.approx(1.0) and panel.power_w == 50
    t = panel.triangles_m
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    np.testing.assert_allclose(n / np.linalg.norm(n, axis=1, keepdims=True), [[0, 0, -1]] * 2,
                               atol=1e-12)
    np.testing.assert_allclose(t[0, 1] - t[0, 0], [2, 0, 0], atol=1e-12)  # along the tangent
    assert glow.kind == "surface" and glow.triangles_m.shape == (2, 3, 3)
    assert glow.area_m2 == pytest.approx(24.0) and glow.power_w == 100.0


def test_cone_source(library):
    data = tomllib.loads(ROOM)
    data["sources"] = [{"position_m": [1, 1, 1], "directivity": "cone", "axis": [0, 3, 4]}]
    (s,) = load_scene(data, library=library).sources
    assert s.name == "S1" and s.cone_half_angle_deg == 45.0
    np.testing.assert_allclose(s.axis, [0, 0.6, 0.8])


def test_shoebox_with_mesh_obstacle(write, library, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=[1, 1, 1]).export(tmp_path / "crate.stl")
    data = tomllib.loads(ROOM)
    data["geometry"].append({"type": "mesh", "file": "crate.stl", "material": "plaster-smooth",
                             "translate_m": [1, 1, 1]})
    data["sources"] = [{"position_m": [1, 1, 1]}]
    with pytest.raises(Exception, match="inside an obstacle"):
        load_scene(data, library=library, base_dir=tmp_path)
    data["sources"] = [{"position_m": [3, 2, 1.5]}]
    scene = load_scene(data, library=library, base_dir=tmp_path)
    assert scene.volume_m3 == pytest.approx(72.0 - 1.0)
    assert not any("face out" in w for w in scene.warnings)


@pytest.mark.parametrize("name", ["shoebox.toml", "mesh_room.toml"])
def test_examples_load_with_the_shipped_library(name):
    scene = load_scene(EXAMPLES / name)
    assert scene.warnings == []
    assert scene.receivers.count > 0


def test_l_room_example_is_closed_and_is_what_its_generator_writes(tmp_path):
    """examples/l-room: the committed OBJ is its generator's output, and the scene loads
    without a warning (closed, consistently wound, every listener kept)."""
    folder = EXAMPLES.parent / "l-room"
    spec = importlib.util.spec_from_file_location("make_l_room", folder / "make_l_room.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.write_obj(tmp_path / "l-room.obj") == 652
    assert (tmp_path / "l-room.obj").read_text() == (folder / "l-room.obj").read_text()
    scene = load_scene(folder / "l-room.toml")
    assert scene.warnings == []
    r = scene.mesh_report
    assert (r["n_open_edges"], r["n_nonmanifold_edges"], r["n_inconsistent_edges"]) == (0, 0, 0)
    # 12 x 9 x 3.2 m less the 5 x 4 m notch, less what the furniture fills (under 2 m³).
    assert 281.6 - 2.0 < scene.volume_m3 < 281.6
    assert scene.receivers.count == 4


def test_weld_joins_close_vertices_and_drops_unused():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [9, 9, 9], [1 + 1e-8, 0, 0], [0, 0, 1]],
                 dtype=float)
    t = np.array([[0, 1, 2], [0, 4, 5]])
    welded, tri = weld(v, t)
    assert welded.shape == (4, 3)
    np.testing.assert_array_equal(tri, [[0, 1, 2], [0, 1, 3]])


@pytest.mark.parametrize("size_m", [[9223372036855.0, 4, 3], [4, 2e5, 3]])
def test_a_geometry_beyond_the_coordinate_limit_is_named(size_m, library):
    # Found by the hardening tests: a 9e12 m shoebox overflowed the vertex weld's integer grid.
    with pytest.raises(SceneError, match=r"geometry\[0\].*within 100000 m"):
        load_scene({"geometry": [{"type": "shoebox", "size_m": size_m,
                                  "materials": {"default": "concrete-painted"}}]},
                   library=library)


def test_band_settings_choose_octaves_or_thirds(library):
    data = tomllib.loads(ROOM)
    data["settings"] = {"bands": "third-octave"}
    s = load_scene(data, library=library).settings
    assert s.bands == "third-octave" and s.bands_hz[0] == 100 and s.bands_hz[-1] == 5000
    data["settings"] = {"bands": "third-octave", "band_range_hz": [25, 20000]}
    assert load_scene(data, library=library).settings.band_set.n_bands == 30
    data["settings"] = {"band_range_hz": [31.5, 16000]}
    assert load_scene(data, library=library).settings.bands_hz[0] == 31.5
    data["settings"] = {"bands": [1000, 1250, 1600]}
    assert load_scene(data, library=library).settings.bands == "third-octave"
    data["settings"] = {"bands": "octave"}
    assert load_scene(data, library=library).settings.bands_hz == (125, 250, 500, 1000, 2000,
                                                                    4000)


def test_materials_in_thirds_convert_to_the_scene_bands(library):
    data = tomllib.loads(ROOM)
    thirds = [100, 125, 160, 200, 250, 315]
    data["materials"] = {"panel": {"bands_hz": thirds,
                                   "absorption": [0.1, 0.2, 0.6, 0.3, 0.3, 0.9]}}
    data["geometry"][0]["materials"] = {"default": "panel"}
    data["settings"] = {"bands_hz": [125, 250]}
    scene = load_scene(data, library=library)
    (panel,) = scene.materials
    np.testing.assert_allclose(panel.absorption_in(scene.settings.band_set), [0.3, 0.5],
                               rtol=1e-15)
    # Its scattering (not given) is the new-material default on the same thirds.
    np.testing.assert_array_equal(panel.scattering_in(scene.settings.band_set), 0.1)
