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

