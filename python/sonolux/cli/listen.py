"""The listening commands: ``auralize`` (a dry signal heard at a point or along a walk, as a WAV
file), ``film`` (the walk seen and heard, as a video) and ``serve`` (the walk-through viewer in
the browser).

    sonolux auralize field.h5 dry.wav --at X,Y --heading DEG --layout binaural -o out.wav
    sonolux auralize field.h5 builtin:speech --path walk.csv --layout cube8 -o walk.wav
    sonolux film field.h5 --path walk.csv -o walk.mp4 [--dry builtin:speech] [--fps 25]
    sonolux serve FIELD [--port N] [--host 127.0.0.1] [--open] [--rebuild] [--max-length-s S]
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from sonolux.auralize.render import LAYOUT_NAMES
from sonolux.auralize.to_file import SUBTYPES
from sonolux.cli import args as parse
from sonolux.cli.light import add_bundle_options, log, web_options


def cmd_auralize(args: argparse.Namespace) -> int:
    from sonolux.auralize.offline import AuralizeSettings
    from sonolux.auralize.to_file import Listening, Output, auralize_to_file
    from sonolux.errors import SettingError
    from sonolux.fieldfile import open_field
    from sonolux.sound.pick import pick_sources

    if args.dry_of:
        if args.dry is not None or args.source:
            raise SettingError("--dry NAME=DRY gives each source its own signal: leave out "
                               "the positional DRY and --source")
        names = [name for name, _ in args.dry_of]
        if len(set(names)) != len(names):
            raise SettingError(f"--dry names a source twice: {', '.join(names)}")
    elif args.dry is None:
        raise SettingError("give a DRY signal (every source plays it), or --dry NAME=DRY once "
                           "per source")
    field = open_field(args.field)
    if args.dry_of:
        for name, _ in args.dry_of:
            field.source_index(name)  # unknown names: an error naming the field's sources
        dry: Any = dict(args.dry_of)
    else:
        field, dry = pick_sources(field, args.source), args.dry
    settings = AuralizeSettings(layout=args.layout, order=args.order, hrtf=args.hrtf,
                                fade_s=args.fade_ms / 1000.0, block=args.block, seed=args.seed,
                                tail_s=args.tail_s)
    listening = Listening(at_m=args.at, heading_deg=args.heading, path_file=args.path,
                          speed_m_s=args.speed, outside=args.outside, loop=args.loop,
                          png=args.png)
    out = Output(gain_db=args.gain_db, normalize=args.normalize, calibrated=args.calibrated,
                 allow_over_full_scale=args.allow_over_full_scale, subtype=args.subtype)
    done = auralize_to_file(field, dry, args.output, listening, settings, out,
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
        print(f"sonolux: {'' if note.startswith('warning:') else 'note: '}{note}", file=sys.stderr)
    return 0


def _dry_of(text: str) -> tuple[str, str]:
    """--dry NAME=DRY."""
    name, eq, dry = text.partition("=")
    if not (name and eq and dry):
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=DRY (a source's name or index, "
                                         "then its dry signal: a sound file or builtin:NAME)")
    return name, dry


def cmd_film(args: argparse.Namespace) -> int:
    from sonolux.fieldfile import contents, open_field, open_light_field
    from sonolux.film import FilmSettings, make_film
    from sonolux.progress import ProgressLine

    has = contents(args.field)
    missing = [s for s in ("sound", "light") if not has[s]]
    if missing:
        from sonolux.errors import SonoluxError

        raise SonoluxError(f"{args.field}: a film needs both senses; this file has no "
                           f"{' and no '.join(missing)} (bake the scene with both)")
    width, height = args.size
    settings = FilmSettings(fps=args.fps, width_px=width, height_px=height, fov_deg=args.fov,
                            eye_height_m=args.eye_height, samples=args.samples,
                            layout=args.layout, crf=args.crf)
    done = make_film(open_field(args.field), open_light_field(args.field), args.dry, args.path,
                     args.output, settings,
                     progress=None if args.quiet else ProgressLine("film", unit="frames"))
    print(f"{done['frames']} frames at {done['fps']:g} fps ({done['size_px'][0]}x"
          f"{done['size_px'][1]}, eye at {done['eye_height_m']:.2f} m) and {done['layout']} "
          f"sound of {done['dry']}, {done['duration_s']:.2f} s through {len(done['cells'])} "
          f"cells, made in {done['seconds']:.1f} s -> {done['output']} "
          f"({done['bytes'] / 1e6:.1f} MB)")
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
    """Adds ``auralize``, ``film`` and ``serve`` to the subcommand table ``sub``."""
    p = sub.add_parser(
        "auralize", help="hear a sound field: a dry signal at a point or along a path",
        description="Convolve a dry (anechoic) signal with the responses of the cell at X,Y (or "
                    "of the cells along a path), turn each direction into a virtual source "
                    "rotated by the heading, and write the layout's channels as a WAV file. "
                    "By default the peak is normalised to -1 dBFS and the gain printed; "
                    "--calibrated or --gain-db keep absolute levels.")
    p.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    p.add_argument("dry", metavar="DRY", nargs="?", default=None,
                   help="a sound file (WAV, FLAC, ...; any rate, resampled) or a built-in "
                        "signal: builtin:speech, builtin:melody, builtin:clicks, builtin:noise, "
                        "builtin:sweep (optionally :SECONDS)")
    p.add_argument("--dry", dest="dry_of", type=_dry_of, action="append", default=[],
                   metavar="NAME=DRY",
                   help="a field of several sources: source NAME plays DRY (repeat it, once per "
                        "source heard; sources not named are silent), instead of one DRY for all")
    parse.add_source_option(p)
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--at", type=parse.xy, metavar="X,Y", help="the listener's position in metres")
    where.add_argument("--path", metavar="FILE",
                       help="a walk: CSV (time,x,y,heading) or JSON (points or waypoints)")
    p.add_argument("--heading", type=parse.heading_deg, default=0.0, metavar="DEG",
                   help="where the listener faces with --at: 0 = +x, 90 = +y (default 0)")
    p.add_argument("--layout", choices=LAYOUT_NAMES, default="binaural",
                   help="binaural (headphones), cube8 (the paper's 8 loudspeakers), ambisonics "
                        "(AmbiX), stereo, 5.1, 7.1 (default binaural)")
    p.add_argument("--order", type=parse.number(1, 7, integer=True),
                   default=1, help="ambisonic order, 1 to 7 (default 1)")
    p.add_argument("--hrtf", metavar="FILE.sofa",
                   help="binaural through this SOFA file (default: a spherical head model)")
    p.add_argument("-o", "--output", required=True, help="the WAV file to write")
    parse.add_level_options(p)
    p.add_argument("--subtype", choices=SUBTYPES, default="FLOAT",
                   help="sample format (default FLOAT, 32-bit float)")
    p.add_argument("--fade-ms", type=parse.number(5, 500, unit="ms"), default=30.0,
                   help="equal-power cross-fade between cells, ms (default 30)")
    p.add_argument("--block", type=parse.number(16, 1 << 20, integer=True, unit="samples"), default=8192,
                   help="block size of the renderer in samples (default 8192)")
    p.add_argument("--seed", type=parse.seed, default=0, help="seed of the responses' fine structure")
    p.add_argument("--tail-s", type=parse.number(0, 60, unit="s"), default=None,
                   help="seconds rendered after the signal ends (default: the whole response)")
    p.add_argument("--channel", type=parse.number(0, 1023, integer=True), default=None,
                   help="use this channel of the dry file (from 0; default: mix to mono)")
    p.add_argument("--loop", action="store_true",
                   help="repeat the dry signal to the end of the walk")
    p.add_argument("--speed", type=parse.number(0, 100, lo_open=True, unit="m/s"), default=1.2,
                   help="walking speed for paths without times, m/s (default 1.2)")
    p.add_argument("--outside", choices=("error", "clamp"), default="error",
                   help="a path leaving the field: stop with an error (default) or stay in the "
                        "nearest cell")
    p.add_argument("--png", default=None,
                   help="the walk's plan view (default: the output's name with .png)")
    p.set_defaults(func=cmd_auralize)

    f = sub.add_parser(
        "film", help="the walk-through film: the lit room seen and heard along a path (MP4)",
        description="Render the lit room from the walker's eye along a path (the camera of "
                    "sonolux render, one frame every 1/FPS s) and mux the walk's binaural or "
                    "stereo soundtrack (as sonolux auralize --path makes it), in sync, into an "
                    "MP4, MKV or MOV (H.264 and AAC through PyAV). The field file needs both "
                    "senses. The sound is never written above full scale.")
    f.add_argument("field", metavar="FIELD", help="a field file with sound and light")
    f.add_argument("--path", required=True, metavar="FILE",
                   help="the walk: CSV (time,x,y,heading) or JSON, as for auralize")
    f.add_argument("-o", "--output", required=True, help="the film to write (.mp4, .mkv, .mov)")
    f.add_argument("--dry", default="builtin:speech", metavar="DRY",
                   help="what is heard: a sound file or builtin:NAME (default builtin:speech)")
    f.add_argument("--fps", type=parse.number(1, 120, unit="frames per second"),
                   default=25.0, help="frames per second (default 25)")
    f.add_argument("--size", type=parse.size_px, default=(640, 360), metavar="WxH",
                   help="pixels, both even (default 640x360)")
    f.add_argument("--fov", type=parse.number(0, 170, lo_open=True, hi_open=True, unit="degrees"),
                   default=70.0, metavar="DEG",
                   help="vertical field of view (default 70)")
    f.add_argument("--eye-height", type=parse.number(0, 100, lo_open=True, hi_open=True, unit="m"),
                   default=None, metavar="M",
                   help="the camera's height (default: the receivers', where the ears are)")
    f.add_argument("--samples", type=parse.number(1, 16, integer=True), default=1,
                   help="samples² rays per pixel (default 1)")
    f.add_argument("--layout", choices=("binaural", "stereo"), default="binaural",
                   help="the soundtrack (default binaural, for headphones)")
    f.add_argument("--crf", type=parse.number(0, 51, integer=True), default=20,
                   help="H.264 quality, 0 (best) to 51 (default 20)")
    f.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    f.set_defaults(func=cmd_film)

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
