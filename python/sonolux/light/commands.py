"""The light's subcommands of the ``sonolux`` command line: ``render`` and ``export``.

    sonolux render FIELD -o view.png [--hdr view.exr|view.pfm] [--camera X,Y,Z]
                   [--look-at X,Y,Z | --yaw DEG --pitch DEG] [--fov DEG] [--size WxH]
                   [--exposure EV] [--tone-map aces|reinhard] [--samples N]
    sonolux export FIELD --gltf scene.glb [--exposure EV] [--tone-map aces|reinhard] [--flat]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from sonolux.light.image import TONE_MAPS


def _xyz(text: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y,Z in metres (e.g. 0.3,1.25,1.5)") from None
    return x, y, z


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT in pixels (e.g. 960x540)") from None
    return w, h


def cmd_render(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from sonolux.fieldfile import open_light_field
    from sonolux.light import image
    from sonolux.light.camera import Camera, default_camera
    from sonolux.light.render import Renderable, incident_exposure, render

    field = open_light_field(args.field)
    settings: dict[str, Any] = {"fov_deg": args.fov}
    if args.size:
        settings["width"], settings["height"] = args.size
    if args.look_at is not None:
        settings["look_at_m"] = args.look_at
    else:
        settings["yaw_deg"], settings["pitch_deg"] = args.yaw, args.pitch
    if args.camera is None:
        camera = default_camera(field.vertices_m.min(axis=0), field.vertices_m.max(axis=0), **settings)
    else:
        camera = replace(Camera(position_m=args.camera), **settings)
    started = time.perf_counter()
    renderable = Renderable.of(field)
    rays = render(renderable, camera, samples=args.samples, keep_samples=True)
    linear = rays.mean(axis=2)
    auto = (incident_exposure(renderable, camera) if args.meter == "incident"
            else image.auto_exposure(linear))
    seconds = time.perf_counter() - started
    scale = auto * 2.0 ** args.exposure
    png = image.write_png(args.output, image.to_srgb8(rays, scale, args.tone_map, samples_axis=2))
    written = [str(png)]
    if args.hdr:
        written.append(str(image.write_hdr(args.hdr, linear)))
    view = (f"looking at ({', '.join(f'{v:g}' for v in camera.look_at_m)})" if camera.look_at_m
            else f"yaw {camera.yaw_deg:g}°, pitch {camera.pitch_deg:g}°")
    print(f"{field.scene_name} from ({', '.join(f'{v:.3g}' for v in camera.position_m)}) m, {view}, "
          f"field of view {camera.fov_deg:g}°, {camera.width}×{camera.height}, "
          f"{args.samples ** 2} rays a pixel, in {seconds:.2f} s")
    print(f"exposure ×{scale:.4g} ({args.meter} meter {auto:.4g}, {args.exposure:+g} EV), "
          f"{args.tone_map} tone map "
          f"-> {', '.join(written)}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from sonolux.fieldfile import open_light_field
    from sonolux.light.export import export_gltf

    field = open_light_field(args.field)
    out = export_gltf(field, args.gltf, exposure_ev=args.exposure, curve=args.tone_map,
                      smooth=not args.flat)
    print(f"{field.scene_name}: {out['triangles']:,} patch triangles, {out['vertices']:,} vertices "
          f"coloured by the baked light (exposure ×{out['exposure_scale']:.4g}, {args.tone_map}), "
          f"{out['bytes'] / 1e6:.2f} MB -> {out['path']}")
    return 0


def add_commands(sub: Any) -> None:
    """Adds ``render`` and ``export`` to the subcommand table."""
    r = sub.add_parser(
        "render", help="a picture of the baked light from a camera (PNG, and EXR/PFM)",
        description="Render the light field of a field file from a camera: each ray finds the "
                    "surface it sees and looks up the light stored there; mirror-like surfaces "
                    "follow the reflection. Without --camera: the paper's view from head height "
                    "near the west end wall, looking down the room along +x.")
    r.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake (with light)")
    r.add_argument("-o", "--output", required=True, help="the PNG to write (tone-mapped, sRGB)")
    r.add_argument("--hdr", help="also write linear radiance (W/m²/sr) as .exr or .pfm")
    r.add_argument("--camera", type=_xyz, metavar="X,Y,Z", help="camera position in metres")
    aim = r.add_mutually_exclusive_group()
    aim.add_argument("--look-at", type=_xyz, metavar="X,Y,Z", help="the point the camera looks at")
    aim.add_argument("--yaw", type=float, default=0.0,
                     help="heading in degrees: 0 = +x, counter-clockwise seen from above (default 0)")
    r.add_argument("--pitch", type=float, default=0.0,
                   help="degrees above the horizon, in (-90, 90) (default 0)")
    r.add_argument("--fov", type=float, default=60.0, help="vertical field of view, degrees (default 60)")
    r.add_argument("--size", type=_size, metavar="WxH", help="pixels (default 960x540)")
    r.add_argument("--exposure", type=float, default=0.0,
                   help="stops added to the automatic exposure, default 0")
    r.add_argument("--meter", choices=("incident", "reflected"), default="incident",
                   help="automatic exposure: incident (the light falling on the surfaces in "
                        "view, so white looks white; default) or reflected (the picture's "
                        "log-average luminance at key 0.18)")
    r.add_argument("--tone-map", choices=TONE_MAPS, default="aces", help="default aces")
    r.add_argument("--samples", type=int, default=2,
                   help="N: N×N rays per pixel on a fixed grid (default 2)")
    r.set_defaults(func=cmd_render)

    e = sub.add_parser(
        "export", help="the geometry with the baked light as vertex colours (glTF)",
        description="Write the scene's surfaces, cut into their patches, with the baked light as "
                    "tone-mapped vertex colours and an unlit material, as binary glTF (y up).")
    e.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake (with light)")
    e.add_argument("--gltf", required=True, metavar="PATH.glb", help="the binary glTF file to write")
    e.add_argument("--exposure", type=float, default=0.0, help="stops added to the automatic exposure")
    e.add_argument("--tone-map", choices=TONE_MAPS, default="aces", help="default aces")
    e.add_argument("--flat", action="store_true",
                   help="one colour per patch instead of colours smoothed across patches")
    e.set_defaults(func=cmd_export)
