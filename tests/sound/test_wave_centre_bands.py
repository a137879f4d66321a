"""Whether a measured (SOFA) source's wave bands share one acoustic centre
(``sonolux.sound.wave_centre``: each band's own centre from its measured phase, after Ben Hagai,
Pollow, Vorländer and Rafaely, JASA 2011; the cost of one shared centre in the fit's orders, from
the plane wave's expansion in spherical Bessel functions), on synthetic sources: one displaced
alike in every band (they share: nothing is flagged, the fit is the one of before) and one whose
centre moves with frequency (as a loudspeaker's does: Jacobsen, Barrera-Figueroa and
Rasmussen, JASA 2004), whose bands' centres are found each where it is and flagged."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.sound import wave_sources
from sonolux.sound.wave_centre import translation_spill
from tests.sound.test_wave_sources_centre import OFFSET_M, TO_WORLD, as_read, displaced
from tests.sound.test_wave_sources_order2 import BANDS, C

pytestmark = pytest.mark.usefixtures("core")


def moving(n: int = 500):
    """A cardioid (its frame: x forward) whose centre lies at OFFSET_M·f/125 Hz from the array's
    centre at frequency f (half of it at 63 Hz, twice at 250 Hz), far field: H = D(u)·e^{ik
    u·d(f)}; read as a SOFA directivity is (power and relative phase)."""
    mics = wave_sources.fibonacci_directions(n)
    freqs = np.linspace(20.0, 2000.0, 100)
    k = 2.0 * np.pi * freqs / C
    along = mics @ OFFSET_M
    h = (0.5 + 0.5 * mics[:, 0])[:, None] * np.exp(1j * along[:, None] * (k * freqs / 125.0)[None])
    return as_read("moving.sofa", mics, freqs, h)


def test_the_spill_of_a_translation_is_what_a_quadrature_of_the_moved_monopole_gives():
    """1 − Σ_{n≤L}(2n + 1) j_n(kδ)² against the energy of e^{ik u·δ} above orders 0 and 1
    projected on 4,096 Fibonacci directions (its orders 0 and 1 are ⟨f⟩ and 3⟨f u⟩): within
    1e-6 (the lattice's quadrature error for these smooth functions)."""
    u = wave_sources.fibonacci_directions(4096)
    for x in (0.05, 0.3, 1.0, 2.5):
        f = np.exp(1j * x * u[:, 2])
        order0 = abs(f.mean()) ** 2
        order1 = 3.0 * float(np.sum(np.abs((f[:, None] * u).mean(axis=0)) ** 2))
        spill = translation_spill(np.array([x, x]), np.array([1.0, 1.0]), np.array([0, 1]))
        assert spill[0] == pytest.approx(1.0 - order0, abs=1e-6)
        assert spill[1] == pytest.approx(1.0 - order0 - order1, abs=1e-6)


@pytest.mark.parametrize("pattern", ["omni", "cardioid"])
def test_a_source_displaced_alike_in_every_band_shares_one_centre(pattern):
    """Every wave band's own centre is the offset (2% of it, the centre's tested tolerance), and
    none is flagged: one shared centre costs nothing measurable."""
    source, d = displaced(pattern)
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    assert fit.band_centres_m.shape == (3, 3)
    offset = TO_WORLD @ OFFSET_M
    assert np.all(np.linalg.norm(fit.band_centres_m - offset[None], axis=1)
                  < 0.02 * np.linalg.norm(offset)), fit.band_centres_m
    assert not np.any(fit.centres_differ)
    assert "own centres" not in wave_sources.centred(fit)


def test_a_source_whose_centre_moves_with_frequency_is_found_band_by_band():
    """Each wave band's centre is where the phase puts it at the band's centre frequency,
    OFFSET_M·f_b/125 Hz (within 3% of it: the centre's 2% and the linear interpolation of a
    phase growing as f² between the file's 20 Hz steps, (Δf)²/(8 f²) ≤ 1.3% at 63 Hz).

    Whether they must differ is the fit's to say. With the orders the fit radiates (0-2 here)
    the shared centre, 0.12 m from the 63 Hz band's own, leaves 2.6·10⁻⁶ of that band above its
    orders (a translation by δ reaches above order L only as j_n(kδ), n > L: kδ = 0.14 there),
    less than the 4·10⁻⁴ for which the fit radiates an order at all: they share one, nothing
    is flagged. With order 1 only (a cluster capped by a near wall)
    the same translation leaves a few per mille, far more than at the band's own centre: the
    bands are flagged, and the log names how far apart their centres lie."""
    source, d = moving()
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    for b in range(3):
        want = TO_WORLD @ OFFSET_M * (BANDS[b] / 125.0)
        assert np.linalg.norm(fit.band_centres_m[b] - want) < 0.03 * np.linalg.norm(want), (
            b, fit.band_centres_m[b], want)
    assert not np.any(fit.centres_differ), (fit.residual, fit.orders)
    assert np.all(fit.residual[:3] < 1e-4)
    capped = wave_sources.fit(source, d, len(BANDS), np.ones(len(BANDS), int), bands_hz=BANDS,
                              centre_bands=3)
    np.testing.assert_array_equal(capped.band_centres_m, fit.band_centres_m)
    assert capped.centres_differ[0], (capped.residual, capped.band_centres_m)
    assert capped.residual[0] > 1e-3
    assert "own centres lie" in wave_sources.centred(capped)
