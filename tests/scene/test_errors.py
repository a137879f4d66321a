"""Each way a scene can be wrong gives one SceneError that names file, line, key and value.

Errors found before the geometry is built need no compiled core; the others ask for ``core``.
"""

from __future__ import annotations

import pytest

from sonolux.errors import SceneError
from sonolux.scene import load_scene

ROOM = """
[[geometry]]
type = "shoebox"
size_m = [6, 4, 3]

[geometry.materials]
default = "plaster-smooth"
floor = "carpet-on-concrete"
"""


def error_of(scene, library, **kw) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(scene, library=library, **kw)
    return info.value


def test_absorption_outside_0_1_names_file_line_key_value(write, library):
    path = write("scene.toml", """
        [materials.wall]
        absorption = [0.1, 0.1, 0.1, 1.2, 0.1, 0.1, 0.1, 0.1]
    """ + ROOM)
    err = error_of(path, library)
    assert str(err) == (f"{path}:2: materials.wall.absorption[3] = 1.2 is not allowed: "
                        "a number in [0, 1]")
    assert (err.key, err.value, err.line) == ("materials.wall.absorption[3]", 1.2, 2)


def test_scalar_absorption_out_of_range(library):
    err = error_of({"materials": {"wall": {"absorption": -0.1}}, "geometry": []}, library)
    assert str(err) == "<dict>: materials.wall.absorption = -0.1 is not allowed: a number in [0, 1]"


def test_nan_size_is_rejected_before_any_geometry(write, library):
    path = write("scene.toml", ROOM.replace("[6, 4, 3]", "[6, nan, 3]"))
    err = error_of(path, library)
    assert err.key == "geometry[0].size_m[1]"
    assert "= nan is not allowed: a number > 0" in str(err)
    assert err.line == 3


def test_nan_source_position(write, library):
    path = write("scene.toml", ROOM + """
        [[sources]]
        position_m = [1, nan, 1]
    """)
    err = error_of(path, library)
    assert str(err) == (f"{path}:10: sources[0].position_m[1] = nan is not allowed: "
                        "a finite number")


def test_unknown_material_lists_close_matches(write, library):
    path = write("scene.toml", ROOM.replace('"carpet-on-concrete"', '"carpet-on-concret"'))
    err = error_of(path, library)
    assert err.key == "geometry[0].materials.floor"
    assert err.matches[0] == "carpet-on-concrete"
    assert str(err).endswith('did you mean "carpet-on-concrete"?')
    assert err.line == 7


def test_unknown_base_material(library):
    scene = {"materials": {"x": {"base": "plaster-smoth"}}, "geometry": []}
    err = error_of(scene, library)
    assert err.key == "materials.x.base" and err.matches == ["plaster-smooth"]


def test_new_material_needs_absorption(library):
    err = error_of({"materials": {"brand-new": {"scattering": 0.2}}, "geometry": []}, library)
    assert err.key == "materials.brand-new.absorption"
    assert "is required" in str(err)


def test_missing_mesh_file(write, library):
    path = write("scene.toml", """
        [[geometry]]
        type = "mesh"
        file = "nowhere.obj"
    """)
    err = error_of(path, library)
    assert err.key == "geometry[0].file" and err.line == 3
    assert 'no such mesh file "nowhere.obj"' in str(err)
    assert str(path.parent / "nowhere.obj") in str(err)


def test_mesh_of_unknown_format(write, library, tmp_path):
    write("room.xyz", "")
    err = error_of({"geometry": [{"type": "mesh", "file": "room.xyz"}]}, library,
                   base_dir=tmp_path)
    assert err.key == "geometry[0].file" and ".obj" in err.allowed


def test_empty_mesh(write, library):
    write("empty.obj", "# nothing but a point\nv 0 0 0\n")
    path = write("scene.toml", """
        [[geometry]]
        type = "mesh"
        file = "empty.obj"
        material = "plaster-smooth"
    """)
    err = error_of(path, library)
    assert err.key == "geometry[0].file"
    assert 'the mesh "empty.obj" contains no triangles' in str(err)


def test_zero_volume_room(write, library, core):
    write("flat.obj", "v 0 0 0\nv 4 0 0\nv 4 3 0\nv 0 3 0\nf 1 2 3\nf 1 3 4\n")
    path = write("scene.toml", """
        [[geometry]]
        type = "mesh"
        file = "flat.obj"
        material = "plaster-smooth"
    """)
    err = error_of(path, library)
    assert err.key == "geometry"
    assert "encloses no volume" in str(err)


def test_negative_spacing(write, library):
    path = write("scene.toml", ROOM + """
        [receivers]
        spacing_m = -1.0
    """)
    err = error_of(path, library)
    assert str(err) == f"{path}:10: receivers.spacing_m = -1.0 is not allowed: a number > 0"


def test_radius_larger_than_spacing(library):
    scene = {"geometry": [], "receivers": {"spacing_m": 0.5, "radius_m": 0.6}}
    err = error_of(scene, library)
    assert err.key == "receivers.radius_m" and err.allowed == "a number in [0.0001, 0.5]"


def test_unknown_top_level_key_lists_allowed_keys(write, library):
    path = write("scene.toml", "sources_ = 1\n" + ROOM)
    err = error_of(path, library)
    assert err.key == "sources_" and err.line == 1
    assert "unknown key; the keys allowed here are name, settings, materials" in str(err)
    assert err.matches == ["sources"]


def test_unknown_nested_key_with_close_match(write, library):
    path = write("scene.toml", "[settings]\nsampel_rate_hz = 44100\n" + ROOM)
    err = error_of(path, library)
    assert err.key == "settings.sampel_rate_hz" and err.line == 2
    assert str(err).endswith('did you mean "sample_rate_hz"?')


def test_toml_syntax_error_names_the_line(write, library):
    path = write("scene.toml", 'name = "room"\n[settings]\nseed = = 3\n')
    err = error_of(path, library)
    assert err.line == 3
    assert str(err).startswith(f"{path}:3: TOML syntax error:")


def test_bands_must_be_a_contiguous_run(library):
    err = error_of({"settings": {"bands_hz": [125, 500]}, "geometry": []}, library)
    assert err.key == "settings.bands_hz" and "contiguous" in err.allowed


def test_air_out_of_range(library):
    err = error_of({"settings": {"air": {"humidity_percent": 120}}, "geometry": []}, library)
    assert str(err) == ("<dict>: settings.air.humidity_percent = 120 is not allowed: "
                        "a number in [0, 100]")


def test_integer_settings_reject_floats_and_bools(library):
    err = error_of({"settings": {"seed": 1.5}, "geometry": []}, library)
    assert err.allowed == "an integer in [0, 18446744073709551615]"
    err = error_of({"settings": {"sample_rate_hz": True}, "geometry": []}, library)
    assert err.key == "settings.sample_rate_hz"


def test_no_geometry(library):
    err = error_of({"name": "x"}, library)
    assert err.key == "geometry" and "at least one [[geometry]]" in str(err)


def test_shoebox_face_without_material(library):
    err = error_of({"geometry": [{"type": "shoebox", "size_m": [1, 1, 1],
                                  "materials": {"walls": "plaster-smooth"}}]}, library)
    assert err.key == "geometry[0].materials" and "floor, ceiling" in str(err)


def test_unmapped_mesh_material(write, library, tmp_path):
    write("room.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl Wal\nf 1 2 3\n")
    err = error_of({"geometry": [{"type": "mesh", "file": "room.obj"}]}, library,
                   base_dir=tmp_path)
    assert err.key == "geometry[0].material_map"
    assert 'mesh material "Wal"' in str(err)


def test_cone_keys_need_a_cone(library):
    scene = {"geometry": [], "sources": [{"position_m": [1, 1, 1], "axis": [1, 0, 0]}]}
    err = error_of(scene, library)
    assert str(err) == '<dict>: sources[0].axis: is only allowed with directivity = "cone"'


def test_duplicate_source_names(library):
    scene = {"geometry": [], "sources": [{"name": "a", "position_m": [1, 1, 1]},
                                         {"name": "a", "position_m": [2, 1, 1]}]}
    assert error_of(scene, library).key == "sources[1].name"


def test_light_tangent_parallel_to_normal(library):
    scene = {"geometry": [], "lights": [{"center_m": [1, 1, 1], "size_m": [1, 1],
                                         "normal": [0, 0, -1], "tangent": [0, 0, 2]}]}
    err = error_of(scene, library)
    assert err.key == "lights[0].tangent" and "not parallel" in err.allowed


@pytest.mark.parametrize("normal", [[0, 0, 1.4e-287], [0, 1e-170, 0], [1e200, 1e200, 0]])
def test_light_normal_whose_length_is_not_a_float(library, normal):
    # Found by the hardening walk: a normal of (0, 0, 1.4e-287) is not zero, but its length
    # underflows to 0 and normalising it divided by zero.
    scene = {"geometry": [], "lights": [{"center_m": [1, 1, 1], "size_m": [1, 1],
                                         "normal": normal}]}
    err = error_of(scene, library)
    assert err.key == "lights[0].normal" and "finite, non-zero" in err.allowed


def test_source_outside_the_room(write, library, core):
    path = write("scene.toml", ROOM + """
        [[sources]]
        position_m = [7, 1, 1]
    """)
    err = error_of(path, library)
    assert err.key == "sources[0].position_m" and err.line == 10
    assert "outside the closed volume" in str(err)


def test_surface_light_of_unused_material(library, core):
    scene = {"geometry": [{"type": "shoebox", "size_m": [2, 2, 2],
                           "materials": {"default": "plaster-smooth"}}],
             "lights": [{"type": "surface", "material": "plaster-smoth"}]}
    err = error_of(scene, library)
    assert err.key == "lights[0].material" and err.matches == ["plaster-smooth"]


def test_unknown_scene_name_suggests_builtins():
    with pytest.raises(SceneError) as info:
        load_scene("paper-smal")
    assert info.value.matches[0] == "paper-small"


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="no such file"):
        load_scene(tmp_path / "nope.toml")


def test_not_a_scene():
    with pytest.raises(SceneError, match="a scene is a path"):
        load_scene(42)


@pytest.mark.parametrize(("settings", "key", "allowed"), [
    ({"bands": "thirds"}, "settings.bands", 'one of "octave", "third-octave"'),
    ({"bands": [125, 200]}, "settings.bands", "contiguous run of the octave centres"),
    ({"bands": "octave", "bands_hz": [100, 125]}, "settings.bands_hz",
     "contiguous run of the octave centres"),
    ({"bands": [125, 250], "bands_hz": [125, 250]}, "settings.bands_hz", "nothing when bands"),
    ({"bands": "third-octave", "band_range_hz": [100, 90]}, "settings.band_range_hz",
     "two third-octave centres"),
    ({"bands": "third-octave", "band_range_hz": [100, 20000], "sample_rate_hz": 32000},
     "settings.band_range_hz", "below the Nyquist frequency 16000 Hz"),
])
def test_band_settings_are_validated(library, settings, key, allowed):
    err = error_of({"settings": settings, "geometry": []}, library)
    assert err.key == key and allowed in err.allowed, str(err)


def test_material_bands_are_validated(library):
    scene = {"materials": {"m": {"bands_hz": [100, 125, 150], "absorption": 0.5}},
             "geometry": []}
    err = error_of(scene, library)
    assert err.key == "materials.m.bands_hz" and "third-octave centres" in err.allowed
    scene = {"materials": {"m": {"bands_hz": [100, 125, 160], "absorption": [0.5, 0.5]}},
             "geometry": []}
    err = error_of(scene, library)
    assert err.key == "materials.m.absorption" and "list of 3 such numbers" in err.allowed
