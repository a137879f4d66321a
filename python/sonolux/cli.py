"""The ``sonolux`` command line.

Subcommands (more, such as ``bake`` and ``render``, join the same table):

- ``sonolux check SCENE [--json]``: load a scene (a .toml file or a built-in name), check it
  and print what it contains and the reverberation times theory predicts.

No traceback reaches the user: a :class:`~sonolux.errors.SonoluxError` is printed as
``sonolux: error: <message>`` with exit status 2; Ctrl-C exits with 130; anything else is a
bug of sonolux and is reported as one (set ``SONOLUX_DEBUG=1`` to see the traceback).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence

from sonolux import __version__
from sonolux.errors import SonoluxError

EXIT_USAGE = 2  # argparse's status for a bad command line, and ours for a bad scene
EXIT_BUG = 1
EXIT_INTERRUPTED = 130


def cmd_check(args: argparse.Namespace) -> int:
    # Imported here, not at the top, so that `sonolux --help` stays fast.
    from sonolux.check import format_summary, summarize
    from sonolux.scene import load_scene

    summary = summarize(load_scene(args.scene))
    if args.json:
        print(json.dumps(summary, indent=2, ensure_ascii=False))
    else:
        print(format_summary(summary))
    return 0


def _xy(text: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y in metres (e.g. 3,1.25)") from None
    return x, y


def _rays(text: str) -> int | str:
    if text == "auto":
        return text
    try:
        n = int(float(text))
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a ray count ≥ 1 or 'auto'")
    return n


def _range(text: str) -> tuple[int, int]:
    try:
        a, b = (int(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not FIRST:END (e.g. 0:500000)") from None
    return a, b


def cmd_bake(args: argparse.Namespace) -> int:
    from sonolux.scene import load_scene
    from sonolux.sound.bake import bake
    from sonolux.sound.fieldfile import save
    from sonolux.sound.info import format_info

    scene = load_scene(args.scene)
    for w in scene.warnings:
        print(f"sonolux: warning: {w}", file=sys.stderr)
    field = bake(scene, rays=args.rays, estimator=args.estimator,
                 azimuth_bands=args.azimuth_bands, elevation_bands=args.elevation_bands,
                 ray_range=args.range, progress=not args.quiet,
                 log=lambda m: print(f"sonolux: {m}", file=sys.stderr))
    if field.stats.get("cancelled"):
        print("sonolux: stopped early: the field holds the rays traced so far", file=sys.stderr)
    path = save(field, args.output)
    print(format_info(field, path))
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from sonolux.sound.fieldfile import open_field
    from sonolux.sound.info import format_info, info

    field = open_field(args.field)
    if args.json:
        print(json.dumps(info(field), indent=2, ensure_ascii=False))
    else:
        print(format_info(field, args.field))
    return 0


def cmd_ir(args: argparse.Namespace) -> int:
    import numpy as np

    from sonolux.audio import write_wav
    from sonolux.sound.fieldfile import open_field

    field = open_field(args.field)
    r = field.cell_at(*args.at)
    direction = None if args.direction == "all" else args.direction
    ir = field.impulse_response(r, direction, seed=args.seed)
    write_wav(args.output, ir[:, None] if ir.ndim == 1 else ir, field.sample_rate_hz)
    print(f"impulse response of receiver #{r} at ({', '.join(f'{v:g}' for v in field.positions_m[r])}) m, "
          f"direction {args.direction}: {ir.shape[0] / field.sample_rate_hz:.3f} s, peak "
          f"{np.max(np.abs(ir)):.3g} -> {args.output}")
    return 0


def cmd_experiment(args: argparse.Namespace) -> int:
    from sonolux.experiment import run

    run(args.output, rays=args.rays, estimator=args.estimator)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sonolux",
        description="One particle tracer for light and sound: see and hear a virtual space.")
    parser.add_argument("--version", action="version", version=f"sonolux {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    check = sub.add_parser(
        "check", help="load a scene and report its geometry, materials and expected T60",
        description="Load a scene, report what it contains (triangles, materials and their "
                    "areas, volume, sources, lights, receivers) and the Sabine and Eyring "
                    "reverberation times per band, with air absorption.")
    check.add_argument("scene", metavar="SCENE",
                       help="a scene file (.toml) or a built-in scene name, e.g. paper-small")
    check.add_argument("--json", action="store_true", help="print machine-readable JSON")
    check.set_defaults(func=cmd_check)

    bake = sub.add_parser(
        "bake", help="trace the scene's sound into a sound field file",
        description="Trace an impulse from every sound source into a sound field over the "
                    "receiver grid: energy per receiver, direction, band and time, saved as HDF5.")
    bake.add_argument("scene", metavar="SCENE", help="a scene file (.toml) or a built-in name")
    bake.add_argument("-o", "--output", required=True, help="the field file to write (.h5)")
    bake.add_argument("--rays", type=_rays, default="auto",
                      help="rays per source, or 'auto' (printed with the reason); default auto")
    bake.add_argument("--estimator", choices=("rain", "paper"), default="rain",
                      help="rain: exact direct sound and diffuse rain (default); paper: the "
                           "paper's sphere receivers only")
    bake.add_argument("--azimuth-bands", type=int, default=8, help="azimuth sectors (default 8)")
    bake.add_argument("--elevation-bands", type=int, default=1,
                      help="elevation bands of equal solid angle (1, or 3 = below/level/above)")
    bake.add_argument("--range", type=_range, default=None, metavar="FIRST:END",
                      help="trace only rays FIRST..END of the bake (ranges merge exactly)")
    bake.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    bake.set_defaults(func=cmd_bake)

    inf = sub.add_parser("info", help="summarise a sound field file",
                         description="Summarise a sound field file: scene, settings, receivers, "
                                     "statistics and the energy balance.")
    inf.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    inf.add_argument("--json", action="store_true", help="print machine-readable JSON")
    inf.set_defaults(func=cmd_info)

    ir = sub.add_parser("ir", help="write a receiver's pressure impulse response as WAV",
                        description="Write the pressure impulse response of the cell at X,Y "
                                    "(one direction, or all directions summed) as a 32-bit "
                                    "float WAV file.")
    ir.add_argument("field", metavar="FIELD")
    ir.add_argument("--at", type=_xy, required=True, metavar="X,Y", help="position in metres")
    ir.add_argument("--direction", default="all",
                    help="a direction name (front, left, right, back, ...) or 'all' (default)")
    ir.add_argument("--seed", type=int, default=0, help="seed of the synthesized phases")
    ir.add_argument("-o", "--output", required=True, help="the WAV file to write")
    ir.set_defaults(func=cmd_ir)

    exp = sub.add_parser("experiment", help="the paper's three rooms, baked and compared",
                         description="Bake the paper's three rooms, print T30 of the central "
                                     "cell beside Sabine and Eyring and the ratios between rooms, "
                                     "and write figure 7 and the impulse responses.")
    exp.add_argument("-o", "--output", default="out/experiment", help="output folder")
    exp.add_argument("--rays", type=_rays, default="auto", help="rays per source (default auto)")
    exp.add_argument("--estimator", choices=("rain", "paper"), default="paper")
    exp.set_defaults(func=cmd_experiment)
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
