"""Panning: unit energy everywhere, the right speakers, the documented channel orders."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.auralize.ambisonics import fibonacci_sphere
from sonolux.auralize.layouts import LAYOUTS, loudspeaker_layout, unit_vectors
from sonolux.errors import SonoluxError


def test_cube_vbap_preserves_energy_in_every_direction():
    # 5000 directions over the sphere: Σ g² = 1 to rounding (1e-12), gains ≥ 0, at most the 4
    # corners of one face sound, and the energy vector Σ g² l points towards the source.
    cube = loudspeaker_layout("cube8")
    d = fibonacci_sphere(5000)
    g = cube.gains(d)
    assert np.allclose(np.sum(g**2, axis=0), 1.0, atol=1e-12)
    assert np.all(g >= 0) and np.all(np.sum(g > 1e-12, axis=0) <= 4)
    spk = unit_vectors(cube.speakers_deg[:, 0], cube.speakers_deg[:, 1])
    r_e = (g**2).T @ spk
    cos = np.sum(r_e * d, axis=1) / np.linalg.norm(r_e, axis=1)
    assert np.min(cos) > np.cos(np.radians(36))  # the worst case: a face's centre vs a corner


def test_cube_corners_and_level_sources():
    cube = loudspeaker_layout("cube8")
    spk = unit_vectors(cube.speakers_deg[:, 0], cube.speakers_deg[:, 1])
    assert np.allclose(cube.gains(spk), np.eye(8), atol=1e-12)  # a corner: that speaker alone
    # A level source feeds the upper and the lower layer alike; straight ahead, the 4 front ones.
    g = cube.gains(unit_vectors(np.arange(0, 360, 7.0)))
    assert np.allclose(g[:4], g[4:], atol=1e-12)
    front = cube.gains(unit_vectors(0.0))[:, 0]
    assert np.allclose(front, [0.5, 0, 0, 0.5, 0.5, 0, 0, 0.5])
    assert cube.channel_names == ("LFL", "LBL", "LBR", "LFR", "UFL", "UBL", "UBR", "UFR")


@pytest.mark.parametrize("name", ["stereo", "5.1", "7.1"])
def test_horizontal_layouts_preserve_energy_and_hit_their_speakers(name):
    lay = loudspeaker_layout(name)
    g = lay.gains(unit_vectors(np.linspace(-180, 180, 721)))
    assert np.allclose(np.sum(g**2, axis=0), 1.0, atol=1e-12) and np.all(g >= 0)
    for c, (az, _) in enumerate(lay.speakers_deg):
        if np.isnan(az):
            assert lay.channel_names[c] == "LFE" and not np.any(g[c])
            continue
        assert np.allclose(lay.gains(unit_vectors(az))[:, 0], np.eye(lay.n_channels)[c])


def test_channel_orders_are_the_documented_ones():
    assert LAYOUTS["5.1"].channel_names == ("L", "R", "C", "LFE", "Ls", "Rs")
    assert LAYOUTS["7.1"].channel_names == ("L", "R", "C", "LFE", "Lrs", "Rrs", "Lss", "Rss")
    assert list(LAYOUTS["7.1"].speakers_deg[[4, 6], 0]) == [135, 90]


def test_stereo_folds_the_back_to_the_front():
    st = loudspeaker_layout("stereo")
    assert np.allclose(st.gains(unit_vectors(150.0)), st.gains(unit_vectors(30.0)))
    right = st.gains(unit_vectors(-90.0))[:, 0]
    assert right[1] == 1.0 and right[0] == 0.0


def test_unknown_layout_names_close_matches():
    with pytest.raises(SonoluxError, match="did you mean 'cube8'"):
        loudspeaker_layout("cube")
