"""Exposure, tone maps and the image files."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.errors import SonoluxError
from sonolux.light import image


def test_auto_exposure_puts_the_log_average_at_the_key():
    flat = np.full((4, 5, 3), 2.5)
    assert image.auto_exposure(flat) == pytest.approx(0.18 / 2.5, rel=1e-5)  # δ = 1e-6 only
    # The log average, not the mean: one bright pixel barely moves it.
    spot = flat.copy()
    spot[0, 0] = 1000.0
    assert image.auto_exposure(spot) == pytest.approx(0.18 / 2.5 / (400 ** (1 / 20)), rel=1e-4)


@pytest.mark.parametrize("curve", image.TONE_MAPS)
def test_tone_maps_are_monotonic_from_black_to_white(curve):
    x = np.linspace(0, 50, 2001)
    y = image.tone_map(x, curve)
    assert y[0] == pytest.approx(0, abs=1e-12) and np.all(np.diff(y) >= 0) and y[-1] > 0.95
    assert np.all((0 <= y) & (y <= 1))
    with pytest.raises(SonoluxError, match="aces or reinhard"):
        image.tone_map(x, "filmic")


def test_srgb_curve_end_points_and_sample_resolve():
    assert image.srgb_encode(np.array([0.0, 0.0031308, 1.0])) == pytest.approx([0, 0.04045, 1], abs=1e-5)
    # A pixel a quarter covered by a light 100× brighter than the wall: tone-mapping the rays
    # first keeps it between wall and light, instead of white.
    rays = np.array([[[[100.0] * 3, [1.0] * 3, [1.0] * 3, [1.0] * 3]]])
    resolved = image.to_srgb8(rays, 0.18, samples_axis=2)[0, 0, 0]
    assert image.to_srgb8(np.ones((1, 1, 3)), 0.18)[0, 0, 0] < resolved < 255
    assert image.to_srgb8(rays.mean(axis=2), 0.18)[0, 0, 0] > resolved


def test_hdr_files_round_trip(tmp_path):
    rgb = np.random.default_rng(1).random((7, 9, 3)).astype(np.float32) * 50
    assert np.array_equal(image.read_pfm(image.write_hdr(tmp_path / "a.pfm", rgb)), rgb)
    openexr = pytest.importorskip("OpenEXR")
    path = image.write_hdr(tmp_path / "a.exr", rgb)
    with openexr.File(str(path)) as f:
        assert np.array_equal(f.channels()["RGB"].pixels, rgb)
    with pytest.raises(SonoluxError, match=r"\.pfm or \.exr"):
        image.write_hdr(tmp_path / "a.hdr", rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "a.pfm"]
