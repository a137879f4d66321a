"""A measured (SOFA) source's acoustic centre from its measured phase
(``sonolux.sound.wave_centre``, after Ben Hagai, Pollow, Vorländer and Rafaely, JASA 2011):
synthetic measurements of sources displaced from the array's centre by a known offset, in the
far field (the translation exactly a phase) and on a 2 m array (its near field too)."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import fft as sfft

from sonolux import engine
from sonolux.sound import wave_sources
from sonolux.sound.wave_centre import acoustic_centre_m
from tests.sound.test_wave_sources_order2 import BANDS, C, pulse_spectrum

pytestmark = pytest.mark.usefixtures("core")

#: The source's offset from the array's centre, in its own frame (x forward, y left, z up).
OFFSET_M = np.array([0.08, -0.05, 0.03])
#: Its view and up in the room; local → world rotation (columns: forward, left, up).
FORWARD, UP = (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
TO_WORLD = np.column_stack([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
PATTERNS = {"omni": lambda v: np.ones(len(v)), "cardioid": lambda v: 0.5 + 0.5 * v[:, 0],
            "dipole": lambda v: v[:, 0]}


def displaced(pattern, radius_m=None, n=500):
    """A SOFA directivity as read (``SofaDirectivity``: power and relative phase) of a source
    of amplitude ``pattern`` (towards the unit vector from it, its frame) at :data:`OFFSET_M`
    from the centre of an array of ``n`` microphones: in the far field (``radius_m`` None:
    H = D(u)·e^{ik·u·d}) or on a sphere of ``radius_m`` (H = D(v)·e^{−ik(|Ru − d| − R)}/|Ru − d|,
    v the direction from the source). With the engine's directivity from its band energies."""
    mics = wave_sources.fibonacci_directions(n)
    freqs = np.linspace(20.0, 2000.0, 100)
    k = 2.0 * np.pi * freqs / C
    if radius_m is None:
        h = PATTERNS[pattern](mics)[:, None] * np.exp(1j * np.outer(mics @ OFFSET_M, k))
    else:
        rel = radius_m * mics - OFFSET_M
        r = np.linalg.norm(rel, axis=1)
        h = (PATTERNS[pattern](rel / r[:, None]) / r)[:, None] * np.exp(
            -1j * np.outer(r - radius_m, k))
    return as_read("displaced.sofa", mics, freqs, h)


def as_read(name, mics, freqs, h):
    """The source of responses ``h`` [microphone, frequency] as a SOFA directivity is read
    (power, and phase relative to the loudest microphone's), and the engine's directivity from
    its band energies."""
    from sonolux.scene.sofa_directivity import SofaDirectivity, sofa_gains

    ref = np.conj(h[np.argmax(np.abs(h[:, 0]))])[None]
    phase = h * ref / np.abs(h * ref)
    sofa = SofaDirectivity(name, mics, freqs, np.abs(h) ** 2, phase)
    edges = np.column_stack([BANDS / math.sqrt(2), BANDS * math.sqrt(2)])
    d = engine.Directivity.pattern(np.ascontiguousarray(sofa_gains(sofa, edges), float),
                                   FORWARD, UP)
    return SimpleNamespace(directivity="sofa", forward=FORWARD, up=UP, name="m", sofa=sofa), d


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
@pytest.mark.parametrize("radius_m", [None, 2.0])
def test_a_displaced_source_s_centre_is_found_from_its_phase(pattern, radius_m):
    """The centre found from the phase of the wave bands (63-250 Hz) is the offset, in the
    room's frame. Tolerance 2% of the offset (2 mm; measured 0.4-0.5% in the far field): the
    phase is interpolated linearly on the triangulation of 500 directions (edges h ≈ 0.17 rad,
    an error of order h²/8 ≈ 0.4% of the phase per triangle) and differenced on the fit's
    grid. On a 2 m array, plus |d|²/(2R) (2.5 mm): the near field's phase
    k(|d|² − (u·d)²)/(2R), which no translation carries (measured 1.5 mm for the cardioid).
    The dipole's rear lobe, in antiphase, does not move it (the sign changes are not a
    translation)."""
    source, d = displaced(pattern, radius_m)
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    tolerance = 0.02 * np.linalg.norm(OFFSET_M) + (
        0.0 if radius_m is None else OFFSET_M @ OFFSET_M / (2.0 * radius_m))
    assert np.linalg.norm(fit.centre_offset_m - TO_WORLD @ OFFSET_M) < tolerance, (
        fit.centre_offset_m, TO_WORLD @ OFFSET_M)


def test_a_displaced_omni_source_is_one_monopole_at_its_centre():
    """Measured 94 mm off the array's centre, an omni source is, referred to its centre, a
    monopole: the fit keeps order 0 only (one term, nothing left out); referred to the array's
    centre its pattern e^{ik·u·d} would hold (kd)²/3 above order 0 at the top band (17% at
    500 Hz, its spherical-Bessel series: 1 − j₀(kd)², in closed form here). The log line says
    where the cluster is (to the millimetre: 50, 80, 30 within the 0.5 mm found)."""
    source, d = displaced("omni")
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    assert np.all(fit.orders == 0) and np.all(fit.residual < 1e-4), (fit.orders, fit.residual)
    line = wave_sources.describe("m (sofa)", fit, 1, 3)
    assert "radiated from its acoustic centre, (+50, +80, +30) mm from its position" in line, line
    spacing = C / (10 * 500.0)
    pos, _, _ = wave_sources.terms(np.zeros(3), fit, BANDS, 500.0, spacing, 8660.0, 4000, C)
    np.testing.assert_allclose(pos, fit.centre_offset_m[None], atol=1e-12)
    kd = 2 * math.pi * 500.0 / C * np.linalg.norm(OFFSET_M)
    assert 1.0 - np.sinc(kd / math.pi) ** 2 > 0.1  # what centring spares at 500 Hz


def test_the_cluster_radiates_the_measured_field_from_the_array_s_centre():
    """The displaced cardioid's cluster, summed in closed form as free-field monopoles (far
    field, positions from the array's centre, over the reference pulse), is the measured
    complex field √g·e^{iφ} at 125 and 250 Hz within 0.03 of its peak (the centre's error,
    ≤ 2 mm: k·2 mm = 0.009 rad at 250 Hz; the interpolation of 500 directions; the stencils,
    10⁻⁴); the same cluster at the array's centre misses by more than 0.1 (the translation's
    phase, k|d| = 0.43 rad at 250 Hz)."""
    source, d = displaced("cardioid")
    fit = wave_sources.fit(source, d, len(BANDS), bands_hz=BANDS, centre_bands=3)
    u = wave_sources.fibonacci_directions(800)
    assert cluster_error(fit, source, d, u) < 0.03
    at_array = dataclasses.replace(fit, centre_offset_m=np.zeros(3))
    assert cluster_error(at_array, source, d, u) > 0.1


def cluster_error(fit, source, pattern, u, bands=(1, 2)):
    """The largest difference over directions ``u`` at the centres of ``bands`` (125 and 250 Hz)
    between the cluster's far
    field in closed form and the measured field (``wave_sources.amplitude``, the SOFA phase
    referred to the array's centre), both with phase 0 towards the loudest direction, over
    the peak."""
    f_max, fs, steps = 500.0, 500.0 * 10 * math.sqrt(3.0), 8000
    spacing = C / (f_max * 10)
    pos, sig, delay = wave_sources.terms(np.zeros(3), fit, BANDS, f_max, spacing, fs, steps, C)
    n_fft = sfft.next_fast_len(2 * steps, real=True)
    freqs = sfft.rfftfreq(n_fft, 1.0 / fs)
    spectra = sfft.rfft(sig, n_fft, axis=1)
    ref = pulse_spectrum(delay, f_max, fs, steps, n_fft)
    worst = 0.0
    for b in bands:
        i = int(np.argmin(np.abs(freqs - BANDS[b])))
        far = np.exp(2j * math.pi * freqs[i] / C * (u @ pos.T)) @ spectra[:, i] / ref[i]
        target = wave_sources.amplitude(source, pattern, u, len(BANDS), np.array([freqs[i]] * 4))
        target = target[:, b]
        loudest = np.argmax(np.abs(target))
        far = far * np.exp(-1j * np.angle(far[loudest]))
        target = target * np.exp(-1j * np.angle(target[loudest]))
        worst = max(worst, np.abs(far - target).max() / np.abs(target).max())
    return worst


def test_a_pattern_of_constant_phase_has_its_centre_where_it_is():
    """``acoustic_centre_m`` in closed form: a real pattern (a beam with a sign change) is
    centred where it is, and the same pattern times e^{ik·u·d} is centred at d, to the fit
    grid's differences (tolerance 10⁻⁵ of |d|, measured 7·10⁻⁷: sixth-order differences along
    the meridians over 48 rings, spectral ones around them)."""
    u, w = wave_sources.fit_directions()
    rings = np.polynomial.legendre.leggauss(wave_sources.FIT_RINGS)[0]
    real = (u @ np.array([0.6, 0.0, 0.8])) * (1.0 + u[:, 0]) ** 2
    k = 2 * math.pi * np.array([63.0, 125.0, 250.0]) / C
    shift = np.array([-0.03, 0.11, 0.05])
    assert np.linalg.norm(acoustic_centre_m(real[:, None] * np.ones((1, 3)), u, w, rings,
                                            wave_sources.FIT_AZIMUTHS, k)) < 1e-12
    moved = real[:, None] * np.exp(1j * np.outer(u @ shift, k))
    found = acoustic_centre_m(moved, u, w, rings, wave_sources.FIT_AZIMUTHS, k)
    assert np.linalg.norm(found - shift) < 1e-5 * np.linalg.norm(shift), found
