"""Figures: the data behind them (binning, plan sections, grid images and their orientation),
and that each plot writes a PNG."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.analysis.params import room_parameters
from sonolux.plotting.maps import grid_image, plan_section, plot_parameter_maps
from sonolux.plotting.responses import (
    azimuth_echograms,
    per_millisecond,
    plot_azimuth_echograms,
    plot_decay_curves,
)
from tests.analysis.fields import decaying_grid, synthetic_field
from tests.analysis.test_decay import decay_histogram, nonuniform_axis

PNG = b"\x89PNG\r\n\x1a\n"


def box(size):
    """A shoebox [0, L] × [0, W] × [0, H]: (vertices float[8, 3], triangles int[12, 3])."""
    L, W, H = size
    v = np.array([[x, y, z] for z in (0, H) for y in (0, W) for x in (0, L)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return v, np.array(tris)


def test_per_millisecond_keeps_every_joule():
    start, width = nonuniform_axis(0.3)
    e = np.random.default_rng(1).random((2, start.size))
    ms = per_millisecond(e, start)
    assert ms.shape == (2, 300)
    np.testing.assert_allclose(ms.sum(axis=-1), e.sum(axis=-1), rtol=1e-12)
    np.testing.assert_allclose(ms[:, 0], e[:, :48].sum(axis=-1), rtol=1e-12)  # 48 samples


def test_echograms_per_azimuth_sum_the_elevations():
    field, start, _ = decaying_grid((0.8,), duration_s=1.0)
    field.energy[0, 6] *= 3  # more from the right
    echo = azimuth_echograms(field, 0)
    assert echo.shape == (8, 1000)
    assert echo[6].sum() == pytest.approx(3 * echo[0].sum(), rel=1e-5)
    # Bands carry the full energy each: the mean over bands, not the sum.
    assert echo.sum() == pytest.approx(field.energy[0].sum(dtype=np.float64) / 2, rel=1e-6)


def test_plan_section_of_a_shoebox_is_its_outline():
    v, t = box((6.0, 2.5, 2.0))
    seg = plan_section(v, t, 1.5)
    assert seg.shape[1:] == (2, 2) and 4 <= seg.shape[0] <= 8
    xy = seg.reshape(-1, 2)
    on_wall = (np.isclose(xy[:, 0], 0) | np.isclose(xy[:, 0], 6) | np.isclose(xy[:, 1], 0)
               | np.isclose(xy[:, 1], 2.5))
    assert on_wall.all()
    np.testing.assert_allclose([xy.min(axis=0), xy.max(axis=0)], [[0, 0], [6, 2.5]], atol=1e-9)
    # Total length: the perimeter.
    assert np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1).sum() == pytest.approx(17.0)
    assert plan_section(v, t, 3.0).shape == (0, 2, 2)  # above the room


def grid_field(nx=4, ny=3):
    """A grid every 1 m at x = 1..nx, y = 0.5..; receiver (i, j) decays with 0.5 + 0.2 i s."""
    start, width = nonuniform_axis(2.0)
    idx = [(i, j) for j in range(ny) for i in range(nx)]
    e = np.stack([decay_histogram(start, width, [(1.0, 0.5 + 0.2 * i)]) for i, _ in idx])
    energy = np.broadcast_to(e[:, None, None, :] / 8, (len(idx), 8, 1, e.shape[-1]))
    positions = [(1.0 + i, 0.5 + j, 1.5) for i, j in idx]
    return synthetic_field(energy, start, width, positions, source_m=(2.0, 1.5, 1.5),
                           grid_index=idx, spacing_m=1.0, bands_hz=(1000.0,))


def test_grid_image_puts_x_along_columns_and_y_up():
    field = grid_field()
    rcv = np.arange(field.n_receivers)
    img, extent = grid_image(field, rcv, field.positions_m[:, 0] + 10 * field.positions_m[:, 1])
    assert img.shape == (3, 4)  # rows: y, columns: x
    assert extent == pytest.approx((0.5, 4.5, 0.0, 3.0))
    # imshow(origin="lower"): row 0 is the lowest y, column 0 the lowest x.
    assert img[0, 0] == pytest.approx(1 + 5) and img[0, 3] == pytest.approx(4 + 5)
    assert img[2, 0] == pytest.approx(1 + 25)
    # A receiver missing from the grid leaves a hole, not a shift.
    img, _ = grid_image(field, rcv[1:], np.ones(rcv.size - 1))
    assert np.isnan(img[0, 0]) and np.isfinite(img[0, 1])


def test_every_plot_writes_a_png(tmp_path):
    field = grid_field()
    p = room_parameters(field, theory=False)
    v, t = box((5.0, 3.0, 2.5))
    paths = [plot_azimuth_echograms(field, 5, tmp_path / "echo.png"),
             plot_decay_curves(field, 5, tmp_path / "edc.png"),
             plot_parameter_maps(field, p, tmp_path / "maps.png", outline=plan_section(v, t, 1.5),
                                 mark_m=(2.0, 1.5)),
             plot_parameter_maps(field, p, tmp_path / "one.png", names=("jlf",))]
    for path in paths:
        assert path.read_bytes()[:8] == PNG, path
