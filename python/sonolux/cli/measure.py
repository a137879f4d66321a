"""The measuring commands: ``params`` (ISO 3382-1 parameters of a sound field) and ``report``
(a static HTML report of one or more fields)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sonolux.cli import args as parse


def cmd_params(args: argparse.Namespace) -> int:
    from sonolux.analysis.params import room_parameters
    from sonolux.analysis.tables import format_cell, format_grid, to_json
    from sonolux.fieldfile import open_field

    field = open_field(args.field)
    title = f"ISO 3382-1 parameters of {field.scene_name} ({args.field})"
    if args.at is not None:
        r = field.cell_at(*args.at)
        p = room_parameters(field, [r], directional=True)
        text = format_cell(p, title)
    else:
        p = room_parameters(field)
        text = format_grid(p, title)
    if args.json:
        print(json.dumps(to_json(p, field_path=str(args.field), scene=field.scene_name),
                         indent=1, ensure_ascii=False))
    else:
        print(text)
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from sonolux.report.build import ReportOptions, build_report

    options = ReportOptions(at=args.at, light_images=[Path(p) for p in args.light_image],
                            audio=[Path(p) for p in args.audio], auralize=args.auralize,
                            title=args.title)
    index = build_report([Path(f) for f in args.fields], Path(args.output), options,
                         log=lambda m: print(f"sonolux: {m}", file=sys.stderr))
    print(f"report -> {index}  (open it in any browser: file://{index.resolve()})")
    return 0


def add_commands(sub) -> None:
    """Adds ``params`` and ``report`` to the subcommand table ``sub``."""
    params = sub.add_parser(
        "params", help="ISO 3382-1 room-acoustic parameters of a sound field",
        description="EDT, T20, T30, C50, C80, D50, Ts, G and the early lateral energy fraction "
                    "(JLF, JLFC) per band and broadband, beside Sabine and Eyring: over the "
                    "whole grid (mean, min, max), or for the cell at X,Y with its directions.")
    params.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    params.add_argument("--at", type=parse.xy, default=None, metavar="X,Y",
                        help="one cell (position in metres) instead of the whole grid")
    params.add_argument("--json", action="store_true", help="print machine-readable JSON")
    params.set_defaults(func=cmd_params)

    report = sub.add_parser(
        "report", help="a static HTML report of one or more sound fields",
        description="Write an HTML page (with its PNG figures beside it, no external files) "
                    "of the scene, the bake's statistics, the parameter tables, impulse "
                    "responses, decay curves, parameter maps, the light view and audio.")
    report.add_argument("fields", metavar="FIELD", nargs="+", help="field files (.h5)")
    report.add_argument("-o", "--output", required=True, help="the report folder to write")
    report.add_argument("--at", type=parse.xy, default=None, metavar="X,Y",
                        help="the cell whose responses are shown (default: the source's cell)")
    report.add_argument("--light-image", action="append", default=[], metavar="PNG",
                        help="a rendered view to show (one per field, in order)")
    report.add_argument("--audio", action="append", default=[], metavar="WAV",
                        help="an auralization to offer as an audio player (repeatable)")
    report.add_argument("--auralize", action="store_true",
                        help="auralize a built-in dry signal at the cell (binaural, cube8)")
    report.add_argument("--title", default=None, help="the page's title")
    report.set_defaults(func=cmd_report)
