"""The scene and field commands: ``check``, ``bake``, ``info``, ``ir`` and ``experiment``.

Each is a thin shell: it parses, calls the library (:mod:`sonolux.scene`,
:mod:`sonolux.multisensory`, :mod:`sonolux.fieldfile`, :mod:`sonolux.experiment`) and prints.
Library modules are imported inside the commands so that ``sonolux --help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import sys

from sonolux.cli import args as parse
from sonolux.cli import spread
from sonolux.limits import MAX_THREADS


def cmd_check(args: argparse.Namespace) -> int:
    # Imported here, not at the top, so that `sonolux --help` stays fast.
    from sonolux.scene import load_scene
    from sonolux.scene.summary import format_summary, summarize

    summary = summarize(load_scene(args.scene))
    if args.json:
        print(json.dumps(summary, indent=2, ensure_ascii=False))
    else:
        print(format_summary(summary))
    return 0


def cmd_bake(args: argparse.Namespace) -> int:
    import time
    from dataclasses import replace

    from sonolux.fieldfile import save_fields
    from sonolux.light.info import format_info as format_light
    from sonolux.light.options import LightOptions
    from sonolux.multisensory import bake_senses
    from sonolux.scene import load_scene
    from sonolux.sound.info import format_info as format_sound
    from sonolux.sound.options import SoundOptions

    started = time.perf_counter()
    scene = load_scene(args.scene)
    overrides = {k: v for k, v in (("seed", args.seed), ("threads", args.threads)) if v is not None}
    if overrides:  # the command line wins over the scene's [settings]
        scene = replace(scene, settings=replace(scene.settings, **overrides))
    load_s = time.perf_counter() - started
    for w in scene.warnings:
        print(f"sonolux: warning: {w}", file=sys.stderr)
    spread.progressive_accuracy(args)  # its usage errors before any pilot ray is traced
    sound_options = SoundOptions(rays=args.rays, estimator=args.estimator,
                                 nee_receivers=args.nee_receivers,
                                 azimuth_bands=args.azimuth_bands,
                                 elevation_bands=args.elevation_bands, ray_range=args.range,
                                 air_absorption=not args.no_air, storage=args.storage,
                                 memory_bytes=args.memory,
                                 sources=tuple(args.bake_source) or None,
                                 **({} if args.late_bin_ms is None
                                    else {"late_bin_s": args.late_bin_ms / 1e3}),
                                 waves=args.waves, crossover_hz=args.crossover_hz,
                                 wave_time_budget_s=args.wave_time_budget)
    if (args.estimator == "auto" and args.rays != "auto" and args.sound is not False
            and scene.sources):
        # A fixed ray count: the estimator is measured here (a progressive bake measures it
        # itself, before its first round), after the hybrid's checks (clearance, memory).
        from sonolux.sound.bake import check_waves
        from sonolux.sound.progressive import choose_estimator

        check_waves(scene, sound_options.validate())
        sound_options = replace(sound_options, estimator=choose_estimator(
            scene, SoundOptions(nee_receivers=args.nee_receivers),
            log=lambda m: print(f"sonolux: {m}", file=sys.stderr))[0].estimator)
    with spread.bakers(args) as (sound_baker, light_baker, written):
        baked = bake_senses(
            scene, sound=args.sound, light=args.light, load_s=load_s,
            sound_options=sound_options,
            light_options=LightOptions(particles=args.particles, patch_size_m=args.patch_size),
            progress=not args.quiet, log=lambda m: print(f"sonolux: {m}", file=sys.stderr),
            sound_baker=sound_baker, light_baker=light_baker)
        for field in (baked.sound, baked.light):
            if field is not None and field.stats.get("cancelled"):
                print("sonolux: stopped early: the field holds what was traced so far",
                      file=sys.stderr)
        if baked.sound is not None:  # a fixed count's unreached receivers (auto says its own)
            from sonolux.sound.reach import silent_receivers

            for note in silent_receivers(baked.sound, scene.area_m2):
                print(f"sonolux: {note}", file=sys.stderr)
        path = save_fields(args.output, sound=baked.sound, light=baked.light, bake=baked.report)
        written()
    if baked.sound is not None:
        print(format_sound(baked.sound, path))
    if baked.light is not None:
        print(format_light(baked.light, path))
    print(baked.sharing_note())
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    from sonolux.fieldfile import contents, open_field, open_light_field
    from sonolux.light.info import format_info as format_light
    from sonolux.light.info import info as light_info
    from sonolux.sound.info import format_info, info
    from sonolux.sound.pick import pick_sources

    has = contents(args.field)
    sound = pick_sources(open_field(args.field), args.source) if has["sound"] else None
    light = open_light_field(args.field) if has["light"] else None
    if args.json:
        out = info(sound) if sound is not None else {}
        if light is not None:
            out["light"] = light_info(light)
        if has["bake"] is not None:
            out["bake"] = has["bake"]
        print(json.dumps(out, indent=2, ensure_ascii=False, default=str))
    else:
        parts = ([format_info(sound, args.field)] if sound is not None else []) + \
                ([format_light(light, args.field)] if light is not None else [])
        print("\n".join(parts))
    return 0


def cmd_ir(args: argparse.Namespace) -> int:
    import numpy as np

    from sonolux.audio import set_level, write_wav
    from sonolux.fieldfile import open_field
    from sonolux.sound.info import listener_warnings

    field = open_field(args.field)
    r = field.cell_at(*args.at)
    direction = None if args.direction == "all" else args.direction
    if args.paper_filters:
        return _write_paper_filters(field, r, direction, args)
    ir = field.impulse_response(r, direction, seed=args.seed)
    peak = float(np.max(np.abs(ir))) if ir.size else 0.0
    calibrated = not args.normalize and (args.calibrated or args.allow_over_full_scale
                                         or args.gain_db is not None)
    samples, gain_db, notes = set_level(ir[:, None] if ir.ndim == 1 else ir, args.gain_db,
                                        calibrated)
    write_wav(args.output, samples, field.sample_rate_hz)
    level = (f"calibrated, gain {gain_db:+.1f} dB" if calibrated
             else f"normalised to -1 dBFS: gain {gain_db:+.1f} dB")
    print(f"impulse response of receiver #{r} at ({', '.join(f'{v:g}' for v in field.positions_m[r])}) m, "
          f"direction {args.direction}: {ir.shape[0] / field.sample_rate_hz:.3f} s, peak "
          f"{peak:.3g} Pa-units ({level}) -> {args.output}")
    for note in notes + listener_warnings(field, r):
        print(f"sonolux: {note}", file=sys.stderr)
    return 0


def _write_paper_filters(field, r: int, direction: str | None, args: argparse.Namespace) -> int:
    """The paper's energy filters of one cell as a multichannel 32-bit float WAV: one channel per
    (direction, band), direction-major, each ``--length`` taps (J/m² per sample)."""
    import numpy as np

    from sonolux.audio import write_wav
    from sonolux.errors import SonoluxError

    if not 1 <= args.length <= 10_000_000:
        raise SonoluxError(f"--length {args.length} is not allowed: 1 to 10000000 taps")
    names = field.direction_names
    taps = field.paper_filters(r, args.length)  # [direction, band, length]
    if direction is not None:
        if direction not in names:
            raise SonoluxError(f"unknown direction {direction!r}: one of {', '.join(names)} or all")
        keep = [names.index(direction)]
        taps, names = taps[keep], [direction]
    channels = [f"{d} {b:g} Hz" for d in names for b in field.bands_hz]
    write_wav(args.output, taps.reshape(len(channels), -1).T, field.sample_rate_hz)
    print(f"the paper's filters of receiver #{r} at "
          f"({', '.join(f'{v:g}' for v in field.positions_m[r])}) m: {len(channels)} channels "
          f"of {args.length} energy taps (J/m² per sample, {field.sample_rate_hz:g} Hz), total "
          f"{np.sum(taps):.3g} J/m² -> {args.output}\nchannels: {', '.join(channels)}")
    return 0


def cmd_experiment(args: argparse.Namespace) -> int:
    from sonolux.experiment import run

    run(args.output, rays=args.rays, estimator=args.estimator)
    return 0


def add_commands(sub) -> None:
    """Adds check, bake, info, ir and experiment to the subcommand table ``sub``."""
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
        "bake", help="trace the scene's sound and light into one field file",
        description="Trace the scene's sound and light with the same particle tracer, in one run "
                    "that loads the scene and builds its BVH once. Sound: an impulse from every "
                    "source into energy per receiver, direction, band and time. Light: particles "
                    "from every light into the flux on every surface patch. Saved as HDF5.")
    bake.add_argument("scene", metavar="SCENE", help="a scene file (.toml) or a built-in name")
    bake.add_argument("-o", "--output", required=True, help="the field file to write (.h5)")
    bake.add_argument("--rays", type=parse.rays, default="auto",
                      help="rays per source, or 'auto': rounds of rays until T30, EDT and C80 "
                           "are known to --accuracy (default auto)")
    bake.add_argument("--estimator", choices=("paper", "rain", "nee", "auto"), default="paper",
                      help="paper: sphere receivers, as the paper (default); rain: exact direct "
                           "sound and diffuse rain to every receiver (few receivers, diffuse "
                           "surfaces); nee: rain to --nee-receivers receivers a reflection drawn "
                           "by importance (grids); auto: a short pilot of each, the one that "
                           "reaches --accuracy with the least counted work (the same choice "
                           "on any machine; docs/progressive.md)")
    bake.add_argument("--nee-receivers", type=parse.number(1, 256, integer=True), default=8,
                      help="receivers each diffuse reflection connects to with --estimator nee "
                           "(default 8)")
    bake.add_argument("--azimuth-bands", type=parse.number(1, 360, integer=True),
                      default=8, help="azimuth sectors (default 8)")
    bake.add_argument("--elevation-bands", type=parse.number(1, 90, integer=True), default=1,
                      help="elevation bands of equal solid angle (1, or 3 = below/level/above)")
    bake.add_argument("--source", dest="bake_source", action="append", default=[],
                      metavar="NAME", help="bake this source of the scene only (repeatable; "
                      "default: every source, each keeping its own field)")
    bake.add_argument("--storage", choices=("compact", "full"), default="compact",
                      help="compact (default): the early part's non-zero one-sample cells and "
                           "the late part at the late bin width; full: every cell dense")
    bake.add_argument("--late-bin-ms", type=parse.number(0.01, 100, unit="ms"), default=None,
                      metavar="MS", help="width of the late time bins in ms (default "
                                         "SoundOptions.late_bin_s; 1 for the full resolution)")
    bake.add_argument("--memory", type=parse.memory_size, default=None, metavar="SIZE",
                      help="the sound bake's memory budget, e.g. 8G: receivers are traced in "
                           "tiles to stay within it (default: 80%% of the memory available)")
    bake.add_argument("--range", type=parse.ray_range, default=None, metavar="FIRST:END",
                      help="trace only rays FIRST..END of the bake (ranges merge exactly)")
    bake.add_argument("--waves", action=argparse.BooleanOptionalAction, default=None,
                      help="bake the bands below a crossover with the wave solver (FDTD) and the "
                           "rest with rays, joined into one field (docs/waves.md); default: as "
                           "the scene's [waves] says (off without it)")
    bake.add_argument("--crossover-hz", type=parse.number(10, 20_000, unit="Hz"), default=None,
                      metavar="HZ", help="with --waves: where waves hand over to rays, snapped "
                                         "to a band edge (default: from the Schroeder frequency "
                                         "and the grid's budget, printed)")
    bake.add_argument("--wave-time-budget", type=parse.number(0, 1e6, lo_open=True, unit="s"),
                      default=None, metavar="S",
                      help="with --waves: warn when the wave run's time predicted at the rate "
                           "measured here is over S (the crossover does not depend on the machine; "
                           "default: the scene's [waves] time_budget_s, else 600 s)")
    bake.add_argument("--sound", action=argparse.BooleanOptionalAction, default=None,
                      help="trace sound (default: when the scene has a source and receivers)")
    bake.add_argument("--light", action=argparse.BooleanOptionalAction, default=None,
                      help="trace light (default: when the scene has a light)")
    bake.add_argument("--particles", type=parse.rays, default="auto",
                      help="light particles, or 'auto' (printed with the reason); default auto")
    bake.add_argument("--patch-size", type=parse.number(0.001, 100, unit="m"), default=0.25, metavar="M",
                      help="size of the light's surface patches in metres (default 0.25)")
    bake.add_argument("--seed", type=parse.seed, default=None,
                      help="seed of the random numbers (default: the scene's, else 1)")
    bake.add_argument("--threads", type=parse.number(0, MAX_THREADS, integer=True), default=None,
                      help="worker threads, 0 = every core (default: the scene's, else 0); "
                           "the result does not depend on it")
    bake.add_argument("--no-air", action="store_true",
                      help="leave out the air's absorption (for comparisons with theory that "
                           "leaves it out)")
    bake.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    spread.add_progressive_flags(bake)
    spread.add_bake_flags(bake)
    bake.set_defaults(func=cmd_bake)

    inf = sub.add_parser("info", help="summarise a field file (sound and light)",
                         description="Summarise a field file: scene, settings, receivers and "
                                     "patches, statistics and the energy and flux balance.")
    inf.add_argument("field", metavar="FIELD", help="a field file written by sonolux bake")
    inf.add_argument("--json", action="store_true", help="print machine-readable JSON")
    parse.add_source_option(inf)
    inf.set_defaults(func=cmd_info)

    ir = sub.add_parser("ir", help="write a receiver's pressure impulse response as WAV",
                        description="Write the pressure impulse response of the cell at X,Y "
                                    "(one direction, or all directions summed) as a 32-bit "
                                    "float WAV file.")
    ir.add_argument("field", metavar="FIELD")
    ir.add_argument("--at", type=parse.xy, required=True, metavar="X,Y", help="position in metres")
    ir.add_argument("--direction", default="all",
                    help="a direction name (front, left, right, back, ...) or 'all' (default)")
    ir.add_argument("--seed", type=parse.seed, default=0, help="seed of the synthesized phases")
    ir.add_argument("--paper-filters", action="store_true",
                    help="write the paper's energy filters instead (Pope and Chalmers): one "
                         "channel per direction and band, --length taps each")
    ir.add_argument("--length", type=parse.number(1, 10_000_000, integer=True, unit="taps"), default=3840,
                    help="taps of --paper-filters (default 3840: the paper's 80 ms at 48 kHz)")
    parse.add_level_options(ir)
    ir.add_argument("-o", "--output", required=True, help="the WAV file to write")
    ir.set_defaults(func=cmd_ir)

    exp = sub.add_parser("experiment", help="the paper's three rooms, baked and compared",
                         description="Bake the paper's three rooms, print T30 of the central "
                                     "cell beside Sabine and Eyring and the ratios between rooms, "
                                     "and write figure 7 and the impulse responses.")
    exp.add_argument("-o", "--output", default="out/experiment", help="output folder")
    exp.add_argument("--rays", type=parse.rays, default="auto", help="rays per source (default auto)")
    exp.add_argument("--estimator", choices=("rain", "paper"), default="paper")
    exp.set_defaults(func=cmd_experiment)

