"""The light and export commands: ``render`` (a picture of the baked light) and ``export`` (the
lit geometry as glTF, and/or the walk-through viewer's web bundle).

    sonolux render FIELD -o view.png [--hdr view.exr|view.pfm] [--camera X,Y,Z]
                   [--look-at X,Y,Z | --yaw DEG --pitch DEG] [--fov DEG] [--size WxH]
                   [--exposure EV] [--tone-map aces|reinhard] [--samples N]
    sonolux export FIELD [--gltf scene.glb] [--web DIR] [--sofa OUT.sofa [--receiver N|all]]
                   [--max-length-s S] [--seed N] ...
"""

from __future__ import annotations

import argparse
import sys

from sonolux.cli import args as parse
from sonolux.light.image import TONE_MAPS
from sonolux.web.options import TAIL_DB


def log(message: str) -> None:
    print(f"sonolux: {message}", file=sys.stderr)


def cmd_render(args: argparse.Namespace) -> int:
    from sonolux.fieldfile import open_light_field
    from sonolux.light.view import ViewSettings, render_view

    field = open_light_field(args.field)
    settings = ViewSettings(camera_m=args.camera, look_at_m=args.look_at, yaw_deg=args.yaw,
                            pitch_deg=args.pitch, fov_deg=args.fov, size_px=args.size,
                            samples=args.samples, exposure_ev=args.exposure, meter=args.meter,
                            tone_map=args.tone_map)
    done = render_view(field, args.output, settings, hdr=args.hdr)
    camera = done["camera"]
    view = (f"looking at ({', '.join(f'{v:g}' for v in camera.look_at_m)})" if camera.look_at_m
            else f"yaw {camera.yaw_deg:g}°, pitch {camera.pitch_deg:g}°")
    print(f"{field.scene_name} from ({', '.join(f'{v:.3g}' for v in camera.position_m)}) m, {view}, "
          f"field of view {camera.fov_deg:g}°, {camera.width}×{camera.height}, "
          f"{args.samples ** 2} rays a pixel, in {done['seconds']:.2f} s")
    print(f"exposure ×{done['exposure_scale']:.4g} ({args.meter} meter "
          f"{done['meter_reading']:.4g}, {args.exposure:+g} EV), {args.tone_map} tone map "
          f"-> {', '.join(done['written'])}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    if not args.web and not args.gltf and not args.sofa:
        args.parser.error("give --gltf PATH.glb, --web DIR, --sofa OUT.sofa, or several")
    if args.sofa and not str(args.sofa).lower().endswith(".sofa"):
        args.parser.error(f"--sofa {args.sofa}: a SOFA file must end in .sofa")
    if args.source and not args.sofa:
        from sonolux.errors import SettingError

        raise SettingError("--source chooses what --sofa exports (the web bundle holds every "
                           "source): give --sofa OUT.sofa too")
    if args.receiver is not None and not args.sofa:
        args.parser.error("--receiver chooses what --sofa exports: give --sofa OUT.sofa too")
    bundle_only = [flag for flag, given in (
        ("--max-length-s", args.max_length_s is not None),
        ("--sample-format", args.sample_format != "int16"),
        ("--tail-db", args.tail_db != TAIL_DB), ("--no-compress", args.no_compress)) if given]
    if bundle_only and not args.web:
        args.parser.error(f"{', '.join(bundle_only)} shape the web bundle: give --web DIR too "
                          "(--sofa always writes the whole responses, float64)")
    if args.gltf:
        from sonolux.fieldfile import open_light_field
        from sonolux.light.export import export_gltf

        field = open_light_field(args.field)
        out = export_gltf(field, args.gltf, exposure_ev=args.exposure, curve=args.tone_map,
                          smooth=not args.flat)
        print(f"{field.scene_name}: {out['triangles']:,} patch triangles, {out['vertices']:,} "
              f"vertices coloured by the baked light (exposure ×{out['exposure_scale']:.4g}, "
              f"{args.tone_map}), {out['bytes'] / 1e6:.2f} MB -> {out['path']}")
    if args.web:
        from sonolux.web.bundle import export_web

        summary = export_web(args.field, args.web, web_options(args), log=log)
        for w in summary.warnings:
            print(f"sonolux: warning: {w}", file=sys.stderr)
        print(summary.describe())
        print(f"serve it with any static web server, or walk through it with `sonolux serve "
              f"{args.field}`")
    if args.sofa:
        from sonolux.sofa import export_sofa

        done = export_sofa(args.field, args.sofa, receiver=args.receiver, seed=args.seed, log=log,
                           sources=args.source)
        print(done.describe())
    return 0


def _receiver(text: str) -> int | None:
    """--receiver: a receiver's index (checked against the field when it is opened), or 'all'."""
    if text.strip().lower() == "all":
        return None
    return int(parse.number(0, integer=True)(text))


def web_options(args: argparse.Namespace):
    from sonolux.web.options import WebExportOptions

    return WebExportOptions(max_length_s=args.max_length_s, sample_format=args.sample_format,
                            seed=args.seed, tail_db=args.tail_db, compress=not args.no_compress,
                            responses=args.responses)


def _tail_db(text: str) -> float | None:
    """--tail-db: a decay from 20 to 200 dB, or 'none'."""
    if text.strip().lower() == "none":
        return None
    return float(parse.number(20, 200, unit="dB")(text))


def add_bundle_options(p: argparse.ArgumentParser) -> None:
    """The web bundle's options, shared by ``export --web`` and ``serve``."""
    g = p.add_argument_group("web bundle")
    g.add_argument("--max-length-s", type=parse.seconds, default=None, metavar="S",
                   help="cut the responses after S seconds (default: the full decay)")
    g.add_argument("--sample-format", choices=("int16", "float32"), default="int16",
                   help="samples of the responses (default int16, half the size)")
    g.add_argument("--seed", type=parse.seed, default=0, help="seed of the responses' fine structure")
    g.add_argument("--tail-db", type=_tail_db, default=TAIL_DB, metavar="DB",
                   help=f"end each cell's responses where its decay has fallen DB below its "
                        f"whole energy (default {TAIL_DB:g}, as the T60; 'none' keeps the "
                        f"field's whole time axis)")
    g.add_argument("--responses", choices=("compact", "pcm"), default="compact",
                   help="compact (default): each cell's compact field, the browser synthesises "
                        "the responses (sonolux-web/3); pcm: the responses themselves "
                        "(sonolux-web/2, --sample-format applies)")
    g.add_argument("--no-compress", action="store_true",
                   help="store the responses uncompressed (default: deflated per cell, lossless)")


def add_commands(sub) -> None:
    """Adds ``render`` and ``export`` to the subcommand table ``sub``."""
    r = sub.add_parser(
        "render", help="a picture of the baked light from a camera (PNG, and EXR/PFM)",
        description="Render the light field of a field file from a camera: each ray finds the "
                    "surface it sees and looks up the light stored there; mirror-like surfaces "
                    "follow the reflection. Without --camera: the paper's view from head height "
                    "near the west end wall, looking down the room along +x.")
    r.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake (with light)")
    r.add_argument("-o", "--output", required=True, help="the PNG to write (tone-mapped, sRGB)")
    r.add_argument("--hdr", help="also write linear radiance (W/m²/sr) as .exr or .pfm")
    r.add_argument("--camera", type=parse.xyz, metavar="X,Y,Z", help="camera position in metres")
    aim = r.add_mutually_exclusive_group()
    aim.add_argument("--look-at", type=parse.xyz, metavar="X,Y,Z",
                     help="the point the camera looks at")
    aim.add_argument("--yaw", type=parse.heading_deg, default=0.0,
                     help="heading in degrees: 0 = +x, counter-clockwise seen from above (default 0)")
    r.add_argument("--pitch", type=parse.number(-90, 90, lo_open=True, hi_open=True, unit="degrees"),
                   default=0.0,
                   help="degrees above the horizon, in (-90, 90) (default 0)")
    r.add_argument("--fov", type=parse.number(0, 180, lo_open=True, hi_open=True, unit="degrees"),
                   default=60.0, help="vertical field of view, degrees (default 60)")
    r.add_argument("--size", type=parse.size_px, metavar="WxH", help="pixels (default 960x540)")
    r.add_argument("--exposure", type=parse.exposure_ev, default=0.0,
                   help="stops added to the automatic exposure, default 0")
    r.add_argument("--meter", choices=("incident", "reflected"), default="incident",
                   help="automatic exposure: incident (the light falling on the surfaces in "
                        "view, so white looks white; default) or reflected (the picture's "
                        "log-average luminance at key 0.18)")
    r.add_argument("--tone-map", choices=TONE_MAPS, default="aces", help="default aces")
    r.add_argument("--samples", type=parse.number(1, 16, integer=True), default=2,
                   help="N: N×N rays per pixel on a fixed grid (default 2)")
    r.set_defaults(func=cmd_render)

    e = sub.add_parser(
        "export", help="the lit geometry as glTF, and/or the viewer's web bundle",
        description="With --gltf: the scene's surfaces, cut into their patches, with the baked "
                    "light as tone-mapped vertex colours and an unlit material, as binary glTF "
                    "(y up). With --web DIR: the walk-through viewer's bundle (the scene as "
                    "glTF, the sound field's responses per cell and direction, and their "
                    "index), for `sonolux serve` or any static web server. With --sofa: "
                    "the responses per receiver and direction as AES69 SOFA. Any of them.")
    e.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    e.add_argument("--gltf", metavar="PATH.glb", help="the binary glTF file to write (needs light)")
    e.add_argument("--web", metavar="DIR",
                   help="write the walk-through viewer's bundle (scene.glb, field.json, "
                        "responses.bin) into DIR")
    e.add_argument("--exposure", type=parse.exposure_ev, default=0.0,
                   help="glTF: stops added to the automatic exposure")
    e.add_argument("--tone-map", choices=TONE_MAPS, default="aces", help="glTF: default aces")
    e.add_argument("--flat", action="store_true",
                   help="glTF: one colour per patch instead of colours smoothed across patches")
    e.add_argument("--sofa", metavar="OUT.sofa",
                   help="write the synthesised responses per receiver and direction as an "
                        "AES69 SOFA file (SingleRoomSRIR; see docs/export.md)")
    parse.add_source_option(e)
    e.add_argument("--receiver", type=_receiver, default=None, metavar="N|all",
                   help="SOFA: the receiver to export (its index, as `sonolux info` lists "
                        "them), or all (default)")
    add_bundle_options(e)
    e.set_defaults(func=cmd_export, parser=e)
