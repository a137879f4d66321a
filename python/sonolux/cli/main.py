"""The ``sonolux`` command: the parser of every subcommand (each family of commands adds its
own, see :mod:`sonolux.cli`) and what happens to errors.

No traceback reaches the user: a :class:`~sonolux.errors.SonoluxError` is printed as
``sonolux: error: <message>`` with exit status 2; Ctrl-C exits with 130; anything else is a
bug of sonolux and is reported as one (set ``SONOLUX_DEBUG=1`` to see the traceback).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence

from sonolux.cli import light, listen, measure, scene
from sonolux.errors import SonoluxError
from sonolux.version import __version__

EXIT_USAGE = 2  # argparse's status for a bad command line, and ours for a bad scene
EXIT_BUG = 1
EXIT_INTERRUPTED = 130


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sonolux",
        description="One particle tracer for light and sound: see and hear a virtual space.")
    parser.add_argument("--version", action="version", version=f"sonolux {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for family in (scene, light, measure, listen):
        family.add_commands(sub)
    return parser


def _run(func: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    try:
        return func(args)
    except SonoluxError as exc:
        print(f"sonolux: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("sonolux: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `sonolux check x | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    except Exception as exc:  # a bug of sonolux, not of the user's input
        if os.environ.get("SONOLUX_DEBUG"):
            raise
        print(f"sonolux: internal error: {type(exc).__name__}: {exc} (this is a bug of sonolux;"
              " run with SONOLUX_DEBUG=1 to see where)", file=sys.stderr)
        return EXIT_BUG


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sonolux`` command; returns the exit status."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    return _run(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
