"""The listening commands: ``auralize`` (a dry signal heard at a point or along a walk, as a WAV
file) and ``serve`` (the walk-through viewer in the browser).

    sonolux auralize field.h5 dry.wav --at X,Y --heading DEG --layout binaural -o out.wav
    sonolux auralize field.h5 builtin:speech --path walk.csv --layout cube8 -o walk.wav
    sonolux serve FIELD [--port N] [--host 127.0.0.1] [--open] [--rebuild] [--max-length-s S]
"""

from __future__ import annotations

import argparse
import sys

from sonolux.auralize.render import LAYOUT_NAMES
from sonolux.auralize.to_file import NORMALIZE_PEAK_DBFS, SUBTYPES
from sonolux.cli import args as parse
from sonolux.cli.light import add_bundle_options, log, web_options


def cmd_auralize(args: argparse.Namespace) -> int:
    from sonolux.auralize.offline import AuralizeSettings
    from sonolux.auralize.to_file import Listening, Output, auralize_to_file
    from sonolux.fieldfile import open_field

    field = open_field(args.field)
    settings = AuralizeSettings(layout=args.layout, order=args.order, hrtf=args.hrtf,
                                fade_s=args.fade_ms / 1000.0, block=args.block, seed=args.seed,
                                tail_s=args.tail_s)
    listening = Listening(at_m=args.at, heading_deg=args.heading, path_file=args.path,
                          speed_m_s=args.speed, outside=args.outside, loop=args.loop,
                          png=args.png)
    out = Output(gain_db=args.gain_db, normalize=args.normalize,
                 allow_over_full_scale=args.allow_over_full_scale, subtype=args.subtype)
    done = auralize_to_file(field, args.dry, args.output, listening, settings, out,
                            channel=args.channel)
    info = done["info"]
    scaled = f" ({done['scaled']})" if done["scaled"] else ""
    print(f"{done['what']} heard {done['where']}")
    print(f"  {info['layout']}: {done['channels']} channels ({', '.join(info['channels'])}), "
          f"{done['seconds']:.2f} s at {done['sample_rate_hz']} Hz, peak "
          f"{done['peak_dbfs']:+.1f} dBFS{scaled} "
          f"-> {args.output}")
    print(f"  rendered in {info['seconds']:.2f} s "
          f"({done['seconds'] / max(info['seconds'], 1e-9):.1f}x real time; "
          f"{info['prepare_seconds']:.2f} s of it synthesising the cells' responses); a live "
          f"renderer with this block would add {info['latency_samples']} samples "
          f"({1000 * info['latency_samples'] / done['sample_rate_hz']:.1f} ms) of latency")
    for note in done["notes"]:
        print(f"sonolux: note: {note}", file=sys.stderr)
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    import webbrowser

    from sonolux.web.serve import cached_bundle, is_loopback, make_server, url_of

    bundle = cached_bundle(args.field, web_options(args), log=log, rebuild=args.rebuild)
    server = make_server(bundle, host=args.host, port=args.port, quiet=not args.verbose)
    url = url_of(server)
    if not is_loopback(args.host):
        log(f"warning: listening on {args.host}: other machines on the network can reach it")
    print(f"serving the walk-through of {args.field} at {url}  (Ctrl-C to stop)", flush=True)
    if args.open:
        webbrowser.open(url)
    try:
        server.serve_forever()
    finally:
        server.server_close()
    return 0


def add_commands(sub) -> None:
    """Adds ``auralize`` and ``serve`` to the subcommand table ``sub``."""
    p = sub.add_parser(
        "auralize", help="hear a sound field: a dry signal at a point or along a path",
        description="Convolve a dry (anechoic) signal with the responses of the cell at X,Y (or "
                    "of the cells along a path), turn each direction into a virtual source "
                    "rotated by the heading, and write the layout's channels as a WAV file. "
                    "The file never goes above full scale unless --allow-over-full-scale.")
    p.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    p.add_argument("dry", metavar="DRY",
                   help="a sound file (WAV, FLAC, ...; any rate, resampled) or a built-in "
                        "signal: builtin:speech, builtin:melody, builtin:clicks, builtin:noise, "
                        "builtin:sweep (optionally :SECONDS)")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--at", type=parse.xy, metavar="X,Y", help="the listener's position in metres")
    where.add_argument("--path", metavar="FILE",
                       help="a walk: CSV (time,x,y,heading) or JSON (points or waypoints)")
    p.add_argument("--heading", type=float, default=0.0, metavar="DEG",
                   help="where the listener faces with --at: 0 = +x, 90 = +y (default 0)")
    p.add_argument("--layout", choices=LAYOUT_NAMES, default="binaural",
                   help="binaural (headphones), cube8 (the paper's 8 loudspeakers), ambisonics "
                        "(AmbiX), stereo, 5.1, 7.1 (default binaural)")
    p.add_argument("--order", type=int, default=1, help="ambisonic order, 1 to 7 (default 1)")
    p.add_argument("--hrtf", metavar="FILE.sofa",
                   help="binaural through this SOFA file (default: a spherical head model)")
    p.add_argument("-o", "--output", required=True, help="the WAV file to write")
    p.add_argument("--normalize", action="store_true",
                   help=f"scale the peak to {NORMALIZE_PEAK_DBFS:g} dBFS (default: only when it "
                        "would be above full scale)")
    p.add_argument("--allow-over-full-scale", action="store_true",
                   help="keep float samples above ±1 (default: scale the whole signal down)")
    p.add_argument("--gain-db", type=float, default=0.0, help="a fixed gain in dB (default 0)")
    p.add_argument("--subtype", choices=SUBTYPES, default="FLOAT",
                   help="sample format (default FLOAT, 32-bit float)")
    p.add_argument("--fade-ms", type=float, default=30.0,
                   help="equal-power cross-fade between cells, ms (default 30)")
    p.add_argument("--block", type=int, default=8192,
                   help="block size of the renderer in samples (default 8192)")
    p.add_argument("--seed", type=int, default=0, help="seed of the responses' fine structure")
    p.add_argument("--tail-s", type=float, default=None,
                   help="seconds rendered after the signal ends (default: the whole response)")
    p.add_argument("--channel", type=int, default=None,
                   help="use this channel of the dry file (from 0; default: mix to mono)")
    p.add_argument("--loop", action="store_true",
                   help="repeat the dry signal to the end of the walk")
    p.add_argument("--speed", type=float, default=1.2,
                   help="walking speed for paths without times, m/s (default 1.2)")
    p.add_argument("--outside", choices=("error", "clamp"), default="error",
                   help="a path leaving the field: stop with an error (default) or stay in the "
                        "nearest cell")
    p.add_argument("--png", default=None,
                   help="the walk's plan view (default: the output's name with .png)")
    p.set_defaults(func=cmd_auralize)

    s = sub.add_parser(
        "serve", help="walk through a field in the browser: see it and hear it",
        description="Export the field's web bundle into a cache folder (once; reused while the "
                    "field file is unchanged) and serve the walk-through viewer with it on this "
                    "machine. Open the printed address; use headphones.")
    s.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    s.add_argument("--port", type=parse.port, default=8765, help="port (default 8765; 0: any free)")
    s.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only)")
    s.add_argument("--open", action="store_true", help="open the address in the web browser")
    s.add_argument("--rebuild", action="store_true", help="export the bundle again, even if cached")
    s.add_argument("-v", "--verbose", action="store_true", help="log every request")
    add_bundle_options(s)
    s.set_defaults(func=cmd_serve)
