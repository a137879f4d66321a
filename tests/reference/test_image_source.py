"""The reference image-source model against hand-worked images, lattice counts and limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.reference.image_source import (
    WALLS,
    Shoebox,
    energy_histogram,
    image_sources,
    schroeder_db,
)

SIZE_M = (5.0, 4.0, 3.0)
SOURCE_M = np.array([1.0, 1.5, 1.2])
RECEIVER_M = np.array([3.5, 2.0, 1.7])
C_M_S = 343.0


def octahedral(n):
    """Number of points of Z³ with L1 norm <= n: the images of order <= n."""
    return (2 * n + 1) * (2 * n * n + 2 * n + 3) // 3


def test_first_order_images_by_hand():
    # Mirror the source in each wall: x -> -x (west), 2L - x (east), and so on. 1e-12 m:
    # the positions are sums of a few exact binary fractions.
    images = image_sources(Shoebox(SIZE_M), SOURCE_M, RECEIVER_M, max_order=1)
    x, y, z = SOURCE_M
    expected = {
        "floor": (x, y, -z), "ceiling": (x, y, 2 * 3.0 - z),
        "west": (-x, y, z), "east": (2 * 5.0 - x, y, z),
        "south": (x, -y, z), "north": (x, 2 * 4.0 - y, z),
    }
    assert len(images) == 7
    assert images.order[0] == 0
    np.testing.assert_allclose(images.position_m[0], SOURCE_M, atol=1e-12)
    for i in range(1, 7):
        (wall,) = [WALLS[w] for w in np.nonzero(images.reflections[i])[0]]
        assert images.reflections[i].sum() == 1
        np.testing.assert_allclose(images.position_m[i], expected[wall], atol=1e-12)
        d = np.linalg.norm(np.array(expected[wall]) - RECEIVER_M)
        assert images.distance_m[i] == pytest.approx(d, rel=1e-12)
        assert images.delay_s[i] == pytest.approx(d / C_M_S, rel=1e-12)


def test_second_order_images_by_hand():
    # Floor then ceiling: -z, then 2H - (-z) = 2H + z; ceiling then floor: z - 2H. Likewise
    # west/east gives 2L + x and x - 2L. Floor and west (either order): (-x, y, -z).
    images = image_sources(Shoebox(SIZE_M), SOURCE_M, RECEIVER_M, max_order=2)
    x, y, z = SOURCE_M

    def find(counts):
        return images.position_m[(images.reflections == counts).all(axis=1)]

    def same_set(got, expected):
        order = np.lexsort(np.transpose(got))
        want = np.array(expected)
        np.testing.assert_allclose(got[order], want[np.lexsort(want.T)], atol=1e-12)

    same_set(find([1, 1, 0, 0, 0, 0]), [(x, y, 6.0 + z), (x, y, z - 6.0)])
    same_set(find([0, 0, 1, 1, 0, 0]), [(10.0 + x, y, z), (x - 10.0, y, z)])
    same_set(find([1, 0, 1, 0, 0, 0]), [(-x, y, -z)])
    # No path of two reflections meets the same wall twice.
    assert images.reflections[images.order == 2].max() == 1


@pytest.mark.parametrize("n", range(8))
def test_image_count_is_the_octahedral_number(n):
    # The images are Z³ with the order as L1 norm: 4 k² + 2 of order k >= 1, and
    # (2n + 1)(2n² + 2n + 3) / 3 up to order n (1, 7, 25, 63, 129, 231, ...). Exact.
    images = image_sources(Shoebox(SIZE_M), SOURCE_M, RECEIVER_M, max_order=n)
    assert len(images) == octahedral(n)
    per_order = np.bincount(images.order, minlength=n + 1)
    assert per_order[0] == 1
    np.testing.assert_array_equal(per_order[1:], [4 * k * k + 2 for k in range(1, n + 1)])
    assert np.all(images.reflections.sum(axis=1) == images.order)
    # All images are distinct points.
    assert len(np.unique(np.round(images.position_m, 9), axis=0)) == len(images)


def test_order_and_direction_and_direct_sound():
    power_w = 0.02
    images = image_sources(Shoebox(SIZE_M), SOURCE_M, RECEIVER_M, max_order=6, power_w=power_w)
    assert np.all(np.diff(images.distance_m) >= 0)
    d = np.linalg.norm(SOURCE_M - RECEIVER_M)
    assert images.order[0] == 0 and images.distance_m[0] == pytest.approx(d, rel=1e-12)
    assert images.energy[0] == pytest.approx(power_w / (4 * math.pi * d * d), rel=1e-12)
    np.testing.assert_allclose(images.direction[0], (SOURCE_M - RECEIVER_M) / d, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(images.direction, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(RECEIVER_M + images.direction * images.distance_m[:, None],
                               images.position_m, atol=1e-9)
    # Rigid walls, no air: every image carries the free-field energy at its distance.
    np.testing.assert_allclose(images.energy, power_w / (4 * math.pi * images.distance_m**2),
                               rtol=1e-12)


def test_absorption_per_wall_and_band_and_air():
    # Two bands; each image's energy is W/(4πd²) Π(1-α)^count exp(-m d), checked for first-
    # and third-order images (1e-12: a few float products).
    alpha = {"floor": [0.1, 0.2], "ceiling": [0.3, 0.4], "west": [0.05, 0.5],
             "east": [0.0, 0.25], "south": [0.6, 0.7], "north": [1.0, 0.0]}
    m = np.array([0.001, 0.01])
    room = Shoebox(SIZE_M, absorption=alpha, air_m_per_m=m)
    images = image_sources(room, SOURCE_M, RECEIVER_M, max_order=3)
    assert images.energy.shape == (len(images), 2)
    a = np.array([alpha[w] for w in WALLS])

    def expected(i):
        d = images.distance_m[i]
        wall_factor = np.prod((1 - a) ** images.reflections[i][:, None], axis=0)
        return wall_factor * np.exp(-m * d) / (4 * math.pi * d * d)

    for counts in ([1, 0, 0, 0, 0, 0], [1, 1, 1, 0, 0, 0], [0, 0, 0, 0, 1, 2]):
        (found,) = np.nonzero((images.reflections == counts).all(axis=1))
        assert found.size > 0
        for i in found:
            np.testing.assert_allclose(images.energy[i], expected(i), rtol=1e-12)
    # The north wall absorbs everything in band 0: images that touch it carry nothing there.
    touched = images.reflections[:, WALLS.index("north")] > 0
    assert np.all(images.energy[touched, 0] == 0) and np.all(images.energy[touched, 1] > 0)


def test_max_time_selects_the_nearest_images_of_any_order():
    # Within 50 ms (17 m) every image has order <= 16 in this room, so order 25 holds them all.
    room = Shoebox(SIZE_M)
    by_time = image_sources(room, SOURCE_M, RECEIVER_M, max_time_s=0.05)
    by_order = image_sources(room, SOURCE_M, RECEIVER_M, max_order=25)
    near = by_order.delay_s <= 0.05
    assert by_time.delay_s.max() <= 0.05
    assert len(by_time) == near.sum()
    np.testing.assert_allclose(by_time.position_m, by_order.position_m[near], atol=1e-12)
    both = image_sources(room, SOURCE_M, RECEIVER_M, max_time_s=0.05, max_order=3)
    assert len(both) == ((by_order.delay_s <= 0.05) & (by_order.order <= 3)).sum()


def test_rigid_room_collects_w_c_t_over_v():
    # The images fill space with density 1/V, so the energy arriving by t tends to
    # ∫ W / (4π r²) · 4π r² dr / V = W c t / V. The lattice sum differs from the integral by an
    # edge term of relative size ~ room size / (c t) (2.5 % seen at 0.3 s, 0.7 % at 1 s):
    # 5 % at 0.3 s, and the error shrinks from 0.1 s to 0.3 s.
    room = Shoebox(SIZE_M)
    volume = np.prod(SIZE_M)
    ratios = []
    for t in (0.1, 0.3):
        images = image_sources(room, SOURCE_M, RECEIVER_M, max_time_s=t)
        ratios.append(images.energy.sum() / (C_M_S * t / volume))
    assert ratios[1] == pytest.approx(1.0, abs=0.05)
    assert abs(ratios[1] - 1) < abs(ratios[0] - 1)


def test_cube_early_decay_follows_eyring():
    # In a cube with uniform α, the images along direction u have order c t (|ux|+|uy|+|uz|)/L,
    # whose mean over directions is c t S / (4V): the decay is a mix of exponentials whose
    # mean rate is Eyring's. The early decay follows the mean (EDT within 4 % of Eyring,
    # 1.9 % seen); the mix bends the curve upwards later (T30 > EDT).
    side, alpha = 5.0, 0.3
    room = Shoebox((side, side, side), absorption=alpha)
    images = image_sources(room, (1.1, 1.6, 1.2), (3.5, 2.2, 1.7), max_time_s=0.3)
    edges = np.arange(0.0, 0.3 + 1e-9, 1e-3)
    edc = schroeder_db(energy_histogram(images, edges))
    t = edges[:-1]

    def decay_time(upper, lower):
        sel = (edc <= upper) & (edc >= lower)
        return -60.0 / np.polyfit(t[sel], edc[sel], 1)[0]

    eyring = 24 * math.log(10) * side**3 / (C_M_S * -6 * side**2 * math.log(1 - alpha))
    assert decay_time(0.0, -10.0) == pytest.approx(eyring, rel=0.04)
    assert decay_time(-5.0, -35.0) > decay_time(0.0, -10.0)


def test_energy_histogram_and_schroeder_db():
    room = Shoebox(SIZE_M, absorption=[[0.2, 0.4]] * 6)
    images = image_sources(room, SOURCE_M, RECEIVER_M, max_time_s=0.2)
    edges = np.arange(0.0, 0.2 + 1e-9, 1e-3)
    hist = energy_histogram(images, edges)
    assert hist.shape == (2, edges.size - 1)  # bands first, time last
    # Energy is conserved (all images lie within the edges) and the direct sound is in its bin.
    np.testing.assert_allclose(hist.sum(axis=-1), images.energy.sum(axis=0), rtol=1e-12)
    first = int(np.nonzero(hist[0])[0][0])
    assert edges[first] <= images.delay_s[0] < edges[first + 1]
    edc = schroeder_db(hist)
    assert np.all(edc[:, 0] == 0) and np.all(np.diff(edc, axis=-1) <= 1e-12)
    assert np.all(edc[1] <= edc[0] + 1e-12)  # the more absorbing band decays faster


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="inside"):
        image_sources(Shoebox(SIZE_M), (6.0, 1.0, 1.0), RECEIVER_M, max_order=1)
    with pytest.raises(ValueError, match="max_order"):
        image_sources(Shoebox(SIZE_M), SOURCE_M, RECEIVER_M)
    with pytest.raises(ValueError, match="unknown walls"):
        Shoebox(SIZE_M, absorption={"roof": 0.1})
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        Shoebox(SIZE_M, absorption=1.5)
