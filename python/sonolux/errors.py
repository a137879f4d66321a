"""The exceptions of the sonolux Python package.

Every error that a user can cause by what they hand in (a scene file, a dict, a name, a field
file, a setting) is a :class:`SonoluxError`, those raised by the compiled core included (it
raises :class:`InvalidInputError` and :class:`GeometryError`, defined here). The command
line turns each one into a single line, ``sonolux: error: <message>``, so the message must
stand on its own: it names the file, the line when known, the dotted key, the value and what
would have been allowed.

:class:`SceneError` is the error of the scene layer. Its ``str()`` is one sentence::

    scene.toml:12: materials.wall.absorption[3] = 1.2 is not allowed: a number in [0, 1]
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from typing import Any


class SonoluxError(Exception):
    """Base class of every error that sonolux reports to a user (never a bug of sonolux)."""


class EngineError(SonoluxError):
    """The engine (the compiled core, reached through :mod:`sonolux.engine`) refused what it was
    handed; the message starts with the name of the input at fault."""


class InvalidInputError(EngineError, ValueError):
    """An array or setting handed to the engine is malformed or out of range (raised by the
    compiled core itself, which takes this class from here when it is imported)."""


class GeometryError(EngineError, ValueError):
    """The engine cannot use the geometry as it is (raised by the compiled core)."""


class CoreMissingError(SonoluxError):
    """The compiled core (``sonolux._core``) is not built or cannot be imported."""


class FieldFileError(SonoluxError):
    """A field file that cannot be read or written as asked; the message names the file."""


class AnalysisError(SonoluxError, ValueError):
    """Data that the analysis cannot take (an empty selection, a malformed histogram)."""


class SettingError(SonoluxError, ValueError):
    """A setting given on the command line or to the API that is not allowed; the message
    names the setting, the value given and what is allowed (see :func:`check_number`)."""


class OutputError(SonoluxError):
    """An output that cannot be written where it was asked (a missing or read-only folder, a
    full disk); the message names the file."""


class MemoryLimitError(SonoluxError):
    """A run refused before it allocates: the estimate, what the machine has, and the settings
    that drive it (see :mod:`sonolux.memory`)."""


class DamagedFileError(SonoluxError):
    """An input file that exists but cannot be read as what it claims to be (truncated,
    damaged, the wrong kind, or holding values outside what it may hold)."""


def interval_text(lo: float | None, hi: float | None, lo_open: bool = False,
                  hi_open: bool = False) -> str:
    """``in [0, 1]``, ``> 0``, ``in (0, 180]``, ``<= 5``; empty without bounds."""
    def g(x: float) -> str:
        return str(x) if isinstance(x, int) else f"{x:g}"
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{g(lo)}, {g(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {g(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {g(hi)}"
    return ""


def range_text(lo: float | None, hi: float | None, lo_open: bool = False,
               hi_open: bool = False, what: str = "a number") -> str:
    """``a number in [0, 1]``, ``an integer >= 0``, ``a finite number``..."""
    interval = interval_text(lo, hi, lo_open, hi_open)
    if interval:
        return f"{what} {interval}"
    return "a finite " + what.split(" ", 1)[1]


def number_allowed(v: Any, lo: float | None = None, hi: float | None = None,
                   lo_open: bool = False, hi_open: bool = False, integer: bool = False) -> bool:
    """Whether ``v`` is a number (not a bool), finite, whole when ``integer``, within the bounds.

    The one test behind every number a user gives: scene keys (:mod:`sonolux.scene.schema`),
    command-line values (:mod:`sonolux.cli.args`) and API settings (:func:`check_number`).
    numpy scalars count as numbers; a float that is whole (``3.0``) is not an integer.
    """
    if isinstance(v, bool) or not isinstance(v, (int, float)) and not _is_numpy_number(v):
        return False
    if integer and not (isinstance(v, int) or _is_numpy_integer(v)):
        return False
    if not integer and not math.isfinite(float(v)):
        return False
    if lo is not None and (v <= lo if lo_open else v < lo):
        return False
    return not (hi is not None and (v >= hi if hi_open else v > hi))


def _is_numpy_number(v: Any) -> bool:
    kind = getattr(getattr(v, "dtype", None), "kind", None)
    return getattr(v, "ndim", None) == 0 and kind in ("i", "u", "f")


def _is_numpy_integer(v: Any) -> bool:
    return _is_numpy_number(v) and v.dtype.kind in ("i", "u")


def check_number(name: str, v: Any, lo: float | None = None, hi: float | None = None, *,
                 lo_open: bool = False, hi_open: bool = False, integer: bool = False,
                 none_ok: bool = False, unit: str = "") -> Any:
    """``v`` as an int or float if :func:`number_allowed`, else a :class:`SettingError`
    ``NAME = VALUE is not allowed: an integer in [1, 64]``. ``None`` passes when ``none_ok``."""
    if v is None and none_ok:
        return None
    if number_allowed(v, lo, hi, lo_open, hi_open, integer):
        return int(v) if integer else float(v)
    allowed = range_text(lo, hi, lo_open, hi_open, "an integer" if integer else "a number")
    if unit:
        allowed += f" {unit}"
    raise SettingError(f"{name} = {format_value(v)} is not allowed: {allowed}")


_MISSING = object()


def close_matches(word: str, candidates: Iterable[str], n: int = 3) -> list[str]:
    """The candidates closest to ``word`` (difflib ratio >= 0.6), best first."""
    return difflib.get_close_matches(str(word), sorted(set(candidates)), n=n, cutoff=0.6)


def format_value(value: Any, limit: int = 60) -> str:
    """A short TOML-like rendering of a user value for messages."""

    def render(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, float):
            if math.isnan(v):
                return "nan"
            if math.isinf(v):
                return "inf" if v > 0 else "-inf"
            return repr(v)
        if isinstance(v, int):
            return str(v)
        if isinstance(v, str):
            text = v.replace("\\", "\\\\").replace('"', '\\"')
            return '"' + "".join(c if c.isprintable() else repr(c)[1:-1] for c in text) + '"'
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {render(x)}" for k, x in v.items()) + "}"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(render(x) for x in v) + "]"
        if hasattr(v, "tolist"):  # numpy arrays and scalars
            return render(v.tolist())
        return str(v)

    text = render(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class SceneError(SonoluxError):
    """A scene that cannot be loaded as given.

    Attributes:
        file: where the scene came from: a path, ``"<dict>"`` or ``"built-in NAME"``.
        key: dotted path of the offending entry, e.g. ``materials.wall.absorption[3]`` or
            ``geometry[0].file``; ``None`` for a problem of the whole file (a syntax error).
        value: the offending value as given (``None`` when the key is missing).
        allowed: what would have been accepted, as text.
        line: 1-based line in the file, when known.
        matches: close matches of an unknown name, best first.
        message: replaces the ``"KEY = VALUE is not allowed: ALLOWED"`` sentence when the
            problem is not one value (a syntax error, a missing key, a mesh without volume).
    """

    def __init__(
        self,
        file: str,
        key: str | None = None,
        value: Any = _MISSING,
        allowed: str = "",
        *,
        line: int | None = None,
        matches: Iterable[str] = (),
        message: str | None = None,
    ) -> None:
        self.file = file
        self.key = key
        self.value = None if value is _MISSING else value
        self._has_value = value is not _MISSING
        self.allowed = allowed
        self.line = line
        self.matches = list(matches)
        self.message = message
        super().__init__(str(self))

    @property
    def where(self) -> str:
        """``file`` or ``file:line``."""
        return f"{self.file}:{self.line}" if self.line else self.file

    def __str__(self) -> str:
        if self.message is not None:
            body = f"{self.key}: {self.message}" if self.key else self.message
        elif self._has_value:
            body = f"{self.key} = {format_value(self.value)} is not allowed"
            if self.allowed:
                body += f": {self.allowed}"
        else:
            body = f"{self.key} is required"
            if self.allowed:
                body += f": {self.allowed}"
        if self.matches:
            body += "; did you mean " + " or ".join(f'"{m}"' for m in self.matches) + "?"
        return f"{self.where}: {body}"

    def __reduce__(self):  # keep the error picklable (multiprocessing, pytest-xdist)
        return (_rebuild_scene_error, (self.__dict__.copy(),))


def _rebuild_scene_error(state: dict) -> SceneError:
    err = SceneError.__new__(SceneError)
    err.__dict__.update(state)
    Exception.__init__(err, str(err))
    return err
