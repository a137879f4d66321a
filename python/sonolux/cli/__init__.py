"""The ``sonolux`` command line: thin shells over the library, one module per family.

- :mod:`~sonolux.cli.app`: the parser and the error handling (:func:`main` here loads it);
- :mod:`~sonolux.cli.args`: parsers of the values the commands share (X,Y, counts, ranges);
- :mod:`~sonolux.cli.failures`: one line for every way a run can fail (signals, crash logs);
- :mod:`~sonolux.cli.scene`: ``check``, ``bake``, ``info``, ``ir``, ``experiment``;
- :mod:`~sonolux.cli.spread`: the checkpoint, resume and Dask flags of ``bake``; ``merge``;
- :mod:`~sonolux.cli.light`: ``render`` and ``export`` (glTF and the web bundle);
- :mod:`~sonolux.cli.measure`: ``params`` and ``report``;
- :mod:`~sonolux.cli.listen`: ``auralize`` and ``serve``.

Nothing in the library imports this package. Importing it loads nothing heavy: :func:`main`
imports the commands itself, so that Ctrl-C while they load is answered like any other.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sonolux`` command; returns the exit status."""
    from sonolux.cli.failures import interrupted

    try:
        from sonolux.cli.app import main as run
    except BaseException as exc:  # noqa: BLE001
        if not interrupted(exc):
            raise
        # Ctrl-C while the commands load (an extension module may wrap it in its own error):
        # nothing was written yet.
        print("sonolux: interrupted", file=sys.stderr, flush=True)
        # Exit at once: an interrupt inside an extension module's import can leave the
        # interpreter to re-raise it at exit (status -2 instead of 130).
        os._exit(130)
    return run(argv)


__all__ = ["main"]
