"""Finding the line of a dotted key in TOML text (for error messages)."""

from __future__ import annotations

from sonolux.scene.toml_lines import find_line, parse_key_path

TEXT = """\
name = "x"             # 1
[settings]             # 2
seed = 3               # 3
[settings.air]         # 4
temperature_c = 90     # 5
[[geometry]]           # 6
type = "shoebox"       # 7
[[geometry]]           # 8
type = "mesh"          # 9
file = "a.obj"         # 10
[geometry.material_map]  # 11
"Wall" = "plaster"     # 12
[[sources]]            # 13
position_m = [1, 2, 3] # 14
[materials.my-wall]    # 15
absorption = [0.1, 0.1, 0.1, 1.2, 0.1, 0.1, 0.1, 0.1]  # 16
"""


def test_parse_key_path():
    assert parse_key_path("geometry[1].material_map.Wall") == [
        ("geometry", 1), ("material_map", None), ("Wall", None)]


def test_lines_of_keys():
    assert find_line(TEXT, "name") == 1
    assert find_line(TEXT, "settings.seed") == 3
    assert find_line(TEXT, "settings.air.temperature_c") == 5
    assert find_line(TEXT, "geometry[0].type") == 7
    assert find_line(TEXT, "geometry[1].file") == 10
    assert find_line(TEXT, "geometry[1].material_map.Wall") == 12
    assert find_line(TEXT, "sources[0].position_m[2]") == 14
    assert find_line(TEXT, "materials.my-wall.absorption[3]") == 16


def test_missing_key_falls_back_to_its_table():
    assert find_line(TEXT, "geometry[1].scale") == 8
    assert find_line(TEXT, "sources[0]") == 13


def test_inline_tables_and_unknown_paths():
    assert find_line('settings = { seed = 1.5 }\n', "settings.seed") == 1
    assert find_line(TEXT, "receivers.spacing_m") is None
