"""The measuring commands: ``params`` (ISO 3382-1 parameters of a sound field), ``maps`` (light
and sound over one floor plan, with criteria) and ``report`` (a static HTML report of one or
more fields)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sonolux.analysis.joint import DEFAULT_CRITERIA
from sonolux.cli import args as parse


def cmd_params(args: argparse.Namespace) -> int:
    from sonolux.analysis.lateral import channel_groups
    from sonolux.analysis.params import room_parameters
    from sonolux.analysis.sti import speech_settings_of
    from sonolux.analysis.tables import format_cell, format_grid, to_json
    from sonolux.fieldfile import open_field
    from sonolux.sound.pick import heard, pick_sources

    field = pick_sources(open_field(args.field), args.source)
    title = f"ISO 3382-1 parameters of {field.scene_name} ({args.field})"
    if args.source:
        title += f", {heard(field)}"
    speech = speech_settings_of(field, args.speech_dba, args.noise_db)
    if args.octaves:
        from sonolux.analysis.octaves import octave_field

        field = octave_field(field)
        title += ", octaves summed from its third-octaves"
    if args.at is not None:
        r = field.cell_at(*args.at)
        p = room_parameters(field, [r], directional=True, compensation=args.compensation,
                            speech=speech)
        text = format_cell(p, title)
    else:
        p = room_parameters(field, compensation=args.compensation, speech=speech)
        text = format_grid(p, title)
        channels = channel_groups(field)
        if channels:  # directional channels: each channel's own table
            text = "\n\n".join(
                format_grid(room_parameters(field, idx, compensation=args.compensation,
                                            speech=speech), f"{title}, channel {name!r}")
                for name, idx in channels)
    if args.json:
        print(json.dumps(to_json(p, field_path=str(args.field), scene=field.scene_name),
                         indent=1, ensure_ascii=False))
    else:
        print(text)
    return 0


def _criterion(text: str):
    from sonolux.analysis.joint import Criterion
    from sonolux.errors import SonoluxError

    try:
        return Criterion.parse(text)
    except SonoluxError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cmd_maps(args: argparse.Namespace) -> int:
    import numpy as np

    from sonolux.analysis.joint import Criterion, joint_map
    from sonolux.analysis.params import room_parameters, scene_of
    from sonolux.fieldfile import contents, open_field, open_light_field
    from sonolux.plotting.joint import plot_joint_map
    from sonolux.plotting.maps import plan_section

    has = contents(args.field)
    sound = open_field(args.field) if has["sound"] else None
    light = open_light_field(args.field) if has["light"] else None
    params = None
    if sound is not None:
        from sonolux.analysis.sti import speech_settings_of

        params = room_parameters(sound, theory=False,
                                 speech=speech_settings_of(sound, args.speech_dba, args.noise_db))
    criteria = args.require if args.require else [Criterion.parse(t) for t in DEFAULT_CRITERIA]
    joint = joint_map(sound, params, light, [] if args.no_criteria else criteria)
    height = float(np.mean(joint.positions_m[:, 2]))
    if light is not None:
        outline = plan_section(light.vertices_m, light.triangles, height)
    else:
        scene, _ = scene_of(sound)
        outline = plan_section(scene.vertices_m, scene.triangles, height) if scene else None
    written = [plot_joint_map(joint, args.output, outline)]
    for path in (args.csv, args.json):
        if path:
            written.append(joint.write(path))
    summary = joint.summary()
    print(f"{joint.scene_name}: {summary['cells']} cells")
    for name, value in summary.items():
        if name.startswith("mean_") and value is not None:
            print(f"  mean {name[5:]:<24} {value:.3g}")
    for text, counts in summary["criteria"].items():
        print(f"  {text:<28} pass {counts['pass']:>5}  fail {counts['fail']:>5}  "
              f"undefined {counts['undefined']:>5}")
    for note in joint.notes:
        print(f"  note: {note}")
    print("-> " + ", ".join(str(p) for p in written))
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from sonolux.report.build import ReportOptions, build_report

    options = ReportOptions(at=args.at, light_images=[Path(p) for p in args.light_image],
                            audio=[Path(p) for p in args.audio], auralize=args.auralize,
                            title=args.title, sources=args.source)
    index = build_report([Path(f) for f in args.fields], Path(args.output), options,
                         log=lambda m: print(f"sonolux: {m}", file=sys.stderr))
    print(f"report -> {index}  (open it in any browser: file://{index.resolve()})")
    return 0


def _speech_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--speech-dba", type=parse.speech_dba, default=None, metavar="DBA",
                   help="for STI: the talker's speech level at 1 m in dB(A) (default: the "
                        "scene's [speech], else 60, normal vocal effort)")
    p.add_argument("--noise-db", type=parse.octave_levels_db, default=None, metavar="L[,L...]",
                   help="for STI: background noise per octave 125 Hz … 8 kHz in dB SPL, one "
                        "level or seven (default: the scene's [speech], else none)")


def add_commands(sub) -> None:
    """Adds ``params``, ``maps`` and ``report`` to the subcommand table ``sub``."""
    params = sub.add_parser(
        "params", help="ISO 3382-1 room-acoustic parameters of a sound field",
        description="EDT, T20, T30, C50, C80, D50, Ts, G and the early lateral energy fraction "
                    "(JLF, JLFC) per band and broadband, beside Sabine and Eyring, and the "
                    "speech transmission index (STI, IEC 60268-16) per receiver: over the "
                    "whole grid (mean, min, max), or for the cell at X,Y with its directions.")
    params.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    params.add_argument("--at", type=parse.xy, default=None, metavar="X,Y",
                        help="one cell (position in metres) instead of the whole grid")
    params.add_argument("--json", action="store_true", help="print machine-readable JSON")
    params.add_argument("--compensation", choices=("none", "lundeby"), default="none",
                        help="how decay curves treat the record's end: none (default; the "
                             "plain backward integral, right for simulated fields) or lundeby "
                             "(noise subtraction and truncation, for fields with a real noise "
                             "floor)")
    params.add_argument("--octaves", action="store_true",
                        help="of a third-octave field: the octaves its thirds make whole, each "
                             "the sum of its three thirds' energies (never averaged times)")
    _speech_options(params)
    parse.add_source_option(params)
    params.set_defaults(func=cmd_params)

    maps = sub.add_parser(
        "maps", help="light and sound over one floor plan, with the cells that fail criteria",
        description="One floor plan for both senses: illuminance (and daylight factor) on the "
                    "work plane beside STI, C50, G and T30 at the receivers (ISO 3382-1 single "
                    "numbers: the mean of 500 Hz and 1 kHz), with every cell that fails a "
                    "criterion flagged; a picture, and the cells as CSV or JSON.")
    maps.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    maps.add_argument("-o", "--output", required=True, metavar="PNG", help="the picture to write")
    maps.add_argument("--csv", default=None, metavar="FILE", help="also write the cells as CSV")
    maps.add_argument("--json", default=None, metavar="FILE", help="also write them as JSON")
    maps.add_argument("--require", type=_criterion, action="append", default=[],
                      metavar="NAME>=LIMIT",
                      help="a criterion (repeatable), NAME>=LIMIT or NAME<=LIMIT, NAME one of "
                           "illuminance_lx, daylight_factor_percent, sti, c50_db, c80_db, "
                           "d50, g_db, edt_s, t30_s (default: " + ", ".join(DEFAULT_CRITERIA)
                           + ", where the field has them)")
    maps.add_argument("--no-criteria", action="store_true", help="flag nothing")
    _speech_options(maps)
    maps.set_defaults(func=cmd_maps)

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
    parse.add_source_option(report)
    report.set_defaults(func=cmd_report)
