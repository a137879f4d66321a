"""The light bake from Python: energy balance, determinism, options, surface lights."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sonolux.errors import SonoluxError
from sonolux.light.bake import auto_particles, bake_light, channel_flux_w, light_arrays
from sonolux.light.options import LightOptions

from .conftest import furnace_scene


def test_flux_balance_holds_to_1e_9(small_light):
    # Tolerance 1e-9: the core tallies flux in 2⁻⁶⁴ W fixed point, so emitted + roulette =
    # absorbed + escaped holds to the last bits of a double; 1e-9 leaves room for rounding only.
    st = small_light.stats
    assert np.all(np.abs(small_light.balance_relative_error()) < 1e-9)
    assert st["flux_emitted_w"] == pytest.approx([60.0] * 3, rel=1e-12)
    # The patches tell the same story: each hit deposits the incident flux and the surface keeps
    # (1 − ρ) of it. Stochastic rounding to 2⁻⁵⁰ of the emitted flux per deposit adds at most
    # about 1e-10 relative over a bake of this size, so 1e-9 again.
    absorbed = (small_light.flux_w * (1 - small_light.rho[small_light.patch_material])).sum(axis=0)
    assert absorbed == pytest.approx(st["flux_absorbed_w"], rel=1e-9)
    assert st["escaped_particles"] == 0 and st["particles"] == 60_000


def test_same_seed_same_bits_on_one_and_two_threads(small_scene):
    one = bake_light(replace(small_scene, settings=replace(small_scene.settings, threads=1)),
                     particles=20_000)
    two = bake_light(replace(small_scene, settings=replace(small_scene.settings, threads=2)),
                     particles=20_000)
    assert np.array_equal(one.flux_w, two.flux_w)
    assert np.array_equal(one.hits, two.hits)
    assert one.stats["flux_absorbed_w"] == two.stats["flux_absorbed_w"]
    other = bake_light(replace(small_scene, settings=replace(small_scene.settings, seed=7)),
                       particles=20_000)
    assert not np.array_equal(one.flux_w, other.flux_w)


def test_colour_convention_power_is_the_mean_over_channels():
    assert channel_flux_w(30.0, np.array([1.0, 0.5, 0.0])) == pytest.approx([60.0, 30.0, 0.0])
    assert channel_flux_w(30.0, np.zeros(3)) == pytest.approx([0, 0, 0])


def test_surface_light_arrays_and_radiance(core):
    scene = furnace_scene(power_w=12.0)
    arrays = light_arrays(scene)
    area = 6 * 4.0
    # Every scene triangle emits Φ / (π A) on its inner side, the same as its emitter entry.
    assert arrays["emitted_radiance"] == pytest.approx(np.full((12, 3), 12.0 / (np.pi * area)))
    assert arrays["emitter_radiance"] == pytest.approx(np.full((12, 3), 12.0 / (np.pi * area)))
    assert arrays["emitter_flux"].sum(axis=0) == pytest.approx([12.0] * 3)


def test_auto_particles_aims_at_hits_per_patch(small_scene):
    opts = LightOptions(hits_per_patch=50)
    n, why = auto_particles(small_scene, opts, light_arrays(small_scene))
    assert f"{n:,} particles" in why and "50 hits" in why
    field = bake_light(small_scene, opts, particles=n)
    # The pilot measures hits per particle, so the mean is close to what was asked (±10%:
    # the pilot's own noise with 4096 particles is about 1%, the rest is rounding of n).
    assert field.hits.mean() == pytest.approx(50, rel=0.1)


def test_bad_options_are_clear_errors(small_scene):
    with pytest.raises(SonoluxError, match="particles"):
        bake_light(small_scene, particles=0)
    with pytest.raises(SonoluxError, match="patch_size_m"):
        bake_light(small_scene, patch_size_m=-1.0)
    no_lights = replace(small_scene, lights=[])
    with pytest.raises(SonoluxError, match="no light"):
        bake_light(no_lights)


def test_mean_irradiance_per_surface_and_material(small_light):
    by_surface = small_light.mean_irradiance_w_m2("surface")
    assert set(by_surface) == {"floor", "ceiling", "west", "east", "south", "north"}
    # The strip faces down: the floor under it is lit most, the ceiling behind it least.
    assert by_surface["floor"][0] > by_surface["south"][0] > by_surface["ceiling"][0]
    by_material = small_light.mean_irradiance_w_m2("material")
    assert by_material["paper-floor"] == pytest.approx(by_surface["floor"])
    with pytest.raises(SonoluxError, match="surface or material"):
        small_light.mean_irradiance_w_m2("colour")
