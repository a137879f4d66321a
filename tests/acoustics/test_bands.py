"""Band sets of IEC 61260-1 and conversions between octaves and thirds (sonolux.acoustics.bands)."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.acoustics.bands import (
    NOMINAL_HZ,
    OCTAVE,
    THIRD_OCTAVE,
    BandSet,
    band_set_of,
    convert_coefficients,
    held_bands,
    octave_energies,
)

LIBRARY = BandSet(OCTAVE, (63, 125, 250, 500, 1000, 2000, 4000, 8000))


def test_nominal_centres_are_iec_61260_1_annex_e():
    # The nominal centres as IEC 61260-1 Annex E lists them (exact values rounded to R10).
    assert NOMINAL_HZ[OCTAVE] == (31.5, 63, 125, 250, 500, 1000, 2000, 4000, 8000, 16000)
    assert NOMINAL_HZ[THIRD_OCTAVE] == (
        25, 31.5, 40, 50, 63, 80, 100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250,
        1600, 2000, 2500, 3150, 4000, 5000, 6300, 8000, 10000, 12500, 16000, 20000)


def test_exact_midband_frequencies_and_edges_are_base_10():
    thirds = BandSet(THIRD_OCTAVE, NOMINAL_HZ[THIRD_OCTAVE])
    f = thirds.exact_hz
    # Every exact centre is within 2 % of its nominal label (R10 rounding is at most 1.3 %).
    assert np.all(np.abs(f / np.array(thirds.nominal_hz, float) - 1) < 0.02)
    np.testing.assert_allclose(f[1:] / f[:-1], 10 ** 0.1, rtol=1e-12)  # G^(1/3), G = 10^0.3
    e = thirds.edges_hz
    np.testing.assert_allclose(e[1:, 0], e[:-1, 1], rtol=1e-12)  # edges meet
    np.testing.assert_allclose(np.sqrt(e[:, 0] * e[:, 1]), f, rtol=1e-12)
    octaves = BandSet(OCTAVE, NOMINAL_HZ[OCTAVE])
    # An octave is exactly the union of its three thirds.
    oct_e = octaves.edges_hz
    i = [thirds.nominal_hz.index(c) for c in octaves.nominal_hz]
    np.testing.assert_allclose(oct_e[:, 0], e[[k - 1 for k in i], 0], rtol=1e-12)
    np.testing.assert_allclose(oct_e[:, 1], e[[k + 1 for k in i], 1], rtol=1e-12)
    assert octaves.exact_hz[NOMINAL_HZ[OCTAVE].index(1000)] == 1000.0


def test_band_sets_are_inferred_and_checked():
    assert band_set_of([125, 250, 500]).kind == OCTAVE
    assert band_set_of([1000]).kind == OCTAVE  # a band common to both counts as an octave
    assert band_set_of([1000], THIRD_OCTAVE).kind == THIRD_OCTAVE
    assert band_set_of([100.0, 125.0, 160.0]).kind == THIRD_OCTAVE
    for bad in ([125, 500], [125, 160, 250], [1001], [], [20000, 25000]):
        with pytest.raises(ValueError):
            band_set_of(bad)


def test_octave_coefficients_hold_over_their_thirds_and_return_exactly():
    alpha = np.array([0.11, 0.23, 0.37, 0.41, 0.53, 0.67, 0.71, 0.89])
    thirds = band_set_of([100, 125, 160, 200, 250, 315])
    np.testing.assert_array_equal(convert_coefficients(alpha, LIBRARY, thirds),
                                  [0.23, 0.23, 0.23, 0.37, 0.37, 0.37])
    octaves = band_set_of([125, 250, 500, 1000, 2000, 4000])
    back = convert_coefficients(convert_coefficients(alpha, LIBRARY,
                                                     band_set_of(NOMINAL_HZ[THIRD_OCTAVE])),
                                band_set_of(NOMINAL_HZ[THIRD_OCTAVE]), octaves)
    np.testing.assert_array_equal(back, alpha[1:7])  # bit for bit: three equal thirds
    # Octave to octave is a plain pick: today's scenes keep their bits.
    np.testing.assert_array_equal(convert_coefficients(alpha, LIBRARY, octaves), alpha[1:7])


def test_third_coefficients_average_into_octaves_and_hold_beyond_the_data():
    thirds = band_set_of([100, 125, 160, 200, 250, 315])
    alpha = np.array([0.1, 0.2, 0.6, 0.3, 0.3, 0.9])
    octaves = band_set_of([63, 125, 250, 500])
    got = convert_coefficients(alpha, thirds, octaves)
    # 63 Hz (thirds 50, 63, 80) holds the lowest third; 500 Hz (400, 500, 630) the highest.
    np.testing.assert_allclose(got, [0.1, 0.3, 0.5, 0.9], rtol=1e-15)
    assert held_bands(thirds, octaves) == [63, 500]
    assert held_bands(LIBRARY, band_set_of([40, 50, 63])) == [40]  # 50 Hz lies in 63 Hz's octave


def test_octave_energies_add_three_thirds():
    thirds = band_set_of([80, 100, 125, 160, 200, 250, 315, 400])
    e = np.arange(2 * 8 * 3, dtype=float).reshape(2, 8, 3)
    octaves, summed = octave_energies(e, thirds, axis=1)
    assert octaves.nominal_hz == (125, 250)  # 63 and 500 lack a third: left out
    np.testing.assert_array_equal(summed[:, 0], e[:, 1:4].sum(axis=1))
    np.testing.assert_array_equal(summed[:, 1], e[:, 4:7].sum(axis=1))
    with pytest.raises(ValueError, match="no whole octave"):
        octave_energies(e[:, :2], band_set_of([80, 100]), axis=1)
    with pytest.raises(ValueError, match="third-octave field"):
        octave_energies(e, band_set_of([125, 250, 500]), axis=1)
