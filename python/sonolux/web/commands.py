"""The viewer's subcommands of the ``sonolux`` command line.

    sonolux export FIELD --web DIR [--max-length-s S] [--sample-format int16|float32] [--seed N]
    sonolux serve FIELD [--port N] [--host 127.0.0.1] [--open] [--rebuild] [--max-length-s S]

``export`` belongs to the light half (``--gltf``); :func:`add_commands` adds ``--web`` to it
(either or both may be given), or makes the command when this build has no light half.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def _seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = -1.0
    if not v > 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a time in seconds > 0")
    return v


def _port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = -1
    if not 0 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number in 0..65535 (0: any free)")
    return v


def _log(message: str) -> None:
    print(f"sonolux: {message}", file=sys.stderr)


def _options(args: argparse.Namespace):
    from sonolux.web.options import WebExportOptions

    return WebExportOptions(max_length_s=args.max_length_s, sample_format=args.sample_format,
                            seed=args.seed)


def _add_bundle_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("web bundle")
    g.add_argument("--max-length-s", type=_seconds, default=None, metavar="S",
                   help="cut the responses after S seconds (default: the full decay)")
    g.add_argument("--sample-format", choices=("int16", "float32"), default="int16",
                   help="samples of the responses (default int16, half the size)")
    g.add_argument("--seed", type=int, default=0, help="seed of the responses' fine structure")


def cmd_export_web(args: argparse.Namespace) -> None:
    from sonolux.web.bundle import export_web

    summary = export_web(args.field, args.web, _options(args), log=_log)
    for w in summary.warnings:
        print(f"sonolux: warning: {w}", file=sys.stderr)
    print(summary.describe())
    print(f"serve it with any static web server, or walk through it with `sonolux serve {args.field}`")


def cmd_serve(args: argparse.Namespace) -> int:
    import webbrowser

    from sonolux.web.serve import cached_bundle, is_loopback, make_server, url_of

    bundle = cached_bundle(args.field, _options(args), log=_log, rebuild=args.rebuild)
    server = make_server(bundle, host=args.host, port=args.port, quiet=not args.verbose)
    url = url_of(server)
    if not is_loopback(args.host):
        _log(f"warning: listening on {args.host}: other machines on the network can reach it")
    print(f"serving the walk-through of {args.field} at {url}  (Ctrl-C to stop)", flush=True)
    if args.open:
        webbrowser.open(url)
    try:
        server.serve_forever()
    finally:
        server.server_close()
    return 0


def add_commands(sub: Any) -> None:
    """Adds ``serve``, and ``--web`` to ``export`` (making ``export`` if it is not there)."""
    export = sub.choices.get("export")
    if export is None:
        export = sub.add_parser("export", help="write a web bundle of a field file",
                                description="Write the files the browser viewer reads.")
        export.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    export.description = (export.description or "").rstrip() + (
        " With --web DIR: the walk-through viewer's bundle (the scene as glTF, the sound field's "
        "responses per cell and direction, and their index), for `sonolux serve` or any static "
        "web server.")
    gltf = next((a for a in export._actions if a.dest == "gltf"), None)
    if gltf is not None:
        gltf.required = False  # --web alone is enough; the check below wants one of the two
    export.add_argument("--web", metavar="DIR",
                        help="write the walk-through viewer's bundle (scene.glb, field.json, "
                             "responses.bin) into DIR")
    _add_bundle_options(export)
    light_export = export.get_default("func")

    def cmd_export(args: argparse.Namespace) -> int:
        if not args.web and not getattr(args, "gltf", None):
            export.error("give --web DIR" + (" or --gltf PATH.glb" if gltf is not None else ""))
        if getattr(args, "gltf", None) and light_export is not None:
            light_export(args)
        if args.web:
            cmd_export_web(args)
        return 0

    export.set_defaults(func=cmd_export)

    s = sub.add_parser(
        "serve", help="walk through a field in the browser: see it and hear it",
        description="Export the field's web bundle into a cache folder (once; reused while the "
                    "field file is unchanged) and serve the walk-through viewer with it on this "
                    "machine. Open the printed address; use headphones.")
    s.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    s.add_argument("--port", type=_port, default=8765, help="port (default 8765; 0: any free)")
    s.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only)")
    s.add_argument("--open", action="store_true", help="open the address in the web browser")
    s.add_argument("--rebuild", action="store_true", help="export the bundle again, even if cached")
    s.add_argument("-v", "--verbose", action="store_true", help="log every request")
    _add_bundle_options(s)
    s.set_defaults(func=cmd_serve)
