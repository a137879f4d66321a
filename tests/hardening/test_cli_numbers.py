"""Every number a command takes, found by walking the parser (so a new option is covered
without being listed here): bad text for each (NaN, infinities, overflow, words, empty, out of
range on either side, a fraction where a whole number is needed) is exit status 2 and one line
naming the option and the value; and, as a property, any text either parses to a value within
the option's bounds or is refused in that way."""

from __future__ import annotations

import argparse
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sonolux.cli import args as parse
from sonolux.cli.app import build_parser

from .conftest import assert_usage_error, run

#: Enough of each command that argparse reaches the option under test.
TEMPLATES = {
    "check": ["paper-small"],
    "bake": ["paper-small", "-o", "x.h5"],
    "info": ["f.h5"],
    "ir": ["f.h5", "--at", "1,1", "-o", "x.wav"],
    "experiment": [],
    "render": ["f.h5", "-o", "x.png"],
    "export": ["f.h5", "--web", "d"],
    "params": ["f.h5"],
    "report": ["f.h5", "-o", "r"],
    "auralize": ["f.h5", "builtin:speech", "--at", "1,1", "-o", "x.wav"],
    "serve": ["f.h5"],
    "merge": ["a.h5", "b.h5", "-o", "m.h5"],
    "maps": ["f.h5", "-o", "m.png"],
    "film": ["f.h5", "--path", "walk.csv", "-o", "film.mp4"],
}

#: The shared parsers that take more than one number, and text each must refuse.
SHAPED = {
    parse.xy: ["nan,1", "1,inf", "1", "1,2,3", "a,b", "1e400,0", "", ",", "1;2"],
    parse.xyz: ["nan,1,1", "1,2", "1,2,3,4", "x,y,z", "1,-inf,0", ""],
    parse.size_px: ["0x10", "10x0", "-5x5", "axb", "100000x10", "10", "1.5x2", "nanxnan"],
    parse.rays: ["0", "-1", "1.5", "inf", "nan", "1e13", "lots", "", "auto2"],
    parse.ray_range: ["5:5", "6:5", "-1:5", "a:b", "1", "0:1e20", "0:10000000000000"],
    parse.seconds: ["0", "-1", "nan", "inf", "1e9", "x"],
    parse.port: ["-1", "65536", "x", "1.5", "99999999"],
}


def number_options():
    """(command, option, parse function) for every option whose type is one of ours."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for command, parser in sub.choices.items():
        for action in parser._actions:
            kind = action.type
            if action.option_strings and (hasattr(kind, "bounds") or kind in SHAPED):
                yield command, action.option_strings[-1], kind


def bad_numbers(bounds) -> list[str]:
    lo, hi, lo_open, hi_open, integer = bounds
    out = ["nan", "inf", "-inf", "1e400", "ten", "", "1,2", "0x10"]
    if lo is not None:
        out += [repr(lo - max(1, abs(lo))), str(lo) if lo_open else repr(lo - 1e-3 * max(1, abs(lo)))]
    if hi is not None:
        out += [repr(hi * 2 + 1), str(hi) if hi_open else repr(hi + 1e-3 * max(1, abs(hi)))]
    if integer:
        out += ["1.5", "2.000001"]
    return [v for v in dict.fromkeys(out) if not _allowed(v, bounds)]


def _allowed(text: str, bounds) -> bool:
    try:
        parse.number(*bounds[:2], lo_open=bounds[2], hi_open=bounds[3], integer=bounds[4])(text)
        return True
    except argparse.ArgumentTypeError:
        return False


CASES = [(command, option, value)
         for command, option, kind in number_options()
         for value in (bad_numbers(kind.bounds) if hasattr(kind, "bounds") else SHAPED[kind])]


def test_every_command_has_a_template():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) <= set(TEMPLATES)


def test_every_command_has_its_numbers_covered():
    commands = {c for c, _, _ in CASES}
    assert {"bake", "ir", "render", "export", "auralize", "serve"} <= commands
    assert len(CASES) >= 150


@pytest.mark.parametrize(("command", "option", "value"), CASES,
                         ids=[f"{c} {o} {v!r}" for c, o, v in CASES])
def test_a_bad_number_is_a_one_line_usage_error(capsys, command, option, value):
    code, out, err = run(capsys, command, *TEMPLATES[command], f"{option}={value}")
    assert out == ""
    assert_usage_error(code, err, option, repr(value))


@pytest.mark.parametrize(("command", "option"), sorted({(c, o) for c, o, k in number_options()
                                                        if hasattr(k, "bounds")}))
@given(text=st.one_of(st.text(max_size=12),
                      st.floats(allow_nan=True, allow_infinity=True).map(repr),
                      st.integers(min_value=-(10**30), max_value=10**30).map(str)))
def test_any_text_is_a_value_in_bounds_or_refused(command, option, text):
    kind = next(k for c, o, k in number_options() if (c, o) == (command, option))
    lo, hi, lo_open, hi_open, integer = kind.bounds
    try:
        v = kind(text)
    except argparse.ArgumentTypeError as exc:
        assert repr(text) in str(exc) and "\n" not in str(exc)
        return
    assert isinstance(v, int) if integer else math.isfinite(v)
    assert lo is None or (v > lo if lo_open else v >= lo)
    assert hi is None or (v < hi if hi_open else v <= hi)


BAD_CHOICES = [(command, action.option_strings[-1])
               for command, parser in next(
                   a for a in build_parser()._actions
                   if isinstance(a, argparse._SubParsersAction)).choices.items()
               for action in parser._actions if action.option_strings and action.choices]


@pytest.mark.parametrize(("command", "option"), BAD_CHOICES)
def test_a_bad_choice_is_a_one_line_usage_error(capsys, command, option):
    code, _, err = run(capsys, command, *TEMPLATES[command], f"{option}=nonsense")
    assert_usage_error(code, err, option, "nonsense")


@pytest.mark.parametrize("argv", [[], ["nonsense"], ["bake"], ["ir", "f.h5"], ["bake", "x", "--frobnicate"],
                                  ["render"], ["auralize", "f.h5", "dry.wav", "-o", "x.wav"]])
def test_a_bad_command_line_is_one_line(capsys, argv):
    code, _, err = run(capsys, *argv)
    assert_usage_error(code, err)
