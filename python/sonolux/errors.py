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
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
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
