"""The parsers of the values the commands share: X,Y and X,Y,Z in metres, WxH in pixels, ray
counts, ray ranges, times and ports. Each turns bad text into an argparse error that names what
was given and what is allowed (argparse prints it with the option's name and exits 2)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from sonolux.errors import number_allowed, range_text
from sonolux.limits import MAX_EXPOSURE_EV, MAX_GAIN_DB, MAX_RAYS, MAX_SEED


def _floats(text: str, n: int, what: str, example: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r} is not {what} in metres (finite numbers, "
                                         f"e.g. {example})")
    return values


def add_level_options(p: argparse.ArgumentParser) -> None:
    """The level of a written response or auralization (:func:`sonolux.audio.set_level`)."""
    g = p.add_argument_group("level (default: the peak normalised to -1 dBFS, gain printed)")
    g.add_argument("--normalize", action="store_true",
                   help="normalise the peak to -1 dBFS (the default; overrides the others)")
    g.add_argument("--calibrated", action="store_true",
                   help="keep the field's pressure units (comparable between files); a peak "
                        "above full scale is kept in float files with a warning")
    g.add_argument("--gain-db", type=gain_db, default=None, metavar="DB",
                   help="calibrated, times this gain in dB")
    g.add_argument("--allow-over-full-scale", action="store_true",
                   help="the old name of --calibrated")


def xy(text: str) -> tuple[float, float]:
    """X,Y in metres, e.g. 3,1.25."""
    x, y = _floats(text, 2, "X,Y", "3,1.25")
    return x, y


def xyz(text: str) -> tuple[float, float, float]:
    """X,Y,Z in metres, e.g. 0.3,1.25,1.5."""
    x, y, z = _floats(text, 3, "X,Y,Z", "0.3,1.25,1.5")
    return x, y, z


def size_px(text: str) -> tuple[int, int]:
    """WIDTHxHEIGHT in pixels (their range is the camera's to check)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        w = h = 0
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT in pixels, each from 1 "
                                         "to 16384 (e.g. 960x540)")
    return w, h


def _to_number(text: str, integer: bool) -> float | int | None:
    """The number in ``text``; for an integer, a whole float such as ``1e6`` is taken too."""
    text = text.strip()
    try:
        return int(text)
    except ValueError:
        pass
    try:
        v = float(text)
    except ValueError:
        return None
    if integer:
        return int(v) if math.isfinite(v) and v == int(v) else None
    return v


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
           hi_open: bool = False, integer: bool = False,
           unit: str = "") -> Callable[[str], float | int]:
    """An argparse ``type``: a finite number (a whole one if ``integer``) within the bounds.

    The test is :func:`sonolux.errors.number_allowed`, the same as for scene keys and API
    settings; argparse prints the message after the option's name and exits 2::

        sonolux: error: argument --heading: 'nan' is not allowed: a number in [-36000, 36000] degrees
    """
    allowed = range_text(lo, hi, lo_open, hi_open, "an integer" if integer else "a number")
    allowed += f" {unit}" if unit else ""

    def parse(text: str) -> float | int:
        v = _to_number(text, integer)
        if v is None or not number_allowed(v, lo, hi, lo_open, hi_open, integer):
            raise argparse.ArgumentTypeError(f"{text!r} is not allowed: {allowed}")
        return v

    parse.__name__ = "integer" if integer else "number"
    parse.bounds = (lo, hi, lo_open, hi_open, integer)  # type: ignore[attr-defined]  (for tests)
    return parse


#: A seed of the random numbers: the core's u64.
seed = number(0, MAX_SEED, integer=True)
#: An angle in degrees around the vertical (any finite turn, within a hundred turns).
heading_deg = number(-36000.0, 36000.0, unit="degrees")
#: Stops added to an automatic exposure.
exposure_ev = number(-MAX_EXPOSURE_EV, MAX_EXPOSURE_EV, unit="EV")
#: A gain in dB.
gain_db = number(-MAX_GAIN_DB, MAX_GAIN_DB, unit="dB")


def rays(text: str) -> int | str:
    """A ray or particle count from 1 to MAX_RAYS (1e6 and 2e5 are fine), or 'auto'."""
    if text == "auto":
        return text
    value = _to_number(text, integer=True)
    if value is None or not 1 <= value <= MAX_RAYS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a ray count: a whole number from 1 "
                                         f"to {MAX_RAYS:.0e} or 'auto'")
    return value


_SIZE_UNITS = {"": 1, "B": 1, "K": 10**3, "KB": 10**3, "M": 10**6, "MB": 10**6, "G": 10**9,
               "GB": 10**9, "T": 10**12, "TB": 10**12}


def memory_size(text: str) -> int:
    """A memory budget: bytes, or a number with K, M, G or T (powers of 1000), e.g. 8G or 500MB;
    from 1 MB to 1000 TB."""
    t = text.strip().upper()
    digits = t.rstrip("KMGTB")
    unit = t[len(digits):]
    value = _to_number(digits, integer=False) if digits else None
    if value is None or unit not in _SIZE_UNITS or not math.isfinite(value):
        value = -1.0
    size = value * _SIZE_UNITS.get(unit, 0)
    if not 1e6 <= size <= 1e18:
        raise argparse.ArgumentTypeError(f"{text!r} is not a memory size: bytes or a number with "
                                         "K, M, G or T (e.g. 8G, 500M), from 1M to 1000T")
    return int(size)


def ray_range(text: str) -> tuple[int, int]:
    """FIRST:END, 0 <= FIRST < END."""
    try:
        a, b = (int(v) for v in text.split(":"))
    except ValueError:
        a = b = -1
    if not 0 <= a < b <= MAX_RAYS:
        raise argparse.ArgumentTypeError(f"{text!r} is not FIRST:END with 0 <= FIRST < END "
                                         "(e.g. 0:500000)")
    return a, b


def seconds(text: str) -> float:
    """A time in seconds > 0."""
    try:
        v = float(text)
    except ValueError:
        v = -1.0
    if not (math.isfinite(v) and 0 < v <= 3600):
        raise argparse.ArgumentTypeError(f"{text!r} is not a time in seconds in (0, 3600]")
    return v


def port(text: str) -> int:
    """A TCP port, 0 (any free) to 65535."""
    try:
        v = int(text)
    except ValueError:
        v = -1
    if not 0 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number in 0..65535 (0: any free)")
    return v


def speech_dba(text: str) -> float:
    """A talker's A-weighted speech level at 1 m, 0..130 dB(A)."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not 0.0 <= v <= 130.0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a speech level from 0 to 130 dB(A) at "
                                         "1 m (60 normal, 66 raised, 72 loud; IEC 60268-16 J.3)")
    return v


def octave_levels_db(text: str) -> tuple[float, ...]:
    """Background noise per octave 125 Hz … 8 kHz in dB SPL: one level for all, or seven."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) not in (1, 7) or not all(-50.0 <= v <= 150.0 for v in values):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a noise level: one level in dB SPL from -50 to 150 for every "
            "octave 125 Hz … 8 kHz, or seven separated by commas (e.g. 45,40,35,30,25,20,15)")
    return values * 7 if len(values) == 1 else values


def source(text: str) -> tuple[str, float | None]:
    """``--source NAME|INDEX[=GAIN_DB]`` (:func:`sonolux.sound.pick.parse_spec`); whether the
    name is in the field is checked once the field is open."""
    from sonolux.errors import SonoluxError
    from sonolux.sound.pick import parse_spec

    try:
        return parse_spec(text)
    except SonoluxError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_source_option(p: argparse.ArgumentParser) -> None:
    """``--source``: which of a field's sources to use (repeat it to mix)."""
    p.add_argument("--source", type=source, action="append", default=[],
                   metavar="NAME[=DB]",
                   help="the source to hear, by name or index (default: every source, as "
                        "baked); repeat it, with NAME=GAIN_DB, to mix sources (those not named "
                        "are left out)")
