"""STI (IEC 60268-16:2020, indirect method): the modulation transfer of binned decays against
its closed form, the index's limits and trends, and pyrato's implementation as a peer."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.analysis.sti import (
    MODULATION_HZ,
    SpeechSettings,
    level_factors,
    masking_slope_db,
    modulation_transfer,
    speech_levels_db,
    sti_from_mtf,
)
from sonolux.errors import SonoluxError


def exponential_mtf(t60_s):
    """Closed form for an exponential decay: m(F) = 1 / √(1 + (2πF T / 13.8)²)."""
    f = np.asarray(MODULATION_HZ)
    return 1 / np.sqrt(1 + (2 * np.pi * f * t60_s / 13.8) ** 2)


def binned_decay(t60_s, early_s=0.1, early_bin_s=1e-3, late_bin_s=0.01, length_s=4.0):
    """Exact energies of e^(−13.8 t / T) in bins like the field's: fine, then coarse."""
    edges = np.concatenate([np.arange(0, early_s, early_bin_s),
                            np.arange(early_s, length_s + late_bin_s / 2, late_bin_s)])
    k = 13.8 / t60_s
    energy = (np.exp(-k * edges[:-1]) - np.exp(-k * edges[1:])) / k
    return energy, edges[:-1], np.diff(edges)


@pytest.mark.parametrize("t60_s", [0.3, 0.8, 2.0])
def test_binned_decays_give_the_closed_form_mtf(t60_s):
    # The sinc factor makes an evenly spread bin exact; what is left is the exponential's shape
    # inside a 10 ms bin: below 1e-3 at 12.5 Hz.
    m = modulation_transfer(*binned_decay(t60_s))
    assert np.allclose(m, exponential_mtf(t60_s), atol=1e-3)


def test_the_index_from_the_mtf():
    # A perfect channel reads 1 (Σα − Σβ = 1); a very long decay reads near 0; longer decays
    # read less. The closed form of an exponential decay, mapped by the same chain: within 0.01
    # of the binned decay's index.
    assert sti_from_mtf(np.ones((7, 14))) == pytest.approx(1.0)
    assert sti_from_mtf(np.full((7, 14), 1e-6)) == pytest.approx(0.0, abs=1e-9)
    values = [float(sti_from_mtf(np.tile(exponential_mtf(t), (7, 1)))) for t in (0.3, 1, 3)]
    assert values[0] > values[1] > values[2]
    for t in (0.4, 1.2):
        binned = sti_from_mtf(np.tile(modulation_transfer(*binned_decay(t)), (7, 1)))
        assert binned == pytest.approx(sti_from_mtf(np.tile(exponential_mtf(t), (7, 1))),
                                       abs=0.01)


def test_noise_masking_and_threshold_lower_the_index():
    # Without masking and threshold the noise factor is 1 / (1 + 10^(−SNR/10)) (A.2.3);
    # with them a quiet talker loses more; louder noise always lowers the index.
    speech = speech_levels_db(np.full(7, 20.0))  # G = 20 dB: 60 dB(A) at 1 m, 20 dB more
    quiet = level_factors(speech, None)
    assert np.all(quiet < 1) and np.all(quiet > 0.5)
    m = np.tile(exponential_mtf(0.8), (7, 1))
    values = [float(sti_from_mtf(m * level_factors(speech, speech - snr)[:, None]))
              for snr in (30, 15, 5, -5)]
    assert values == sorted(values, reverse=True) and values[-1] < 0.3
    assert masking_slope_db(np.array([50.0, 65.0, 80.0, 120.0])).tolist() == \
        pytest.approx([-40.0, -29.9, -19.8, -10.0])


def test_settings_are_checked():
    with pytest.raises(SonoluxError, match="noise_db"):
        SpeechSettings(noise_db=(40.0,) * 6).validate()
    with pytest.raises(SonoluxError, match="speech_dba"):
        SpeechSettings(speech_dba=float("nan")).validate()


@pytest.mark.slow
@pytest.mark.parametrize("t60_s", [0.5, 1.2])
def test_against_pyrato(t60_s):
    # pyrato (the Acoustics group of TU Berlin's room-acoustics package) computes the indirect
    # STI from a pressure impulse response through its own octave filters. An exponentially
    # decaying noise has the same decay in every band, so our chain on the closed-form MTF
    # must give pyrato's value; within 0.01 (measured: 0.002-0.003, its filters' skirts and the
    # noise's own scatter), with and without the level corrections.
    pf = pytest.importorskip("pyfar")
    pyrato = pytest.importorskip("pyrato")
    if not hasattr(pyrato.parameters, "speech_transmission_index_indirect"):
        pytest.skip("this pyrato has no STI")
    fs = 48_000
    t = np.arange(int(2.5 * fs)) / fs
    rng = np.random.default_rng(3)
    h = rng.standard_normal(t.size) * np.exp(-6.91 * t / t60_s)
    rir = pf.Signal(h[None], fs)
    theirs = float(pyrato.parameters.speech_transmission_index_indirect(rir)[0])
    ours = float(sti_from_mtf(np.tile(exponential_mtf(t60_s), (7, 1))))
    assert ours == pytest.approx(theirs, abs=0.01)
    level = 60 + np.array([2.9, 2.9, -0.8, -6.8, -12.8, -18.8, -24.8])
    theirs = float(pyrato.parameters.speech_transmission_index_indirect(rir, level=level)[0])
    ours = float(sti_from_mtf(np.tile(exponential_mtf(t60_s), (7, 1))
                              * level_factors(level, None)[:, None]))
    assert ours == pytest.approx(theirs, abs=0.01)
