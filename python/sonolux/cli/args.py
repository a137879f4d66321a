"""The parsers of the values the commands share: X,Y and X,Y,Z in metres, WxH in pixels, ray
counts, ray ranges, times and ports. Each turns bad text into an argparse error that names what
was given and what is allowed (argparse prints it with the option's name and exits 2)."""

from __future__ import annotations

import argparse
import math


def _floats(text: str, n: int, what: str, example: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r} is not {what} in metres (finite numbers, "
                                         f"e.g. {example})")
    return values


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
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT in pixels "
                                         "(e.g. 960x540)") from None
    return w, h


#: The largest ray or particle count a command accepts (a bake of this many rays takes days).
MAX_RAYS = 10**12


def rays(text: str) -> int | str:
    """A ray or particle count from 1 to MAX_RAYS (1e6 and 2e5 are fine), or 'auto'."""
    if text == "auto":
        return text
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value == int(value) and 1 <= value <= MAX_RAYS):
        raise argparse.ArgumentTypeError(f"{text!r} is not a ray count: a whole number from 1 "
                                         f"to {MAX_RAYS:.0e} or 'auto'")
    return int(value)


def ray_range(text: str) -> tuple[int, int]:
    """FIRST:END, 0 <= FIRST < END."""
    try:
        a, b = (int(v) for v in text.split(":"))
    except ValueError:
        a = b = -1
    if not 0 <= a < b:
        raise argparse.ArgumentTypeError(f"{text!r} is not FIRST:END with 0 <= FIRST < END "
                                         "(e.g. 0:500000)")
    return a, b


def seconds(text: str) -> float:
    """A time in seconds > 0."""
    try:
        v = float(text)
    except ValueError:
        v = -1.0
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a time in seconds > 0")
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
