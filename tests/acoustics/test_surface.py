"""Described surfaces (sonolux.acoustics.surface): the phase-grating wells' s(θ, f) and α(θ, f)
against closed forms and published numbers, the scene key, and a bake that uses them."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux.acoustics.bands import BandSet
from sonolux.acoustics.surface import (
    TABLE_COSINES,
    WellSurface,
    by_angle,
    conductance_from_random,
    paris_absorption,
    random_incidence,
    rays_table,
    reflections,
)
from sonolux.errors import SceneError

C = 343.0
OCTAVES = BandSet("octave", (125, 250, 500, 1000, 2000))


def test_lossless_wells_give_the_published_angle_dependence():
    """Depths uniform in [0, d_max] with k·d_max = 0.33, lossless (g = 0): s(θ) = 1 − |⟨R⟩|² at
    one frequency, the numbers session 9 computed for this model (docs/waves-walls.md, "Scattering on
    the waves' side"): 0.036 / 0.116 / 0.341 / 0.391 / 0.199 at 0 / 60 / 80 / 85 / 89°, and 0.098
    at random incidence. Tolerance 0.002: the quadrature of 4,000 depths and the rounding of the
    quoted numbers."""
    depths = (np.arange(4000) + 0.5) / 4000 * 0.33
    theta = np.radians([0, 60, 80, 85, 89])
    s = 1 - np.abs(reflections(depths, 0.0, 1.0, np.cos(theta)).mean(axis=-1)) ** 2
    assert np.allclose(s, [0.036, 0.116, 0.341, 0.391, 0.199], atol=0.002)
    th = (np.arange(7200) + 0.5) * np.pi / 2 / 7200
    s_all = 1 - np.abs(reflections(depths, 0.0, 1.0, np.cos(th)).mean(axis=-1)) ** 2
    w = np.sin(2 * th)
    assert abs((w * s_all).sum() / w.sum() - 0.0985) < 0.002
    # A lossless well reflects everything at every angle: |R| = 1.
    assert np.allclose(np.abs(reflections(depths[:50], 0.0, 1.0, np.cos(th[::100]))), 1.0)


def test_the_conductance_is_paris_and_a_flat_profile_keeps_the_coefficient():
    """g from α by Paris' formula (the core's admittance_from_random: 0.3 → 0.05059, session 9's
    number); a profile of negligible depth (1 µm) absorbs its flat face's coefficient at random
    incidence (1e-4: the quadrature in θ) and scatters nothing (1e-6)."""
    g = conductance_from_random(np.array([0.05, 0.3, 0.0]))
    assert abs(g[1] - 0.05059) < 5e-5 and g[2] == 0.0
    assert np.allclose(paris_absorption(g), [0.05, 0.3, 0.0], atol=1e-9)
    flat = WellSurface((1e-6,), 0.5)
    a, s = random_incidence(flat, np.full(5, 0.3), OCTAVES, C)
    assert np.allclose(a, 0.3, atol=1e-4) and np.all(s < 1e-6)
    with pytest.raises(ValueError, match="locally reacting"):
        conductance_from_random(np.array([0.97]))


def test_the_rays_table_holds_the_model_at_its_nodes_and_its_mean_is_random_incidence():
    """The table's nodes are the model's α and s at cos θ = i/128 (exact); for lossless wells,
    where s is an energy ratio over a constant total, the table's diffuse-field mean
    ∫ s(c) 2c dc (trapezoids) is the random-incidence s within 0.002 (the nodes' spacing
    against the peak a few degrees from grazing)."""
    surface = WellSurface(tuple((np.arange(8) + 0.5) / 8 * 0.05), 0.4)
    table = rays_table(surface, np.zeros(5), OCTAVES, C)
    assert table.shape == (2, TABLE_COSINES, 5)
    c = np.linspace(0, 1, TABLE_COSINES)
    a, s = by_angle(surface, np.zeros(5), OCTAVES, c[[7, 64]], C)
    assert np.array_equal(table[1, [7, 64]], s) and np.array_equal(table[0, [7, 64]], a)
    mean = np.trapezoid(table[1] * 2 * c[:, None], c, axis=0)
    assert np.allclose(mean, random_incidence(surface, np.zeros(5), OCTAVES, C)[1], atol=0.002)
    # Scattering grows with frequency for wells far shallower than the wavelength.
    assert np.all(np.diff(random_incidence(surface, np.zeros(5), OCTAVES, C)[1]) > 0)


def _scene(surface: str, scattering: str = "") -> dict:
    return {
        "name": "profiled",
        "settings": {"bands_hz": [125, 250, 500, 1000]},
        "materials": {"floor": {"absorption": 0.3, **({"scattering": 0.2} if scattering else {}),
                                **({"surface": eval(surface)} if surface else {})},
                      "wall": {"absorption": 0.05, "scattering": 0.1}},
        "geometry": [{"type": "shoebox", "size_m": [5, 4, 3],
                      "materials": {"default": "wall", "floor": "floor"}}],
        "sources": [{"position_m": [1.5, 1.5, 1.5]}],
        "receivers": {"type": "grid", "height_m": 1.4, "spacing_m": 2.0, "radius_m": 0.3},
    }


@pytest.mark.parametrize("surface, match", [
    ("{'depths_m': [-0.1], 'patch_m': 0.5}", "depths_m"),
    ("{'depths_m': [0.0], 'patch_m': 0.5}", "depths_m"),
    ("{'depths_m': 'deep', 'patch_m': 0.5}", "depths_m"),
    ("{'depths_m': [0.1]}", "patch_m"),
    ("{'depths_m': [0.1], 'patch_m': 0}", "patch_m"),
    ("{'depths_m': [0.1], 'patch_m': 0.5, 'width_m': 1}", "width_m"),
])
def test_a_bad_surface_names_the_key(surface, match):
    with pytest.raises(SceneError, match=match):
        sonolux.load_scene(_scene(surface))


def test_a_surface_on_a_face_absorbing_more_than_a_locally_reacting_wall_can_is_refused():
    data = _scene("{'depths_m': [0.1], 'patch_m': 0.5}")
    data["materials"]["floor"]["absorption"] = 0.97
    with pytest.raises(SceneError, match="surface.*0.951"):
        sonolux.load_scene(data)


def test_a_surface_and_a_scattering_coefficient_are_refused_together():
    with pytest.raises(SceneError, match="not both"):
        sonolux.load_scene(_scene("{'depths_m': [0.1], 'patch_m': 0.5}", scattering="yes"))


@pytest.mark.usefixtures("core")
def test_a_profiled_floor_is_baked_with_its_angle_dependence():
    """The scene's scattering is the profile's random-incidence s; the bake takes the table (its
    result differs from a bake with that s at every angle), and the same seed gives the same
    bits on 1 and 2 threads."""
    from sonolux.sound.bake import bake

    profile = "{'depths_m': [0.0, 0.03, 0.06, 0.09], 'patch_m': 0.5}"
    scene = sonolux.load_scene(_scene(profile))
    floor = next(m for m in scene.materials if m.name == "floor")
    s = floor.scattering_in(scene.settings.band_set, scene.settings.speed_of_sound_m_s)
    assert np.all(np.diff(s) > 0) and 0 < s[0] < s[-1] < 1
    runs = {}
    for threads in (1, 2):
        data = _scene(profile)
        data["settings"]["threads"] = threads
        runs[threads] = bake(sonolux.load_scene(data), rays=3000)
    assert np.array_equal(np.asarray(runs[1].energy), np.asarray(runs[2].energy))
    data = _scene("")
    data["materials"]["floor"].update(scattering=[float(v) for v in s],
                                      bands_hz=[125, 250, 500, 1000])
    plain = bake(sonolux.load_scene(data), rays=3000)
    assert not np.array_equal(np.asarray(runs[1].energy), np.asarray(plain.energy))
