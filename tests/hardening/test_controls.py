"""The bake's controls that the scene and the API had and the command lacked: ``--seed``,
``--threads`` (the result does not depend on it) and ``--no-air``."""

from __future__ import annotations

import numpy as np

from sonolux.fieldfile import open_field

from .conftest import run


def bake(capsys, tmp_path, name, *flags):
    out = tmp_path / f"{name}.h5"
    code, _, err = run(capsys, "bake", "paper-small", "--rays", "1500", "--no-light", "-q",
                       "-o", out, *flags)
    assert code == 0, err
    return open_field(out)


def test_seed_threads_and_no_air(capsys, tmp_path):
    one = bake(capsys, tmp_path, "one", "--seed", "7", "--threads", "1")
    two = bake(capsys, tmp_path, "two", "--seed", "7", "--threads", "2")
    other = bake(capsys, tmp_path, "other", "--seed", "8", "--threads", "2")
    dry = bake(capsys, tmp_path, "dry", "--seed", "7", "--no-air")
    assert one.settings["seed"] == 7 and other.settings["seed"] == 8
    assert np.array_equal(one.energy, two.energy)  # same seed, same bits, any thread count
    assert not np.array_equal(one.energy, other.energy)
    assert np.all(np.asarray(dry.settings["air_attenuation_per_m"]) == 0)
    assert np.any(np.asarray(one.settings["air_attenuation_per_m"]) > 0)


def test_merge_of_ranges_is_the_whole_bake_and_names_what_is_wrong(capsys, tmp_path):
    def part(name, *flags):
        out = tmp_path / name
        code, _, err = run(capsys, "bake", "paper-small", "--rays", "3000", "--no-light", "-q",
                           "-o", out, *flags)
        assert code == 0, err
        return out

    a, b = part("a.h5", "--range", "0:1000"), part("b.h5", "--range", "1000:3000")
    whole = part("whole.h5")
    other = part("other.h5", "--range", "1000:3000", "--seed", "9")
    code, _, err = run(capsys, "merge", a, b, "-o", tmp_path / "m.h5")
    assert code == 0, err
    assert open_field(tmp_path / "m.h5").energy.tobytes() == open_field(whole).energy.tobytes()
    for parts, words in (([a], ["1000:3000", "missing"]), ([a, a], ["overlap", "a.h5"]),
                         ([a, other], ["other.h5", "different bakes"]),
                         ([a, whole], ["whole.h5", "ray range"]),
                         ([a, tmp_path / "none.h5"], ["none.h5", "no such file"])):
        code, _, err = run(capsys, "merge", *parts, "-o", tmp_path / "bad.h5")
        line = err.strip()
        assert code == 2 and "\n" not in line and all(w in line for w in words), err
        assert not (tmp_path / "bad.h5").exists()
    code, _, err = run(capsys, "merge", a, "--partial", "-o", tmp_path / "p.h5")
    assert code == 0 and "1000:3000" in err
