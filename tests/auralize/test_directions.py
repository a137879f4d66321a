"""A single arrival from the listener's right is on the right; turned towards it, in front.
Stereo, binaural (spherical head and a SOFA file), ambisonics and the cube."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.auralize import ambisonics
from sonolux.auralize.binaural import SofaHRTF, SphericalHead
from sonolux.auralize.layouts import unit_vectors
from sonolux.auralize.offline import AuralizeSettings, auralize
from sonolux.errors import SonoluxError

from .conftest import FS


def levels_db(y):
    e = np.sum(y.astype(float) ** 2, axis=0)
    return 10 * np.log10(np.maximum(e / e.max(), 1e-30))


def render(field, layout, heading, **kw):
    x = np.random.default_rng(0).standard_normal(4800)
    y, _ = auralize(field, x, (0.5, 0.5), heading, AuralizeSettings(layout=layout, **kw))
    return y


@pytest.mark.parametrize("layout", ["stereo", "binaural"])
def test_an_arrival_from_the_right_is_louder_on_the_right_then_in_front(one_arrival, layout):
    field = one_arrival("right")
    facing_x = levels_db(render(field, layout, 0.0))
    assert facing_x[1] == 0.0 and facing_x[0] < -10.0  # right channel louder by > 10 dB
    turned = levels_db(render(field, layout, -90.0))  # turned 90° to the right, towards it
    assert abs(turned[0] - turned[1]) < 0.01  # balanced: the model and panning are symmetric
    left = levels_db(render(one_arrival("left"), layout, 0.0))
    assert left[0] == 0.0 and left[1] < -10.0


def test_spherical_head_delays_the_far_ear_by_woodworth():
    head = SphericalHead(FS)
    left, right = head.hrirs(unit_vectors(-90.0))[0]
    lag = np.argmax(np.correlate(np.r_[left, np.zeros(64)], right, "full")) - (right.size - 1)
    woodworth = 0.0875 / 343 * (1 + np.pi / 2) * FS  # 31.5 samples
    assert abs(lag - woodworth) <= 1


def write_sofa(path, rate=44100):
    import sofar

    head = SphericalHead(rate)
    az = np.arange(0, 360, 5.0)
    sofa = sofar.Sofa("SimpleFreeFieldHRIR")
    sofa.Data_IR = head.hrirs(unit_vectors(az))
    sofa.SourcePosition = np.column_stack([az, np.zeros_like(az), np.full_like(az, 1.5)])
    sofa.Data_SamplingRate = rate
    sofar.write_sofa(str(path), sofa)
    return path


def test_a_sofa_file_gives_the_same_sides(one_arrival, tmp_path):
    sofa = write_sofa(tmp_path / "head.sofa")  # at 44.1 kHz: resampled to the field's 48 kHz
    hrtf = SofaHRTF(sofa, FS)
    assert hrtf.sample_rate_hz == FS and hrtf.data.shape[0] == 72
    field = one_arrival("right")
    facing_x = levels_db(render(field, "binaural", 0.0, hrtf=str(sofa)))
    assert facing_x[1] == 0.0 and facing_x[0] < -10.0
    turned = levels_db(render(field, "binaural", -90.0, hrtf=str(sofa)))
    assert abs(turned[0] - turned[1]) < 0.1


def test_bad_sofa_files_are_named(tmp_path):
    with pytest.raises(SonoluxError, match="nothing.sofa: no such SOFA file"):
        SofaHRTF(tmp_path / "nothing.sofa", FS)
    bad = tmp_path / "bad.sofa"
    bad.write_bytes(b"not a sofa file")
    with pytest.raises(SonoluxError, match="bad.sofa: not a SOFA file"):
        SofaHRTF(bad, FS)


@pytest.mark.parametrize("order", [1, 3])
def test_ambisonics_puts_the_arrival_where_it_came_from(one_arrival, order):
    # Facing +x, an arrival from the left (+y) has its intensity along +y; turned 90° to the
    # left, it is straight ahead (+x). Angles to 1e-6 rad: the encoding is exact.
    field = one_arrival("left")
    for heading, expect in ((0.0, [0, 1, 0]), (90.0, [1, 0, 0]), (180.0, [0, -1, 0])):
        y = render(field, "ambisonics", heading, order=order)
        assert y.shape[1] == (order + 1) ** 2
        assert np.allclose(ambisonics.intensity_direction(y.T), expect, atol=1e-6)


@pytest.mark.parametrize("order", [1, 3])
def test_an_encoded_direction_decodes_back_to_it(order):
    # Encode 20 random directions; decode to 2000 directions (mode matching); the loudest
    # is within the grid's spacing (~4.6°) of the source: the encoding is right in all channels.
    rng = np.random.default_rng(7)
    grid = ambisonics.fibonacci_sphere(2000)
    dec = ambisonics.decoder(grid, order)
    for v in rng.standard_normal((20, 3)):
        v /= np.linalg.norm(v)
        b = ambisonics.sn3d_gains(v[None], order)[:, 0]
        best = grid[np.argmax((dec @ b) ** 2)]
        assert np.degrees(np.arccos(np.clip(best @ v, -1, 1))) < 5.0
        assert np.allclose(ambisonics.intensity_direction(b[:, None] * np.ones((1, 4))), v)


def test_sn3d_first_order_values():
    g = ambisonics.sn3d_gains(unit_vectors(30.0, 20.0), 1)[:, 0]
    az, el = np.radians(30), np.radians(20)
    assert np.allclose(g, [1, np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])
    assert ambisonics.channel_names(1) == ["W", "Y", "Z", "X"]
    with pytest.raises(SonoluxError, match="ambisonic order 0"):
        ambisonics.sn3d_gains(unit_vectors(0.0), 0)


def test_elevation_bands_reach_the_cube_upper_layer(one_arrival):
    field = one_arrival("front@above", n_elevation=3)
    e = np.sum(render(field, "cube8", 0.0).astype(float) ** 2, axis=0)
    assert e[4:].sum() > 10 * e[:4].sum()  # the upper layer carries it


def test_cached_hrir_spectra_equal_the_hrirs_spectra(one_arrival):
    """The per-ear (spherical head) and per-direction (other HRTFs) caches of HRIR spectra
    give the spectra of hrirs() for every heading of a turn, to float32 rounding."""
    from scipy import fft as sfft

    from sonolux.auralize.render import BinauralSpatializer, field_directions, head_frame

    field = one_arrival("right")
    world = field_directions(field)
    head = SphericalHead(FS)

    class Plain:  # the same head without ear_angles: the per-direction cache
        taps, delay_samples, name = head.taps, head.delay_samples, "plain"
        hrirs = staticmethod(head.hrirs)

    for hrtf in (head, Plain()):
        sp = BinauralSpatializer(world, hrtf)
        for heading in np.arange(0.0, 400.0, 2.0):
            want = sfft.rfft(head.hrirs(head_frame(world, heading)).transpose(1, 0, 2), 512,
                             axis=-1)
            planar = sp._spectra(heading, 512)  # cached as [ear, direction, 2, bins]
            got = planar[:, :, 0] + 1j * planar[:, :, 1]
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * np.abs(want).max())
