"""Light physics through the Python API: the furnace and the Monte Carlo convergence rate."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.light.bake import bake_light

from .conftest import furnace_scene


def test_furnace_radiance_is_le_over_one_minus_rho(core):
    # A closed room whose every wall emits Le and reflects ρ diffusely: the radiance is
    # Le / (1 − ρ) everywhere, per channel.
    rho = np.array([0.5, 0.6, 0.7])
    scene = furnace_scene(rho=tuple(rho), power_w=12.0)
    field = bake_light(scene, particles=200_000, patch_size_m=0.25)
    le = 12.0 / (np.pi * 24.0)
    expected = le / (1 - rho)
    radiance = field.radiance_w_m2_sr
    area = field.patch_area_m2[:, None]
    mean = (radiance * area).sum(axis=0) / area.sum()
    # The room's mean: 200 000 particles make ~1e6 deposits, a relative noise of about 0.2%
    # on the reflected part; 1% is five of those.
    assert mean == pytest.approx(expected, rel=0.01)
    # Every patch within 5 of its own standard deviations (≈ 1/sqrt(hits) of the reflected
    # part): a wrong emission side or a lost channel would miss by far more.
    reflected = radiance - le
    sigma = (expected - le) / np.sqrt(field.hits)[:, None]
    assert np.all(np.abs(reflected - (expected - le)) < 5 * sigma + 1e-12)


def test_doubling_particles_halves_a_patch_variance(core):
    # In the furnace every patch (all of one area in a cube) has the same expected irradiance,
    # so the spread across patches is the estimator's variance. With ~1500 patches the sample
    # variance is known to about 4%, the ratio to about 6%: ±15% is 2.5 of those.
    scene = furnace_scene(rho=(0.6, 0.6, 0.6))
    variances = []
    for n in (40_000, 80_000):
        e = bake_light(scene, particles=n, patch_size_m=0.2).irradiance_w_m2[:, 0]
        variances.append(np.var(e / e.mean()))
    assert variances[0] / variances[1] == pytest.approx(2.0, rel=0.15)
