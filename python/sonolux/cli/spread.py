"""Bakes that survive and spread: the flags of ``bake`` for checkpoints, resume and Dask, and the
``merge`` command. Thin shells over :mod:`sonolux.sound.ranges`, :mod:`sonolux.distributed`
and :mod:`sonolux.parts`.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from typing import Any

from sonolux.cli import args as parse
from sonolux.limits import MAX_RAYS


def _count(what: str) -> Callable[[str], int]:
    """A whole number from 1 (the shared parser of :mod:`sonolux.cli.args`)."""
    del what  # the option's name says what is counted
    return parse.number(1, MAX_RAYS, integer=True)


#: Seconds between checkpoints, 0 (after every range) to a day.
_interval = parse.number(0, 86400, unit="s (0: after every range)")


def add_bake_flags(bake: argparse.ArgumentParser) -> None:
    """Adds the checkpoint, resume and Dask flags to the ``bake`` parser."""
    g = bake.add_argument_group("checkpoint and resume")
    again = g.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="continue from the checkpoints beside the output (OUTPUT.checkpoint for "
                            "sound, OUTPUT.light.checkpoint for light)")
    again.add_argument("--restart", action="store_true",
                       help="discard those checkpoints and bake from the start")
    g.add_argument("--checkpoint-every", type=_interval, default=60.0, metavar="S",
                   help="write the checkpoint at most every S seconds (default 60; 0: after "
                        "every range)")
    g.add_argument("--no-checkpoint", dest="checkpoint", action="store_false",
                   help="write no checkpoint (a killed bake then starts over)")
    g.add_argument("--range-rays", type=_count("a number of rays"), default=None, metavar="N",
                   help="rays (or light particles) per range in this process (default: 1/16 of "
                        "the bake, then about one checkpoint interval's worth)")
    d = bake.add_argument_group("Dask")
    d.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="trace the rays as tasks on a Dask cluster: its scheduler's address "
                        "(tcp://host:8786) or 'local' for a process pool on this machine")
    d.add_argument("--dask-workers", type=_count("a number of workers"), default=None,
                   metavar="N", help="worker processes of --dask local (default: the cores)")
    d.add_argument("--tasks", type=_count("a number of tasks"), default=None, metavar="N",
                   help="ray ranges to make tasks of (default: 2 per worker thread)")


def progressive_accuracy(args: argparse.Namespace) -> Any:
    """The accuracy of a progressive bake (``--rays auto``), or None for a fixed ray count."""
    from sonolux.errors import SonoluxError

    given = [f for f, v in (("--accuracy", args.accuracy), ("--max-rays", args.max_rays),
                            ("--max-seconds", args.max_seconds)) if v is not None]
    if args.rays != "auto":
        if given:
            raise SonoluxError(f"{', '.join(given)} steer a progressive bake (--rays auto); "
                               f"--rays {args.rays} fixes the count: give one or the other")
        return None
    if args.range is not None:
        raise SonoluxError("--range splits a bake of a known size: give its ray count with "
                           "--rays N (a progressive bake, --rays auto, decides it as it goes)")
    from sonolux.sound.progressive import Accuracy

    return Accuracy(fraction_of_jnd=0.25 if args.accuracy is None else args.accuracy,
                    max_rays=args.max_rays, max_seconds=args.max_seconds).validate()


def add_progressive_flags(bake: argparse.ArgumentParser) -> None:
    """Adds the flags of the progressive bake (``--rays auto``) to the ``bake`` parser."""
    g = bake.add_argument_group("progressive bake (--rays auto)")
    g.add_argument("--accuracy", type=parse.number(0.0, 10.0, lo_open=True), default=None,
                   metavar="F", help="stop when the standard error of T30, EDT and C80 is below "
                   "F just-noticeable differences at every receiver and band (default 0.25)")
    g.add_argument("--max-rays", type=parse.number(2048, MAX_RAYS, integer=True), default=None,
                   metavar="N", help="rays per source at most (default 5e7)")
    g.add_argument("--max-seconds", type=parse.number(0.0, 1e7, lo_open=True, unit="s"),
                   default=None, metavar="S", help="stop after the round that passes S seconds")


@contextmanager
def bakers(args: argparse.Namespace) -> Iterator[tuple[Any, Any, Callable[[], None]]]:
    """(the sound baker and the light baker for :func:`sonolux.multisensory.bake_senses`, the
    function to call once the output is safely written: it removes the checkpoints). None for
    the plain bakes, when neither a checkpoint nor Dask is asked for. The sound bake's
    checkpoint is OUTPUT.checkpoint, the light bake's OUTPUT.light.checkpoint; one Dask client
    serves both."""
    from pathlib import Path

    from sonolux.checkpoint import side_file
    from sonolux.errors import SonoluxError

    if not args.checkpoint and (args.resume or args.restart):
        raise SonoluxError("--resume and --restart need the checkpoint: drop --no-checkpoint")
    if args.dask_workers is not None and args.dask is None:
        raise SonoluxError("--dask-workers is for --dask local")
    accuracy = progressive_accuracy(args)
    if not args.checkpoint and args.dask is None and accuracy is None:
        yield None, None, lambda: None
        return
    sound_side = side_file(args.output) if args.checkpoint else None
    light_side = side_file(Path(str(args.output) + ".light")) if args.checkpoint else None
    context: Any = nullcontext(None)
    if args.dask is not None:
        from sonolux.distributed import connect

        context = connect(args.dask, args.dask_workers)
    with context as client:
        def in_ranges(make_work: Callable[..., Any], side: Any) -> Callable[..., Any]:
            def bake(scene: Any, options: Any, progress: Any = False, log: Any = None) -> Any:
                from sonolux.range_bake import bake_ranges

                work = make_work(scene, options, log=log)
                field, report = bake_ranges(
                    work, client=client, checkpoint=side, resume=args.resume,
                    restart=args.restart, checkpoint_every_s=args.checkpoint_every,
                    range_rays=args.range_rays, tasks=args.tasks, progress=progress, log=log)
                if log and report["restored"]:
                    log(f"{report['restored']:,} {work.unit} came from the checkpoint, "
                        f"{sum(b - a for a, b in report['ranges']):,} were traced now")
                return field
            return bake

        def progressive_bake(scene: Any, options: Any, progress: Any = False,
                             log: Any = None) -> Any:
            from sonolux.sound import progressive

            field, _ = progressive.bake(
                scene, options, accuracy, client=client, checkpoint=sound_side,
                resume=args.resume, restart=args.restart,
                checkpoint_every_s=args.checkpoint_every, range_rays=args.range_rays,
                tasks=args.tasks, progress=progress, log=log)
            return field  # its checkpoint goes once the output is written (done below)

        def sound_work(*a: Any, **k: Any) -> Any:
            from sonolux.sound.ranges import SoundRanges
            return SoundRanges(*a, **k)

        def light_work(*a: Any, **k: Any) -> Any:
            from sonolux.light.ranges import LightRanges
            return LightRanges(*a, **k)

        def done() -> None:
            for side in (sound_side, light_side):
                if side is not None:
                    side.unlink(missing_ok=True)

        light = in_ranges(light_work, light_side) if args.checkpoint or client else None
        sound = progressive_bake if accuracy is not None else in_ranges(sound_work, sound_side)
        yield sound, light, done


def cmd_merge(args: argparse.Namespace) -> int:
    from sonolux.fieldfile import save_fields
    from sonolux.parts import merge_parts
    from sonolux.sound.info import format_info

    field, report = merge_parts(args.parts, partial=args.partial)
    path = save_fields(args.output, sound=field)
    print(format_info(field, path))
    state = ("complete" if not report["missing"] else "partial, missing rays "
             + ", ".join(f"{a}..{b}" for a, b in report["missing"]))
    print(f"merged {report['parts']} parts of a {report['rays']:,}-ray bake ({state}) -> {path}")
    return 0


def add_commands(sub: Any) -> None:
    """Adds ``merge`` to the subcommand table ``sub``."""
    merge = sub.add_parser(
        "merge", help="add up the parts of a bake (ray ranges, checkpoints) into one field",
        description="Add up the parts of one sound bake: field files baked with --range (on "
                    "several machines, say) and checkpoints of stopped bakes. The parts must "
                    "come from the same scene, settings and version and share no rays; the "
                    "rays that no part holds are named. The sum is exact: a complete merge has "
                    "the bits of the bake done at once.")
    merge.add_argument("parts", nargs="+", metavar="PART",
                       help="field files (.h5) with counts, or OUTPUT.checkpoint files")
    merge.add_argument("-o", "--output", required=True, help="the field file to write (.h5)")
    merge.add_argument("--partial", action="store_true",
                       help="write the sum even when rays are missing (a part, to merge later)")
    merge.set_defaults(func=cmd_merge)
