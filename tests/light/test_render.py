"""Pictures: the paper's view of paper-small, the furnace, a mirror, and camera errors."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.light.bake import bake_light
from sonolux.light.camera import Camera, default_camera
from sonolux.light.image import auto_exposure, luminance, to_srgb8
from sonolux.light.render import Renderable, coverage, incident_exposure, render

from .conftest import furnace_scene


@pytest.fixture(scope="module")
def small_view(small_light):
    r = Renderable.of(small_light)
    camera = default_camera(small_light.vertices_m.min(0), small_light.vertices_m.max(0),
                            width=240, height=135)
    return r, camera, render(r, camera)


def test_paper_view_is_lit_and_the_strip_light_is_brightest(small_view):
    r, camera, img = small_view
    y = luminance(img.astype(np.float64))
    assert img.shape == (135, 240, 3) and np.all(np.isfinite(img))
    share = coverage(r, camera)
    assert share["nothing"] == 0.0 and 0.002 < share["light"] < 0.05
    # The strip light: pixels that see it show its radiance Φ / (π A) = 60 / (π · 0.36).
    le = 60.0 / (np.pi * 3 * 0.12)
    assert y.max() == pytest.approx(le, rel=1e-6)
    brightest = np.unravel_index(np.argmax(y), y.shape)
    assert brightest[0] < 135 // 2  # on the ceiling, in the upper half
    # Everything else is surfaces lit by it: walls brighter than the 30% floor.
    assert np.median(y[:20]) > 0.1 and np.median(y[-10:, 100:140]) < np.median(y[60:80, :20])
    png = to_srgb8(img, auto_exposure(img))
    assert png.std() > 10  # not blank


def test_render_is_deterministic(small_view):
    r, camera, img = small_view
    assert np.array_equal(render(r, camera), img)


def test_furnace_renders_flat_at_le_over_one_minus_rho(core):
    rho = np.array([0.5, 0.6, 0.7])
    field = bake_light(furnace_scene(rho=tuple(rho)), particles=200_000)
    img = render(field, Camera((1.0, 1.0, 1.0), yaw_deg=30, pitch_deg=10, width=64, height=48))
    expected = 12.0 / (np.pi * 24.0) / (1 - rho)
    # Smoothing averages several patches, so each pixel is within a few % of the truth (noise
    # 1/sqrt(~1000 hits) per patch); the picture's mean within 1% (as in the furnace test).
    assert img.reshape(-1, 3).mean(axis=0) == pytest.approx(expected, rel=0.01)
    assert np.all(np.abs(img / expected - 1) < 0.1)
    # The incident meter reads E / π = the incident radiance, Le / (1 − ρ) here: a white
    # surface under it is exposed to 0.6 (same noise as the mean: 1%).
    camera = Camera((1.0, 1.0, 1.0), yaw_deg=30, pitch_deg=10, width=64, height=48)
    assert incident_exposure(field, camera) == pytest.approx(0.6 / luminance(expected), rel=0.01)


def test_a_mirror_floor_shows_the_light(core):
    scene = sonolux.load_scene({
        "materials": {"mirror": {"absorption": 0.1, "diffuse_rgb": [0.9, 0.9, 0.9], "specular": 1.0,
                                 "roughness": 0.0},
                      "white": {"absorption": 0.1, "diffuse_rgb": [0.8, 0.8, 0.8]}},
        "geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                      "materials": {"default": "white", "floor": "mirror"}}],
        "lights": [{"center_m": [2, 2, 2.99], "size_m": [1.0, 0.2], "power_w": 10}],
    })
    field = bake_light(scene, particles=20_000)
    img = render(field, Camera((2.0, 2.0, 1.5), look_at_m=(2.0, 2.0, 0.0), width=31, height=31),
                 samples=1)
    le = 10.0 / (np.pi * 0.2)
    # Straight down at the mirror: the light's image, ρ × Le (ρ = 0.9, all of it specular).
    assert img[15, 15] == pytest.approx(0.9 * le, rel=1e-9)


def test_the_glossy_lobe_is_phongs():
    # Phong's lobe cos^n θ about the mirror direction has E[cos θ] = (n + 1) / (n + 2): drawn
    # 200 000 times (standard error of the mean below 1e-4), about a mirror direction tilted so
    # that no draw falls below the surface.
    from sonolux.light.render import _uniforms, glossy_directions

    k = 200_000
    mirror = np.tile([np.sin(0.2), 0.0, np.cos(0.2)], (k, 1))
    normal = np.tile([0.0, 0.0, 1.0], (k, 1))
    for roughness in (0.1, 0.3):
        n = 2 / roughness**2 - 2
        d = glossy_directions(mirror, normal, np.full(k, roughness),
                              *_uniforms(np.arange(k, dtype=np.uint64), 0))
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
        cos = d @ mirror[0]
        assert cos.mean() == pytest.approx((n + 1) / (n + 2), abs=5e-4)
        assert np.allclose(d[:, :2].mean(axis=0), mirror[0, :2] * cos.mean(), atol=3e-3)
    assert np.array_equal(glossy_directions(mirror[:3], normal[:3], np.zeros(3),
                                            np.full(3, 0.5), np.full(3, 0.5)), mirror[:3])


def test_a_glossy_floor_shows_the_light_spread_by_its_lobe(core):
    # Black walls, an all-specular floor of roughness 0.3 (n = 20.2), the light 2.99 m above.
    # Looking straight down from 1.5 m, a ray reflects at the floor into the lobe about the
    # vertical; it sees ρ Le with the probability P that the lobe sends it into the light,
    # P = ∫ (n + 1) / (2π) cos^n θ dω over the light, integrated here on a fine grid (P = 0.068).
    # 400 000 rays with their own draws: relative standard error 0.6%, so within 3% (measured
    # -1.2% with 100 000 rays).
    from sonolux.light.render import Renderable, shade

    scene = sonolux.load_scene({
        "materials": {"gloss": {"absorption": 0.1, "diffuse_rgb": [0.9, 0.9, 0.9], "specular": 1.0,
                                "roughness": 0.3},
                      "black": {"absorption": 1.0, "diffuse_rgb": [0.0, 0.0, 0.0]}},
        "geometry": [{"type": "shoebox", "size_m": [4, 4, 3],
                      "materials": {"default": "black", "floor": "gloss"}}],
        "lights": [{"center_m": [2, 2, 2.99], "size_m": [1.0, 0.2], "power_w": 10}],
    })
    r = Renderable.of(bake_light(scene, particles=20_000))
    k = 400_000
    got = shade(r, np.tile([2.0, 2.0, 1.5], (k, 1)), np.tile([0.0, 0.0, -1.0], (k, 1)))
    le = 10.0 / (np.pi * 0.2)
    n = 2 / 0.3**2 - 2
    x, y = np.meshgrid(np.linspace(1.5, 2.5, 801), np.linspace(1.9, 2.1, 161))
    dist2 = (x - 2) ** 2 + (y - 2) ** 2 + 2.99**2
    cos = 2.99 / np.sqrt(dist2)
    p_light = np.trapezoid(np.trapezoid((n + 1) / (2 * np.pi) * cos**n * cos / dist2,
                                        x[0], axis=1), y[:, 0])
    assert got[:, 0].mean() == pytest.approx(0.9 * le * p_light, rel=0.03)
    assert 0.05 < p_light < 0.6  # the test sees a spread lobe, neither a mirror nor nothing


@pytest.mark.parametrize(("change", "field"), [
    ({"fov_deg": 0.0}, "fov_deg"), ({"fov_deg": 180.0}, "fov_deg"), ({"fov_deg": -10.0}, "fov_deg"),
    ({"width": 0}, "width"), ({"height": 100_000}, "height"), ({"pitch_deg": 90.0}, "pitch_deg"),
    ({"look_at_m": (0.3, 1.25, 1.5)}, "look_at_m"),
    ({"position_m": (-1.0, 1.0, 1.0)}, "outside the room"),
    ({"position_m": (3.0, 1.0, float("nan"))}, "position_m"),
])
def test_bad_cameras_are_clear_errors(small_view, change, field):
    r, _, _ = small_view
    base = {"position_m": (0.3, 1.25, 1.5), "width": 8, "height": 8}
    with pytest.raises(SonoluxError, match=field) as err:
        render(r, Camera(**{**base, **change}))
    assert "not allowed" in str(err.value)
