"""Closed-form room acoustics: air absorption (ISO 9613-1) and reverberation time (Sabine, Eyring).

These are the yardsticks the traced results are checked against. All functions take numpy
arrays or scalars and broadcast.

Air absorption: ISO 9613-1:1993, Acoustics -- Attenuation of sound during propagation
outdoors -- Part 1, equations (1) to (5) (pure tones). The standard states an accuracy of
±10 % for 50 Hz to 10 kHz, -20..50 °C, 10..100 % relative humidity, and pressures near one
atmosphere.

Reverberation: the energy in a diffuse field decays as exp(-c t (A_total + 4 m V) / (4 V)), so
the 60 dB decay time is T60 = 24 ln(10) V / (c (A_total + 4 m V)), with A_total the absorption
area: A = sum(S_i alpha_i) for Sabine, -S ln(1 - mean alpha) for Eyring; m is the air's energy
attenuation coefficient (1/m).
"""

from __future__ import annotations

import math

import numpy as np

T0_K = 293.15  # reference air temperature, 20 °C
T01_K = 273.16  # triple-point isotherm temperature
P_REF_KPA = 101.325  # reference atmospheric pressure
_DB_PER_NEPER_ENERGY = 10.0 * math.log10(math.e)  # 4.343 dB per unit of m x


def speed_of_sound_m_s(temperature_c: float | np.ndarray = 20.0) -> float | np.ndarray:
    """c = 331.3 sqrt(1 + T / 273.15) m/s, T in °C (343.2 m/s at 20 °C)."""
    return 331.3 * np.sqrt(1.0 + np.asarray(temperature_c, dtype=np.float64) / 273.15)


def air_attenuation_db_per_m(freq_hz, temperature_c=20.0, humidity_percent=50.0,
                             pressure_kpa=P_REF_KPA):
    """Pure-tone attenuation coefficient alpha of air in dB/m (ISO 9613-1 eq. 5)."""
    f = np.asarray(freq_hz, dtype=np.float64)
    t = np.asarray(temperature_c, dtype=np.float64) + 273.15
    hr = np.asarray(humidity_percent, dtype=np.float64)
    pa = np.asarray(pressure_kpa, dtype=np.float64) / P_REF_KPA  # relative pressure
    # Molar concentration of water vapour, % (annex B: saturation pressure over water).
    c_exp = -6.8346 * (T01_K / t) ** 1.261 + 4.6151
    h = hr * 10.0 ** c_exp / pa
    # Relaxation frequencies of oxygen and nitrogen, Hz (eq. 3 and 4).
    fr_o = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
    tr = t / T0_K
    fr_n = pa * tr ** -0.5 * (9.0 + 280.0 * h * np.exp(-4.170 * (tr ** (-1.0 / 3.0) - 1.0)))
    alpha = 8.686 * f**2 * (
        1.84e-11 / pa * tr**0.5
        + tr**-2.5 * (0.01275 * np.exp(-2239.1 / t) / (fr_o + f**2 / fr_o)
                      + 0.1068 * np.exp(-3352.0 / t) / (fr_n + f**2 / fr_n)))
    return alpha if alpha.ndim else float(alpha)


def air_energy_attenuation_per_m(freq_hz, temperature_c=20.0, humidity_percent=50.0,
                                 pressure_kpa=P_REF_KPA):
    """Energy attenuation coefficient m in 1/m (energy falls as exp(-m x)): alpha / 4.343."""
    return air_attenuation_db_per_m(freq_hz, temperature_c, humidity_percent,
                                    pressure_kpa) / _DB_PER_NEPER_ENERGY


def _t60(volume_m3, total_absorption_m2, m_per_m, c_m_s):
    v = np.asarray(volume_m3, dtype=np.float64)
    loss = np.asarray(total_absorption_m2, dtype=np.float64) + 4.0 * np.asarray(
        m_per_m, dtype=np.float64) * v
    c = speed_of_sound_m_s(20.0) if c_m_s is None else np.asarray(c_m_s, dtype=np.float64)
    with np.errstate(divide="ignore"):
        t = np.where(loss > 0, 24.0 * math.log(10.0) * v / (c * np.where(loss > 0, loss, 1.0)),
                     np.inf)
    return t if t.ndim else float(t)


def sabine_t60(volume_m3, absorption_area_m2, m_per_m=0.0, c_m_s=None):
    """Sabine's T60 in s: 24 ln(10) V / (c (A + 4 m V)); A = sum(S_i alpha_i) in m².

    ``c_m_s`` defaults to the speed of sound at 20 °C. Infinite when nothing absorbs.
    """
    return _t60(volume_m3, absorption_area_m2, m_per_m, c_m_s)


def eyring_t60(volume_m3, surface_area_m2, mean_absorption, m_per_m=0.0, c_m_s=None):
    """Eyring's T60 in s: 24 ln(10) V / (c (-S ln(1 - mean alpha) + 4 m V)).

    ``mean_absorption`` is the area-weighted mean absorption coefficient; at 1 the room is
    anechoic and T60 is 0.
    """
    a = np.asarray(mean_absorption, dtype=np.float64)
    s = np.asarray(surface_area_m2, dtype=np.float64)
    with np.errstate(divide="ignore"):
        total = -s * np.log1p(-np.minimum(a, 1.0))
    return _t60(volume_m3, total, m_per_m, c_m_s)


def fitzroy_t60(volume_m3, axis_areas_m2, axis_mean_absorption, m_per_m=0.0, c_m_s=None):
    """Fitzroy's T60 in s, for absorption spread unevenly over the three pairs of opposite
    surfaces (D. Fitzroy, "Reverberation formula which seems to be more accurate with nonuniform
    distribution of absorption", JASA 31(7), 893–897, 1959): the area-weighted mean of Eyring's
    T60 taken with each axis's own mean absorption,

        T = Σ_axis (S_axis / S) · 24 ln(10) V / (c (−S ln(1 − ᾱ_axis) + 4 m V)).

    ``axis_areas_m2`` float[3]: the area of the surfaces facing x, y and z;
    ``axis_mean_absorption`` float[3, ...]: each axis's area-weighted mean absorption (bands in
    the trailing axes). Longer than Sabine's and Eyring's where one pair of surfaces absorbs
    little (sound flutters between them), and known to overestimate somewhat there.
    """
    areas = np.asarray(axis_areas_m2, dtype=np.float64)
    alpha = np.asarray(axis_mean_absorption, dtype=np.float64)
    total = float(areas.sum())
    out = 0.0
    for k in range(areas.size):
        if areas[k] > 0:
            out = out + areas[k] / total * np.asarray(
                eyring_t60(volume_m3, total, alpha[k], m_per_m, c_m_s))
    return out
