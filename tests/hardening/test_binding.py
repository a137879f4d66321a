"""The binding's settings objects with random values, through the engine gateway: every
combination either traces or raises a SonoluxError (InvalidInputError from the core's checks
or from the binding's argument conversion), never a panic of the core (pyo3's PanicException,
a BaseException) or another exception."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import sonolux
from sonolux import engine
from sonolux.errors import SonoluxError

ODD_FLOATS = st.one_of(st.sampled_from([np.nan, np.inf, -np.inf, 0.0, -1.0, 1e-300, 1e300]),
                       st.floats(allow_nan=True, allow_infinity=True))
ODD_INTS = st.one_of(st.sampled_from([0, -1, 2**64, 2**63, 10**30]), st.integers(-5, 5))
NUMBER = st.one_of(ODD_FLOATS, ODD_INTS, st.text(max_size=3), st.none(), st.booleans())


@pytest.fixture(scope="module")
def room():
    scene = sonolux.load_scene("paper-small")
    n_mat = len(scene.materials)
    return scene, n_mat


def good_settings() -> dict:
    return dict(rays=200, first_ray=0, end_ray=200, seed=1, threads=1, estimator="paper",
                speed_of_sound_m_s=343.0, air_attenuation_per_m=[0.001] * 6, energy_drop_db=60.0,
                max_time_s=0.3, sample_rate_hz=8000.0, early_s=0.01, late_bin_s=0.005,
                azimuth_bands=8, elevation_bands=1, max_field_bytes=1 << 24)


@given(changes=st.dictionaries(st.sampled_from(sorted(good_settings())), NUMBER, min_size=1,
                               max_size=3),
       radius=ODD_FLOATS, position=st.lists(ODD_FLOATS, min_size=3, max_size=3))
def test_random_settings_trace_or_raise_a_sonolux_error(room, changes, radius, position):
    scene, n_mat = room
    settings = {**good_settings(), **changes}
    try:
        out = engine.trace_sound(
            scene.geometry,
            engine.Acoustics(np.full((n_mat, 6), 0.2), np.full((n_mat, 6), 0.1)),
            [engine.SoundSource(tuple(position), 1.0, engine.Directivity.omni())],
            engine.Receivers(np.array([[1.0, 1.0, 1.5], [2.0, 1.0, 1.5]]), radius),
            engine.SoundSettings(**settings), None)
    except SonoluxError as exc:
        assert str(exc)
        return
    assert np.all(np.isfinite(out["energy"])) and np.all(out["energy"] >= 0)


@given(particles=ODD_INTS, patch=ODD_FLOATS, bounces=ODD_INTS, threads=ODD_INTS)
def test_random_light_settings_trace_or_raise_a_sonolux_error(room, particles, patch, bounces,
                                                              threads):
    scene, _ = room
    from sonolux.light.bake import light_arrays

    arrays = light_arrays(scene)
    try:
        settings = engine.LightSettings(
            particles=min(particles, 500) if isinstance(particles, int) else particles,
            first_ray=0, end_ray=min(particles, 500) if isinstance(particles, int) else 1,
            seed=1, threads=threads, patch_size_m=max(patch, 0.2) if patch == patch else patch,
            max_bounces=bounces)
        engine.trace_light(scene.geometry, engine.Optics(arrays["rho"], arrays["specular"],
                                                         arrays["roughness"]),
                           engine.Emitters(arrays["emitters"], arrays["emitter_flux"]), settings)
    except SonoluxError as exc:
        assert str(exc)
