"""Third-octave bakes against physics: Eyring per third with that third's air, and octaves
summed from thirds against a direct octave bake (docs/bands.md). Tolerances stated per test."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux.acoustics.theory import eyring_t60
from sonolux.analysis.decay import decay_times
from sonolux.analysis.octaves import octave_field
from sonolux.scene.summary import band_air_attenuation_per_m
from sonolux.sound.bake import bake

pytestmark = pytest.mark.usefixtures("core")

SIZE = (6.0, 5.0, 4.0)
RECEIVERS = [(2.0, 2.0, 1.5), (4.5, 3.5, 2.5)]


def box(bands: dict, absorption, scattering: float = 1.0, seed: int = 3):
    return sonolux.load_scene({
        "name": "bands-box", "settings": {**bands, "seed": seed},
        "materials": {"wall": {"absorption": absorption, "scattering": scattering}},
        "geometry": [{"type": "shoebox", "size_m": list(SIZE), "materials": {"default": "wall"}}],
        "sources": [{"position_m": [1.7, 1.3, 1.4]}],
        "receivers": {"type": "points", "positions_m": [list(r) for r in RECEIVERS],
                      "radius_m": 0.5},
    })


def test_diffuse_shoebox_in_thirds_decays_as_eyring_with_each_thirds_air():
    # Fully diffuse walls absorbing 0.1 in every band, air at 20 °C and 50 % RH: each third
    # differs only by its air, from m = 1.0e-4/m at 125 Hz to 3.7e-2/m at 10 kHz (where the
    # air absorbs 0.7 times what the walls do). T30 of every third within 3 % of Eyring with
    # that third's air (ISO 9613-1 at its exact mid-band frequency), as issue 16 asks; Eyring
    # leaves out the free-path variance γ² (Kuttruff eq. 5.50: +2 % on the walls' share at
    # α = 0.1, less where the air takes a share), so the traced times are also checked within
    # 1.5 % of Kuttruff's form with air, which has it. 20 000 rain rays through 0.5 m spheres:
    # the T30 noise is about 0.5 % (the fast test of test_physics.py at one band).
    scene = box({"bands": "third-octave", "band_range_hz": [125, 10000]}, 0.1)
    field = bake(scene, rays=20_000, estimator="rain")
    v = float(np.prod(SIZE))
    s = 2 * (SIZE[0] * SIZE[1] + SIZE[1] * SIZE[2] + SIZE[2] * SIZE[0])
    c = scene.settings.speed_of_sound_m_s
    m = band_air_attenuation_per_m(scene.settings.band_set, scene.settings.air)
    eyring = eyring_t60(v, s, 0.1, m, c)
    gamma2 = field.stats["free_path_relative_variance"]
    walls = -s * np.log(0.9) * (1 + gamma2 / 2 * np.log(0.9))
    kuttruff = 24 * np.log(10) * v / (c * (walls + 4 * m * v))
    assert eyring[-1] < 0.6 * eyring[0]  # the air matters at the top: a test of it
    for k in range(len(RECEIVERS)):
        t30 = decay_times(field.omni_energy(k), field.bin_start_s, field.bin_width_s)["t30_s"]
        np.testing.assert_allclose(t30, eyring, rtol=0.03, err_msg=f"receiver {k}")
        np.testing.assert_allclose(t30, kuttruff, rtol=0.015, err_msg=f"receiver {k}")


@pytest.mark.slow
def test_octaves_summed_from_thirds_equal_a_direct_octave_bake_within_its_noise():
    # The same room baked in octaves (125 Hz … 8 kHz) and in thirds (100 Hz … 10 kHz), four
    # independent seeds each. Absorption changes from octave to octave and each third holds
    # its octave's value (docs/bands.md), so the thirds of an octave differ only by their air.
    # Air attenuation depends on the path length alone, ct, so in expectation a third's
    # histogram is the octave's times exp(-(m_i - m_c) c t) (m_c: the octave's own, at its
    # exact mid-band frequency, which is the centre third's): the octave summed from thirds
    # must equal the direct octave bake times Σ_i exp(-(m_i - m_c) c t). That holds bin by
    # bin, for any room, without a diffuse-field model. Below 2 kHz the factor is 3 within
    # 1 % over the decay; at 8 kHz it bends the decay by several per cent (the band-averaged
    # air a single centre frequency misses). Tolerance: 4 standard errors of the difference
    # of the two four-seed means (seed-to-seed spread), plus 0.5 % for the bias of a T30 fit
    # through a noisy curve.
    alpha = [0.05, 0.08, 0.12, 0.18, 0.25, 0.3, 0.35, 0.4]
    octaves = {"bands_hz": [125, 250, 500, 1000, 2000, 4000, 8000]}
    thirds = {"bands": "third-octave", "band_range_hz": [100, 10000]}
    seeds = (11, 12, 13, 14)
    direct, summed = [], []
    for seed in seeds:
        o = bake(box(octaves, alpha, 0.7, seed), rays=20_000, estimator="rain")
        t = bake(box(thirds, alpha, 0.7, seed + 100), rays=20_000, estimator="rain")
        summed_field = octave_field(t)
        assert list(summed_field.bands_hz) == octaves["bands_hz"]
        m_t = np.asarray(t.settings["air_attenuation_per_m"]).reshape(-1, 3)
        c = o.settings["speed_of_sound_m_s"]
        mid = o.bin_start_s + 0.5 * o.bin_width_s
        factor = np.exp(-(m_t[:, :, None] - m_t[:, 1:2, None]) * c * mid).sum(axis=1)
        for k in range(len(RECEIVERS)):
            e_o = o.omni_energy(k) * factor
            e_t = summed_field.omni_energy(k)
            direct.append([decay_times(e_o, o.bin_start_s, o.bin_width_s)[n] for n in
                           ("t30_s", "edt_s")])
            summed.append([decay_times(e_t, t.bin_start_s, t.bin_width_s)[n] for n in
                           ("t30_s", "edt_s")])
    direct_a = np.asarray(direct).reshape(len(seeds), len(RECEIVERS), 2, -1)
    summed_a = np.asarray(summed).reshape(len(seeds), len(RECEIVERS), 2, -1)
    diff = summed_a.mean(axis=0) - direct_a.mean(axis=0)
    error = np.sqrt(direct_a.var(axis=0, ddof=1) / len(seeds)
                    + summed_a.var(axis=0, ddof=1) / len(seeds))
    allowed = 4 * error + 0.005 * direct_a.mean(axis=0)
    assert np.all(np.abs(diff) <= allowed), (diff, allowed)
