"""Closed-form acoustics against published numbers and exact identities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sonolux.acoustics.theory import (
    air_attenuation_db_per_m,
    air_energy_attenuation_per_m,
    eyring_t60,
    sabine_t60,
    speed_of_sound_m_s,
)


def exact_midband_hz(nominal_hz: float) -> float:
    """ISO 9613-1 Table 1 is computed at exact third-octave midbands 1000 * 10^(k/10)."""
    k = round(10 * math.log10(nominal_hz / 1000))
    return 1000.0 * 10 ** (k / 10)


# ISO 9613-1:1993 Table 1, pure-tone attenuation coefficient in dB/km at 101.325 kPa:
# (temperature °C, relative humidity %, nominal frequency Hz, alpha dB/km). Values as printed
# in the standard (three significant figures), transcribed in public test suites of ISO 9613-1
# implementations (e.g. the ITA-Toolbox test of ita_atmospheric_absorption_iso9613).
ISO_9613_1_TABLE_1 = [
    (20, 50, 1000, 4.66),
    (20, 50, 2000, 9.86),
    (20, 80, 1000, 5.15),
    (20, 80, 50, 0.0501),
    (20, 15, 6300, 175.0),
    (10, 70, 1000, 3.66),
    (0, 20, 2000, 34.6),
    (-20, 50, 1000, 9.14),
    (30, 50, 4000, 24.5),
    (15, 100, 10000, 105.0),
]


@pytest.mark.parametrize(("temp_c", "rh", "freq", "alpha_db_km"), ISO_9613_1_TABLE_1)
def test_air_attenuation_matches_iso_9613_1_table(temp_c, rh, freq, alpha_db_km):
    # Tolerance 1 %: the table prints three significant figures (at most 0.5 % rounding).
    got = air_attenuation_db_per_m(exact_midband_hz(freq), temp_c, rh, 101.325) * 1000
    assert got == pytest.approx(alpha_db_km, rel=0.01)


def test_air_attenuation_broadcasts_and_energy_form():
    f = np.array([125.0, 1000.0, 8000.0])
    alpha = air_attenuation_db_per_m(f)
    assert alpha.shape == (3,) and np.all(np.diff(alpha) > 0)
    m = air_energy_attenuation_per_m(f)
    # Energy falls as exp(-m x): 10 log10(e^(m x)) dB over x metres equals alpha x.
    np.testing.assert_allclose(10 * np.log10(np.exp(m * 100.0)), alpha * 100.0, rtol=1e-12)


def test_speed_of_sound():
    assert speed_of_sound_m_s(0.0) == pytest.approx(331.3)
    assert speed_of_sound_m_s(20.0) == pytest.approx(343.21, abs=0.01)


def test_sabine_closed_form():
    # 24 ln(10) V / (c A) with V = 100 m³, A = 20 m², c = 343 m/s.
    assert sabine_t60(100.0, 20.0, 0.0, 343.0) == pytest.approx(
        24 * math.log(10) * 100 / (343 * 20), rel=1e-12)
    # Air absorption adds 4 m V to the absorption area.
    assert sabine_t60(100.0, 20.0, 0.01, 343.0) == pytest.approx(
        24 * math.log(10) * 100 / (343 * (20 + 4 * 0.01 * 100)), rel=1e-12)
    assert sabine_t60(100.0, 0.0) == math.inf


def test_eyring_tends_to_sabine_for_small_absorption_and_to_zero_at_one():
    v, s = 200.0, 220.0
    small = 1e-4
    assert eyring_t60(v, s, small, c_m_s=343.0) == pytest.approx(
        sabine_t60(v, s * small, c_m_s=343.0), rel=1e-4)
    assert eyring_t60(v, s, 1.0) == 0.0
    # Always shorter than Sabine for the same mean absorption.
    a = np.array([0.05, 0.2, 0.5])
    assert np.all(eyring_t60(v, s, a) < sabine_t60(v, s * a))


def test_fitzroy_is_eyring_when_every_axis_absorbs_alike_and_longer_when_one_pair_absorbs():
    from sonolux.acoustics.theory import eyring_t60, fitzroy_t60

    v, areas = 120.0, np.array([30.0, 40.0, 50.0])
    same = fitzroy_t60(v, areas, [[0.2, 0.4]] * 3, 0.001, 343.0)
    np.testing.assert_allclose(same, eyring_t60(v, areas.sum(), np.array([0.2, 0.4]), 0.001, 343.0),
                               rtol=1e-12)
    # The same absorption area, all of it on the floor and ceiling: walls flutter, the decay is
    # slower than Eyring's uniform room (Fitzroy 1959), and dominated by the walls' pairs.
    a_total = 0.2 * areas.sum()
    uneven = fitzroy_t60(v, areas, [0.0001, 0.0001, (a_total - 0.007) / 50.0], 0.0, 343.0)
    assert uneven > 5 * eyring_t60(v, areas.sum(), 0.2, 0.0, 343.0)


def test_the_automatic_record_covers_a_room_that_absorbs_only_at_the_ceiling():
    """The L-shaped classroom (absorbing ceiling, hard walls) decays about twice as slowly as
    Sabine says: with a record from Sabine alone its T20s were refused ("record too short");
    Fitzroy's T60 makes the record long enough for them."""
    from pathlib import Path

    import sonolux
    from sonolux.analysis.params import room_parameters
    from sonolux.engine import core_available

    if not core_available():
        pytest.skip("needs the compiled core")
    room = Path(__file__).resolve().parents[2] / "examples" / "l-room" / "l-room.toml"
    field = sonolux.bake(sonolux.load_scene(room), rays=60_000)
    reasons = room_parameters(field, theory=False).reasons["t20"]
    assert not any("record too short" in r for r in reasons.ravel())
