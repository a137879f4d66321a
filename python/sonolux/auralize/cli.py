"""``sonolux auralize``: a dry signal heard at a point, or along a path, written as a WAV file.

    sonolux auralize field.h5 dry.wav --at X,Y --heading DEG --layout binaural -o out.wav
    sonolux auralize field.h5 builtin:speech --path walk.csv --layout cube8 -o walk.wav

The output is 32-bit float WAV in the field's pressure units (see docs/auralize.md): values may
exceed 1, which a float file holds; ``--normalize`` scales the peak to −1 dBFS, ``--gain-db``
by a fixed gain. A walk also writes a plan view of the path beside the audio (``--png``).
"""

from __future__ import annotations

import argparse
import sys

LAYOUTS = ("binaural", "cube8", "ambisonics", "stereo", "5.1", "7.1")
NORMALIZE_PEAK_DBFS = -1.0


def _xy(text: str) -> tuple[float, float]:
    from sonolux.cli import _xy as parse_xy  # the one parser of X,Y the whole command line uses

    return parse_xy(text)


def add_parser(sub) -> argparse.ArgumentParser:
    """Adds the ``auralize`` subcommand to the subparsers of the ``sonolux`` command."""
    p = sub.add_parser(
        "auralize", help="hear a sound field: a dry signal at a point or along a path",
        description="Convolve a dry (anechoic) signal with the responses of the cell at X,Y (or "
                    "of the cells along a path), turn each direction into a virtual source "
                    "rotated by the heading, and write the layout's channels as a WAV file.")
    p.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    p.add_argument("dry", metavar="DRY",
                   help="a sound file (WAV, FLAC, ...; any rate, resampled) or a built-in "
                        "signal: builtin:speech, builtin:melody, builtin:clicks, builtin:noise, "
                        "builtin:sweep (optionally :SECONDS)")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--at", type=_xy, metavar="X,Y", help="the listener's position in metres")
    where.add_argument("--path", metavar="FILE",
                       help="a walk: CSV (time,x,y,heading) or JSON (points or waypoints)")
    p.add_argument("--heading", type=float, default=0.0, metavar="DEG",
                   help="where the listener faces with --at: 0 = +x, 90 = +y (default 0)")
    p.add_argument("--layout", choices=LAYOUTS, default="binaural",
                   help="binaural (headphones), cube8 (the paper's 8 loudspeakers), ambisonics "
                        "(AmbiX), stereo, 5.1, 7.1 (default binaural)")
    p.add_argument("--order", type=int, default=1, help="ambisonic order, 1 to 7 (default 1)")
    p.add_argument("--hrtf", metavar="FILE.sofa",
                   help="binaural through this SOFA file (default: a spherical head model)")
    p.add_argument("-o", "--output", required=True, help="the WAV file to write")
    p.add_argument("--normalize", action="store_true",
                   help=f"scale the peak to {NORMALIZE_PEAK_DBFS:g} dBFS (default: no scaling)")
    p.add_argument("--gain-db", type=float, default=0.0, help="a fixed gain in dB (default 0)")
    p.add_argument("--subtype", choices=("FLOAT", "PCM_24", "PCM_16"), default="FLOAT",
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
    return p


def cmd_auralize(args: argparse.Namespace) -> int:
    from pathlib import Path

    import numpy as np

    from sonolux.audio import write_wav
    from sonolux.auralize.offline import AuralizeSettings, auralize, load_dry
    from sonolux.errors import SonoluxError
    from sonolux.fieldfile import open_field

    field = open_field(args.field)
    fs = field.sample_rate_hz
    settings = AuralizeSettings(layout=args.layout, order=args.order, hrtf=args.hrtf,
                                fade_s=args.fade_ms / 1000.0, block=args.block, seed=args.seed,
                                tail_s=args.tail_s).validate()
    if args.path is None:
        x, what = load_dry(args.dry, fs, channel=args.channel)
        y, info = auralize(field, x, args.at, args.heading, settings)
        r = info["receivers"][0]
        where = (f"at ({args.at[0]:g}, {args.at[1]:g}) m (cell #{r}, receiver at "
                 f"{', '.join(f'{v:g}' for v in field.positions_m[r][:2])}), facing "
                 f"{args.heading:g}°")
    else:
        from sonolux.auralize.walk import WalkSettings, auralize_walk, load_path, plot_walk

        walk = WalkSettings(speed_m_s=args.speed, outside=args.outside).validate()
        path = load_path(args.path, walk.speed_m_s)
        x, what = load_dry(args.dry, fs, duration_s=path.duration_s, channel=args.channel)
        if args.loop and x.size < path.duration_s * fs:
            x = np.resize(x, int(np.ceil(path.duration_s * fs)))
            what += ", looped"
        elif x.size < path.duration_s * fs:
            print(f"sonolux: warning: the dry signal ({x.size / fs:.2f} s) is shorter than the "
                  f"walk ({path.duration_s:.2f} s); --loop repeats it", file=sys.stderr)
        y, info = auralize_walk(field, x, path, settings, walk)
        png = Path(args.png) if args.png else Path(args.output).with_suffix(".png")
        plot_walk(field, path, info, png)
        where = (f"along {args.path} ({path.duration_s:.2f} s, {len(info['events'])} cells: "
                 f"{' '.join(f'#{r}' for r in info['receivers'])}; plan view -> {png})")
    y = y * np.float32(10 ** (args.gain_db / 20))
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    if args.normalize and peak > 0:
        y = y * np.float32(10 ** (NORMALIZE_PEAK_DBFS / 20) / peak)
        peak = 10 ** (NORMALIZE_PEAK_DBFS / 20)
    if args.subtype != "FLOAT" and peak > 1.0:
        raise SonoluxError(f"the peak is {20 * np.log10(peak):+.1f} dBFS: {args.subtype} would "
                           "clip; use --normalize or --gain-db, or keep the float format")
    write_wav(args.output, y, fs, subtype=args.subtype)
    dur = y.shape[0] / fs
    print(f"{what} heard {where}")
    print(f"  {info['layout']}: {y.shape[1]} channels ({', '.join(info['channels'])}), "
          f"{dur:.2f} s at {fs} Hz, peak {20 * np.log10(max(peak, 1e-30)):+.1f} dBFS"
          f"{' (normalized)' if args.normalize else ''} -> {args.output}")
    print(f"  rendered in {info['seconds']:.2f} s ({dur / max(info['seconds'], 1e-9):.1f}x real "
          f"time; {info['prepare_seconds']:.2f} s of it synthesising the cells' responses); "
          f"a live renderer with this block would add {info['latency_samples']} samples "
          f"({1000 * info['latency_samples'] / fs:.1f} ms) of latency")
    if peak > 1.0 and args.subtype == "FLOAT":
        print("sonolux: note: samples exceed ±1 (kept in the float file); players may clip: "
              "--normalize or --gain-db", file=sys.stderr)
    return 0
