"""A bake in ranges, here or on a Dask cluster, checkpointed or not: the one entry point for
every kind of bake (:class:`sonolux.sound.ranges.SoundRanges`,
:class:`sonolux.light.ranges.LightRanges`). It picks the runner (:class:`sonolux.ranges.LocalRunner`
or :class:`sonolux.distributed.DaskRunner`) and the checkpoint, then runs
:func:`sonolux.ranges.run_ranges`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from sonolux import ranges
from sonolux.errors import SonoluxError
from sonolux.progress import ProgressLine


def bake_ranges(work: ranges.RangeWork, *, client: Any = None, checkpoint: str | Path | None = None,
                resume: bool = False, restart: bool = False, checkpoint_every_s: float = 60.0,
                range_rays: int | None = None, tasks: int | None = None,
                progress: bool | ranges.Progress = False,
                log: Callable[[str], None] | None = None) -> tuple[Any, dict[str, Any]]:
    """Runs ``work`` in ranges (here, or on ``client``'s Dask cluster), checkpointed to
    ``checkpoint`` if given; returns (the field, the report of :func:`sonolux.ranges.run_ranges`).
    The checkpoint is left in place: remove it (``Checkpointing.discard``) once the field is
    saved."""
    if not (checkpoint_every_s >= 0):
        raise SonoluxError(f"checkpoint interval {checkpoint_every_s!r} s is not allowed: a "
                           "number of seconds ≥ 0")
    if range_rays is not None and not (isinstance(range_rays, int) and range_rays >= 1):
        raise SonoluxError(f"rays per range {range_rays!r} is not allowed: a whole number ≥ 1")
    runner: ranges.Runner
    if client is not None:
        from sonolux.distributed import DaskRunner

        runner = DaskRunner(client, tasks=tasks)
    else:
        runner = ranges.LocalRunner(range_size=range_rays, interval_s=checkpoint_every_s)
    side = None if checkpoint is None else ranges.Checkpointing(
        Path(checkpoint), interval_s=checkpoint_every_s, resume=resume, restart=restart, log=log)
    callback = ProgressLine(f"{work.kind} {work.name}",
                            unit=work.unit) if progress is True else (progress or None)
    return ranges.run_ranges(work, runner, checkpoint=side, progress=callback)


def bake_field(work: ranges.RangeWork, *, checkpoint: str | Path | None = None,
               **options: Any) -> Any:
    """:func:`bake_ranges` for a caller whose output is the field itself (``sonolux.bake``,
    ``sonolux.bake_light``): the field, with the checkpoint removed once the bake is complete."""
    field, _ = bake_ranges(work, checkpoint=checkpoint, **options)
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
    return field
