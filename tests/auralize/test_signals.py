"""The built-in dry signals: lengths, levels, determinism, and what they are made of."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.auralize.signals import DEFAULT_SECONDS, PEAK, builtin
from sonolux.errors import SonoluxError

FS = 48000


@pytest.mark.parametrize("name", sorted(DEFAULT_SECONDS))
def test_each_signal_has_its_length_and_level(name):
    x = builtin(f"builtin:{name}", FS)
    assert x.size == round(DEFAULT_SECONDS[name] * FS)
    assert np.all(np.isfinite(x)) and np.isclose(np.max(np.abs(x)), PEAK)
    assert np.array_equal(x, builtin(name, FS))  # deterministic
    assert builtin(f"builtin:{name}:1.5", FS).size == 1.5 * FS
    assert builtin(f"builtin:{name}", 44100, duration_s=2.0).size == 2 * 44100


def band_energy(x, lo, hi):
    f = np.fft.rfftfreq(x.size, 1 / FS)
    p = np.abs(np.fft.rfft(x)) ** 2
    return p[(f >= lo) & (f < hi)].sum() / p.sum()


def test_speech_is_voiced_with_formants_and_pauses():
    x = builtin("builtin:speech", FS)
    assert band_energy(x, 80, 4000) > 0.8  # voiced energy where speech has it
    assert band_energy(x, 4000, 10000) > 0.001  # and some fricative hiss
    env = np.sqrt(np.convolve(x**2, np.ones(480) / 480, "same"))
    assert np.mean(env < 1e-3 * env.max()) > 0.05  # pauses: syllable and phrase gaps


def test_melody_notes_are_harmonic():
    x = builtin("builtin:melody", FS)
    f = np.fft.rfftfreq(x.size, 1 / FS)
    p = np.abs(np.fft.rfft(x))
    assert 200 < f[np.argmax(p)] < 700  # fundamentals of A3 to E5


def test_sweep_and_clicks():
    clicks = builtin("builtin:clicks", FS)
    assert np.flatnonzero(clicks).tolist() == list(range(0, 4 * FS, FS // 2))
    sweep = builtin("builtin:sweep", FS)
    assert band_energy(sweep, 20, 100) > 0.1 and band_energy(sweep, 5000, 20000) > 0.05


def test_unknown_builtin_suggests_a_name():
    with pytest.raises(SonoluxError, match="did you mean 'speech'"):
        builtin("builtin:speach", FS)
    with pytest.raises(SonoluxError, match="not a length"):
        builtin("builtin:noise:long", FS)
