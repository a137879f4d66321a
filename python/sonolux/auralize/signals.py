"""Built-in dry (anechoic) signals, generated, never downloaded: ``builtin:NAME[:SECONDS]``.

- ``clicks``: unit-sample impulses every 0.5 s (each one plays the response itself).
- ``noise``: white-noise bursts of 0.2 s every 1 s, 5 ms raised-cosine ramps.
- ``sweep``: an exponential sine sweep 20 Hz to 0.45 fs over 3 s, then 1 s of silence, repeated.
- ``melody``: a plucked-string melody: additive partials (amplitude 1/k, upper partials decaying
  faster), 6 ms attack, exponential decay, slight vibrato; notes and rests so tails are heard.
- ``speech``: formant-synthesised syllables: a Rosenberg glottal pulse train (F0 95-140 Hz with
  a falling phrase contour and jitter) through a cascade of three resonators gliding between
  vowel targets (a e i o u), with fricatives (high-passed noise), plosive bursts and pauses.

Every signal is float64[samples] at the rate asked for, peak 0.5 (−6 dBFS), deterministic (the
noise comes from a fixed seed). Without SECONDS each has a default length (4 to 7 s); with it,
the signal is generated (patterns repeated) to exactly that length.
"""

from __future__ import annotations

import numpy as np
from scipy import signal as ss

from sonolux.errors import SonoluxError, close_matches

DEFAULT_SECONDS = {"clicks": 4.0, "noise": 4.0, "sweep": 4.0, "melody": 6.0, "speech": 7.0}
PEAK = 0.5
_SEED = 20240613

# Formants (Hz) of five vowels of an adult male voice (Peterson and Barney 1952, rounded).
VOWELS = {"a": (730, 1090, 2440), "e": (530, 1840, 2480), "i": (270, 2290, 3010),
          "o": (570, 840, 2410), "u": (300, 870, 2240)}
_BANDWIDTHS_HZ = (70.0, 100.0, 140.0)
# A phrase: (consonant, vowel) syllables; "" = none, "s"/"f" fricatives, "t"/"k" plosives.
_PHRASE = [("s", "a"), ("", "e"), ("t", "i"), ("", "o"), ("f", "u"), ("k", "a"), ("", "i"),
           ("s", "e"), ("t", "o")]


def is_builtin(spec: str) -> bool:
    return str(spec).startswith("builtin:")


def builtin(spec: str, sample_rate_hz: int, duration_s: float | None = None) -> np.ndarray:
    """The built-in signal named by ``builtin:NAME[:SECONDS]`` (or just ``NAME``).

    ``duration_s`` is used when the spec gives no SECONDS (e.g. the length of a walk)."""
    text = str(spec).removeprefix("builtin:")
    name, _, secs = text.partition(":")
    if name not in DEFAULT_SECONDS:
        near = close_matches(name, DEFAULT_SECONDS)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise SonoluxError(f"{spec!r} is not a built-in signal: one of "
                           f"{', '.join('builtin:' + n for n in DEFAULT_SECONDS)}{hint}")
    if secs:
        try:
            duration_s = float(secs)
        except ValueError:
            raise SonoluxError(f"{spec!r}: {secs!r} is not a length in seconds") from None
    seconds = DEFAULT_SECONDS[name] if duration_s is None else float(duration_s)
    if not 0.01 <= seconds <= 3600:
        raise SonoluxError(f"{spec!r}: a length of {seconds:g} s is not allowed: 0.01 to 3600 s")
    fs = int(sample_rate_hz)
    n = int(round(seconds * fs))
    x = {"clicks": clicks, "noise": noise_bursts, "sweep": sweep, "melody": melody,
         "speech": speech}[name](n, fs)
    peak = np.max(np.abs(x)) if x.size else 0.0
    return x * (PEAK / peak) if peak > 0 else x


def clicks(n: int, fs: int, interval_s: float = 0.5) -> np.ndarray:
    x = np.zeros(n)
    x[:: max(1, int(round(interval_s * fs)))] = 1.0
    return x


def noise_bursts(n: int, fs: int, burst_s: float = 0.2, period_s: float = 1.0) -> np.ndarray:
    rng = np.random.default_rng(_SEED)
    t = np.arange(n) / fs
    phase = np.mod(t, period_s)
    ramp = 0.005
    env = np.clip(np.minimum(phase, burst_s - phase) / ramp, 0.0, 1.0)
    env = np.sin(0.5 * np.pi * env) ** 2 * (phase < burst_s)
    return rng.standard_normal(n) * env


def sweep(n: int, fs: int, sweep_s: float = 3.0, gap_s: float = 1.0) -> np.ndarray:
    """Exponential (Farina) sweep from 20 Hz to 0.45 fs, 10 ms fades, then silence; repeated."""
    f1, f2 = 20.0, 0.45 * fs
    m = int(round(sweep_s * fs))
    t = np.arange(m) / fs
    rate = np.log(f2 / f1)
    one = np.sin(2 * np.pi * f1 * sweep_s / rate * (np.exp(t * rate / sweep_s) - 1.0))
    fade = int(0.01 * fs)
    w = np.ones(m)
    w[:fade] = np.sin(0.5 * np.pi * np.arange(fade) / fade) ** 2
    w[-fade:] = w[:fade][::-1]
    period = np.concatenate([one * w, np.zeros(int(round(gap_s * fs)))])
    return np.resize(period, n)


def melody(n: int, fs: int) -> np.ndarray:
    """A plucked melody in A minor pentatonic; (MIDI note or None for a rest, beats) at 100 bpm."""
    tune = [(69, 1), (72, 1), (74, 1), (76, 2), (None, 1), (74, 1), (72, 0.5), (69, 0.5),
            (67, 2), (None, 1), (64, 1), (67, 1), (69, 3), (None, 2)]
    beat = 60.0 / 100.0
    x = np.zeros(n)
    start = 0.0
    rng = np.random.default_rng(_SEED)
    while int(start * fs) < n:
        for note, beats in tune:
            dur = beats * beat
            if note is not None:
                _pluck(x, fs, start, dur, 440.0 * 2 ** ((note - 69) / 12), rng)
            start += dur
            if int(start * fs) >= n:
                break
    return x


def _pluck(x: np.ndarray, fs: int, start_s: float, dur_s: float, f0: float, rng) -> None:
    i0 = int(start_s * fs)
    m = min(int(dur_s * 1.2 * fs), x.size - i0)
    if m <= 0:
        return
    t = np.arange(m) / fs
    vibrato = 1.0 + 0.004 * np.sin(2 * np.pi * 5.5 * t) * np.clip(t / 0.3, 0, 1)
    phase = 2 * np.pi * f0 * np.cumsum(vibrato) / fs
    tone = np.zeros(m)
    for k in range(1, 13):
        if k * f0 >= 0.45 * fs:
            break
        decay = 1.5 + 1.2 * k  # upper partials die faster, like a string
        tone += np.sin(k * phase + rng.uniform(0, 2 * np.pi)) / k * np.exp(-decay * t)
    attack = np.clip(t / 0.006, 0, 1)
    release = np.clip((dur_s * 1.2 - t) / 0.05, 0, 1)  # no click at the note's end
    x[i0:i0 + m] += tone * attack * release


def speech(n: int, fs: int) -> np.ndarray:
    """Formant-synthesised syllables in phrases of 9 (about 2.6 s), 0.5 s pauses between."""
    rng = np.random.default_rng(_SEED)
    x = np.zeros(n)
    pos = int(0.1 * fs)
    while pos < n:
        pos = _phrase(x, fs, pos, rng) + int(0.5 * fs)
    return x


def _phrase(x: np.ndarray, fs: int, pos: int, rng) -> int:
    syllable_s = 0.26
    n_syl = len(_PHRASE)
    for k, (consonant, vowel) in enumerate(_PHRASE):
        if pos >= x.size:
            return pos
        f0 = 135.0 - 35.0 * k / (n_syl - 1)  # declination over the phrase
        if consonant in ("s", "f"):
            pos = _add(x, pos, _fricative(fs, 0.09, consonant, rng))
        elif consonant in ("t", "k"):
            pos = _add(x, pos, np.zeros(int(0.04 * fs)))  # the closure: silence
            pos = _add(x, pos, _fricative(fs, 0.015, consonant, rng))
        nxt = _PHRASE[k + 1][1] if k + 1 < n_syl else vowel
        pos = _add(x, pos, _vowel(fs, syllable_s - 0.04, VOWELS[vowel], VOWELS[nxt], f0, rng))
        pos += int(0.03 * fs)
    return pos


def _add(x: np.ndarray, pos: int, part: np.ndarray) -> int:
    m = min(part.size, x.size - pos)
    if m > 0:
        x[pos:pos + m] += part[:m]
    return pos + part.size


def _vowel(fs: int, dur_s: float, formants, next_formants, f0: float, rng) -> np.ndarray:
    m = int(dur_s * fs)
    t = np.arange(m) / fs
    # Glottal source: Rosenberg pulses at a slowly varying F0 with 1 % jitter.
    f = f0 * (1 + 0.06 * np.sin(np.pi * t / dur_s)) * (1 + 0.01 * rng.standard_normal())
    phase = np.mod(np.cumsum(f) / fs, 1.0)
    open_q, close_q = 0.4, 0.16
    src = np.where(phase < open_q, 0.5 * (1 - np.cos(np.pi * phase / open_q)),
                   np.where(phase < open_q + close_q,
                            np.cos(0.5 * np.pi * (phase - open_q) / close_q), 0.0))
    src = np.diff(src, prepend=0.0)  # lip radiation: a first difference
    # Formants glide to the next vowel over the last third; resonators run in 5 ms chunks.
    y = src
    glide = np.clip((t / dur_s - 0.66) / 0.34, 0, 1)
    for fa, fb, bw in zip(formants, next_formants, _BANDWIDTHS_HZ):
        y = _resonate(y, fs, fa + (fb - fa) * 0.5 * glide, bw)
    env = np.clip(t / 0.03, 0, 1) * np.clip((dur_s - t) / 0.05, 0, 1)
    return y * env / (np.max(np.abs(y)) + 1e-12)


def _resonate(x: np.ndarray, fs: int, freq_hz: np.ndarray, bw_hz: float) -> np.ndarray:
    """A two-pole resonator (unit gain at DC) with a time-varying centre, state carried over."""
    chunk = max(1, int(0.005 * fs))
    y = np.empty_like(x)
    zi = np.zeros(2)
    r = np.exp(-np.pi * bw_hz / fs)
    for i in range(0, x.size, chunk):
        theta = 2 * np.pi * freq_hz[i] / fs
        a = [1.0, -2 * r * np.cos(theta), r * r]
        y[i:i + chunk], zi = ss.lfilter([sum(a)], a, x[i:i + chunk], zi=zi)
    return y


def _fricative(fs: int, dur_s: float, kind: str, rng) -> np.ndarray:
    m = int(dur_s * fs)
    band = {"s": (4000, 9000), "f": (1500, 7000), "t": (2500, 8000), "k": (1200, 4000)}[kind]
    hi = min(band[1], 0.45 * fs)
    sos = ss.butter(4, [band[0], hi], btype="bandpass", fs=fs, output="sos")
    noise = ss.sosfilt(sos, rng.standard_normal(m))
    t = np.arange(m) / fs
    env = np.sin(np.pi * t / dur_s) ** 2 if kind in ("s", "f") else np.exp(-t / (0.3 * dur_s))
    level = 0.25 if kind in ("s", "f") else 0.5
    return level * noise * env / (np.max(np.abs(noise)) + 1e-12)
