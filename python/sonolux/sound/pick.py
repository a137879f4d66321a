"""Which sources of a field a consumer hears: one source, or several mixed with gains in dB.

A spec is ``NAME`` or ``INDEX`` (the source alone) or ``NAME=GAIN_DB`` (the source in a mix,
its energy scaled by 10^(GAIN_DB/10)). No spec: every source as baked (their sum). One spec
without a gain: that source's field (:meth:`SoundField.for_source`). Otherwise a mix of the
named sources (:meth:`SoundField.mixed`), the others left out. Names are checked against the
field: an unknown one is an error naming the sources there are.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from sonolux.errors import SonoluxError
from sonolux.sound.field import SoundField

#: The gains a mix takes, dB (a source 120 dB down is silence at any level we write).
MIN_GAIN_DB, MAX_GAIN_DB = -120.0, 60.0


def parse_spec(text: str) -> tuple[str, float | None]:
    """``NAME`` or ``NAME=GAIN_DB`` -> (name, gain in dB or None); bad text is a SonoluxError
    naming what was given and what is allowed."""
    name, eq, gain = str(text).partition("=")
    if not name:
        raise SonoluxError(f"source {text!r} is not NAME, INDEX or NAME=GAIN_DB")
    if not eq:
        return name, None
    try:
        db = float(gain)
    except ValueError:
        db = math.nan
    if not (math.isfinite(db) and MIN_GAIN_DB <= db <= MAX_GAIN_DB):
        raise SonoluxError(f"source {text!r}: the gain {gain!r} is not a number of dB from "
                           f"{MIN_GAIN_DB:g} to {MAX_GAIN_DB:g}")
    return name, db


def pick_sources(field: SoundField, specs: Sequence[str | tuple[str, float | None]]) -> SoundField:
    """The field of the sources ``specs`` name (see the module's doc)."""
    parsed = [parse_spec(s) if isinstance(s, str) else s for s in specs]
    if not parsed:
        return field
    keys = [field.source_index(name) for name, _ in parsed]
    if len(set(keys)) != len(keys):
        raise SonoluxError("a source is named twice: "
                           + ", ".join(f"{n}" for n, _ in parsed))
    if len(parsed) == 1 and parsed[0][1] is None:
        return field.for_source(keys[0])
    gains = [0.0] * len(field.source_names)
    for k, (_, db) in zip(keys, parsed):
        gains[k] = 10.0 ** ((db or 0.0) / 10.0)
    return field.mixed(gains)


def describe(field: SoundField) -> str:
    """One line: the sources a field holds."""
    names = field.source_names
    if names == ["all"]:
        return "sources: all, summed (one field)"
    return "sources: " + ", ".join(f"{k} = {n}" for k, n in enumerate(names))


def heard(field: SoundField) -> str:
    """What a picked field holds, in words: "source desk", "mix of desk +0.0 dB, door -6.0 dB"
    or "all sources"."""
    mix = field.settings.get("mix")
    if mix:
        return "mix of " + ", ".join(f"{n} {10 * math.log10(g):+.1f} dB"
                                     for n, g in mix.items() if g > 0)
    name = field.source_names[0]
    return "all sources" if name == "all" else f"source {name}"
