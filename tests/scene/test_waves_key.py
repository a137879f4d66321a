"""The scene's ``[waves]`` table: read and checked at the edge, and resolved against the bake's
options (the options win; None takes the scene's)."""

from __future__ import annotations

import pytest

import sonolux
from sonolux.errors import SceneError, SettingError
from sonolux.sound.options import SoundOptions
from sonolux.sound.waves import DEFAULT_TIME_BUDGET_S, with_scene


def scene(waves=None):
    d = {
        "name": "box", "settings": {"bands_hz": [125, 250, 500, 1000]},
        "materials": {"m": {"absorption": 0.15}},
        "geometry": [{"type": "shoebox", "size_m": [5, 4, 3], "materials": {"default": "m"}}],
        "sources": [{"position_m": [1.3, 1.1, 1.4]}],
        "receivers": {"type": "points", "positions_m": [[2.9, 2.1, 1.2]]},
    }
    if waves is not None:
        d["waves"] = waves
    return sonolux.load_scene(d)


def test_the_table_sets_the_defaults_and_the_options_win():
    s = scene({"enabled": True, "crossover_hz": 300, "time_budget_s": 42})
    o = with_scene(s, SoundOptions())
    assert (o.waves, o.crossover_hz, o.wave_time_budget_s) == (True, 300.0, 42.0)
    o = with_scene(s, SoundOptions(crossover_hz=700, wave_time_budget_s=5))
    assert (o.waves, o.crossover_hz, o.wave_time_budget_s) == (True, 700.0, 5.0)
    # --no-waves turns a scene's waves off (and its crossover with them).
    o = with_scene(s, SoundOptions(waves=False))
    assert (o.waves, o.crossover_hz) == (False, None)


def test_without_the_table_waves_are_off_and_a_lone_crossover_is_refused():
    # Without a table the options come back as given (None: off; the bake reads a None budget
    # as DEFAULT_TIME_BUDGET_S), so a checkpoint's settings do not depend on the entry point.
    o = with_scene(scene(), SoundOptions())
    assert (o.waves, o.crossover_hz, o.wave_time_budget_s) == (None, None, None)
    assert not o.waves and DEFAULT_TIME_BUDGET_S == 600.0
    assert with_scene(scene(), SoundOptions(waves=True)).waves is True
    with pytest.raises(SettingError, match="crossover_hz"):
        with_scene(scene(), SoundOptions(crossover_hz=300))


@pytest.mark.parametrize("table, key", [
    ({"enabled": "yes"}, "waves.enabled"),
    ({"enabled": True, "crossover_hz": 5}, "waves.crossover_hz"),
    ({"enabled": True, "crossover_hz": "auto"}, "waves.crossover_hz"),
    ({"enabled": True, "time_budget_s": 0}, "waves.time_budget_s"),
    ({"enabled": True, "time_budget_s": float("inf")}, "waves.time_budget_s"),
    ({"crossover_hz": 300}, "waves.crossover_hz"),
    ({"enabled": True, "crossover": 300}, "waves.crossover"),
])
def test_bad_values_name_the_key(table, key):
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        scene(table)


def test_the_command_line_bakes_a_scenes_waves_and_no_waves_turns_them_off(tmp_path):
    """`sonolux bake` of a scene whose [waves] is enabled bakes the hybrid (its checkpointed range
    baker too, which takes the options as resolved), and --no-waves does not."""
    from sonolux.cli import main
    from sonolux.fieldfile import open_field

    scene_file = tmp_path / "box.toml"
    scene_file.write_text(
        'name = "box"\n[settings]\nbands_hz = [125, 250, 500, 1000]\n'
        '[materials.m]\nabsorption = 0.15\n[[geometry]]\ntype = "shoebox"\nsize_m = [5, 4, 3]\n'
        '[geometry.materials]\ndefault = "m"\n[[sources]]\nposition_m = [1.3, 1.1, 1.4]\n'
        '[receivers]\ntype = "points"\npositions_m = [[2.9, 2.1, 1.2]]\n'
        '[waves]\nenabled = true\ncrossover_hz = 177\n')
    on, off = tmp_path / "on.h5", tmp_path / "off.h5"
    assert main(["bake", str(scene_file), "--rays", "2000", "--quiet", "-o", str(on)]) == 0
    assert main(["bake", str(scene_file), "--rays", "2000", "--quiet", "--no-waves",
                 "-o", str(off)]) == 0
    assert open_field(on).waves["wave_bands"] == 1
    assert open_field(off).waves is None
