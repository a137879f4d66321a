"""Octave-band fields from third-octave fields, by adding energy.

A third-octave field's octave is the union of its three thirds (IEC 61260-1 band edges), so
its energy in every (receiver, direction, time) bin is the sum of theirs. Every octave
parameter (T20, EDT, C80, G, STI, ...) is then computed from that summed histogram, as an
octave-filtered measurement would be; decay times or levels of the thirds are never averaged
(an average of three decay times is not the decay time of the summed energy: when the thirds
decay at different rates the sum is curved, and its slope follows the slowest third late).

:func:`octave_field` returns a new :class:`~sonolux.sound.field.SoundField` on the octaves that
the thirds make whole; its theory (Sabine, Eyring, the slowest decay the room allows) is that of
the summed energy, computed from the thirds' (:func:`_summed_t60`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sonolux.acoustics.bands import OCTAVE, THIRD_OCTAVE, octave_grouping
from sonolux.errors import AnalysisError
from sonolux.sound.field import SoundField, with_source_energy

#: Receivers summed at once.
_CHUNK = 32
#: Levels on the Schroeder curve between which T30 is read (ISO 3382-1: −5 to −35 dB).
_T30_LEVELS_DB = (-5.0, -35.0)


def octave_field(field_: SoundField) -> SoundField:
    """The octaves of a third-octave field: energy float32[receiver, direction, octave, time],
    each octave the sum of its three thirds (summed in float64). AnalysisError for a field
    that is not of thirds or holds no whole octave."""
    bands = field_.band_set
    if bands is None or bands.kind != THIRD_OCTAVE:
        raise AnalysisError("octave results from thirds need a third-octave field; this one has "
                            f"{'octave' if bands is not None else 'other'} bands "
                            f"{[float(b) for b in field_.bands_hz]} Hz")
    try:
        octaves, groups = octave_grouping(bands)
    except ValueError as exc:
        raise AnalysisError(str(exc)) from None
    # A field of several sources: each source's octaves (their sum shown as the energy).
    source = field_.energy if field_.per_source is None else field_.per_source
    shape = tuple(source.shape)
    energy = np.empty(shape[:2] + (octaves.n_bands,) + shape[3:], dtype=np.float32)
    # A few receivers at a time, each read whole (``energy[lo:hi]``): bounded float64 copies,
    # and the one kind of indexing every field's energy supports (dense or compact).
    for lo in range(0, shape[0], _CHUNK):
        block = np.asarray(source[lo:lo + _CHUNK])
        for k, g in enumerate(groups):
            energy[lo:lo + _CHUNK, :, k] = block[:, :, g].sum(axis=2, dtype=np.float64)
    settings = dict(field_.settings, bands=OCTAVE, octaves_from="third-octave")
    if "air_attenuation_per_m" in settings:
        # The octave's exact mid-band frequency is its centre third's.
        settings["air_attenuation_per_m"] = [settings["air_attenuation_per_m"][g[1]]
                                             for g in groups.tolist()]
    return with_source_energy(SoundField(**{
        **field_.__dict__, "energy": energy, "per_source": None,
        "bands_hz": np.array(octaves.nominal_hz, dtype=np.float64),
        "counts": None, "settings": settings, "early": None, "path": None,
        "theory": _octave_theory(field_.theory, groups.tolist(), list(octaves.nominal_hz))}),
        energy)


def _octave_theory(theory: dict[str, Any] | None, groups: list[list[int]],
                   octaves_hz: list[float]) -> dict[str, Any] | None:
    """The theory of the summed octaves: mean absorption the mean of the thirds' (ISO 11654);
    the slowest decay bound from the least absorbing third and its air; Sabine's and Eyring's
    T60 of the sum of three exponential decays of equal start (a flat source spectrum), read
    between −5 and −35 dB of its Schroeder curve."""
    if theory is None:
        return None
    out = dict(theory, bands_hz=octaves_hz, bands=OCTAVE)

    def per_octave(key, how):
        v = theory.get(key)
        return None if v is None else [how([v[i] for i in g]) for g in groups]

    out["mean_absorption"] = per_octave("mean_absorption", lambda x: float(np.mean(x)))
    out["min_absorption"] = per_octave("min_absorption", min)
    out["air_attenuation_per_m"] = per_octave("air_attenuation_per_m", min)
    for key in ("sabine_t60_s", "eyring_t60_s"):
        out[key] = per_octave(key, _summed_t60)
    return out


def _summed_t60(t60s: list[float | None]) -> float | None:
    """T60 of E(t) = Σ_i exp(−13.82 t / T_i), read from its Schroeder curve between −5 and
    −35 dB (as T30 is): 2 (t_−35 − t_−5). None when a third never decays."""
    if any(t is None or not math.isfinite(t) for t in t60s):
        return None
    k = np.array([6.0 * math.log(10.0) / t for t in t60s])  # energy decay rates, 1/s

    def level_db(t: float) -> float:
        # Schroeder integral ∫_t^∞ E = Σ exp(−k t)/k, relative to its value at 0.
        return 10.0 * math.log10(float(np.sum(np.exp(-k * t) / k) / np.sum(1.0 / k)))

    def time_at(level: float) -> float:
        lo, hi = 0.0, 10.0 * max(t60s)
        for _ in range(200):  # bisection to far below a microsecond
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if level_db(mid) > level else (lo, mid)
        return 0.5 * (lo + hi)

    a, b = (time_at(level) for level in _T30_LEVELS_DB)
    return 2.0 * (b - a)


__all__ = ["octave_field"]
