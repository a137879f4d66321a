"""The ``sonolux`` command: the parser of every subcommand (each family of commands adds its
own, see :mod:`sonolux.cli`) and what happens to errors.

No traceback reaches the user: a :class:`~sonolux.errors.SonoluxError` (and a file system
that refused, an :class:`OSError`) is printed as one line, ``sonolux: error: <message>``, with
exit status 2; Ctrl-C exits with 130 and SIGTERM with 143, after the outputs being written were
removed (:mod:`sonolux.outputs`); anything else is a bug of sonolux: one line on screen and the
traceback in a log file (``SONOLUX_DEBUG=1`` raises it instead).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence

from sonolux.cli import light, listen, measure, scene, spread
from sonolux.cli.failures import (
    ISSUES_URL,
    Terminated,
    describe_os_error,
    interrupted,
    one_line,
    stop_on_sigterm,
    write_crash_log,
)
from sonolux.errors import SonoluxError
from sonolux.version import __version__

EXIT_USAGE = 2  # argparse's status for a bad command line, and ours for a bad scene
EXIT_BUG = 1
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # 128 + SIGTERM


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``sonolux bake: error: argument --rays: ...`` and where
    to find the usage, instead of the whole usage block before it; exit status 2."""

    def error(self, message: str):  # type: ignore[override]
        one = " ".join(message.split())
        self.exit(EXIT_USAGE, f"{self.prog}: error: {one} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="sonolux",
        description="One particle tracer for light and sound: see and hear a virtual space.")
    parser.add_argument("--version", action="version", version=f"sonolux {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for family in (scene, spread, light, measure, listen):
        family.add_commands(sub)
    return parser


def _run(func: Callable[[argparse.Namespace], int], args: argparse.Namespace) -> int:
    try:
        with stop_on_sigterm():
            return func(args)
    except SonoluxError as exc:
        print(f"sonolux: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("sonolux: interrupted (no partial output was kept)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Terminated:
        print("sonolux: terminated (no partial output was kept)", file=sys.stderr)
        return EXIT_TERMINATED
    except BrokenPipeError:  # `sonolux check x | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    except MemoryError:
        print("sonolux: error: this machine ran out of memory; ask for less (fewer rays, "
              "receivers, bands or pixels, a shorter max_time_s, larger patches)", file=sys.stderr)
        return EXIT_BUG
    except OSError as exc:  # a file system that refused: named, one line, not a bug
        print(f"sonolux: error: {describe_os_error(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # a bug of sonolux, not of the user's input
        if interrupted(exc):  # Ctrl-C wrapped by an extension module while it loaded
            print("sonolux: interrupted (no partial output was kept)", file=sys.stderr)
            return EXIT_INTERRUPTED
        if os.environ.get("SONOLUX_DEBUG"):
            raise
        log = write_crash_log(exc)
        print(f"sonolux: internal error: {type(exc).__name__}: {one_line(exc)} (this is a bug of "
              f"sonolux: please report it at {ISSUES_URL} with the log {log})", file=sys.stderr)
        return EXIT_BUG


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sonolux`` command; returns the exit status."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except SystemExit as done:  # --help, --version, or a usage error (printed, status 2)
        return done.code if isinstance(done.code, int) else EXIT_USAGE
    for name, value in vars(args).items():  # no file name or text can hold a NUL byte
        for text in value if isinstance(value, list) else [value]:
            if isinstance(text, str) and "\x00" in text:
                print(f"sonolux {args.command}: error: {name} = {text.split(chr(0))[0]!r}... "
                      "holds a NUL byte, which no file name or text may hold", file=sys.stderr)
                return EXIT_USAGE
    return _run(args.func, args)


if __name__ == "__main__":
    sys.exit(main())
