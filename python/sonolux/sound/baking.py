"""``sonolux.bake``: which sound bake runs. At once (:func:`sonolux.sound.bake.bake`), in ray
ranges that are checkpointed or spread over a Dask cluster (:func:`sonolux.sound.ranges.bake`),
or progressive, in rounds until an accuracy is reached (:func:`sonolux.sound.progressive.bake`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from sonolux.errors import SonoluxError
from sonolux.scene.schema import Scene
from sonolux.sound import progressive
from sonolux.sound import ranges as in_ranges
from sonolux.sound.bake import check_waves
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions
from sonolux.sound.waves import with_scene


def bake(scene: Scene, options: SoundOptions | None = None, *,
         accuracy: progressive.Accuracy | float | None = None, client: Any = None,
         checkpoint: str | Path | None = None, resume: bool = False, restart: bool = False,
         checkpoint_every_s: float = 60.0, range_rays: int | None = None,
         tasks: int | None = None, progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, **overrides: Any) -> SoundField:
    """:func:`sonolux.sound.ranges.bake` (the same arguments: options, Dask ``client``,
    ``checkpoint``, ``resume``, ``progress``, ...), or, with ``accuracy``, the progressive bake.

    ``accuracy``: bake progressively (``rays`` must be "auto"): rounds of rays until the
    standard error of T30, EDT and C80 at every receiver and band is below this fraction of a
    just-noticeable difference (a float, e.g. 0.25), or a
    :class:`sonolux.sound.progressive.Accuracy` with caps on rays and seconds. The field's
    ``settings["progressive"]`` says how it ended and which errors it reached.
    """
    options = with_scene(scene, replace(options or SoundOptions(), **overrides).validate())
    if accuracy is None and options.estimator == "auto":
        # A fixed ray count: the estimator that reaches a quarter of a JND sooner (the pilots'
        # measure of speed; the count itself stays the caller's). The pilots are rays: the
        # hybrid's clearance and memory are checked before them (the other paths' entries,
        # the range baker and the progressive bake, check before their own first ray).
        check_waves(scene, options, from_ray_zero=(options.ray_range or (0,))[0] == 0)
        options, choice = progressive.choose_estimator(scene, options, log=log)
        field = bake(scene, options, client=client, checkpoint=checkpoint, resume=resume,
                     restart=restart, checkpoint_every_s=checkpoint_every_s,
                     range_rays=range_rays, tasks=tasks, progress=progress, log=log)
        return replace(field, settings=dict(field.settings, estimator_choice=choice))
    if accuracy is None:
        return in_ranges.bake(scene, options, client=client, checkpoint=checkpoint,
                              resume=resume, restart=restart,
                              checkpoint_every_s=checkpoint_every_s, range_rays=range_rays,
                              tasks=tasks, progress=progress, log=log)
    if options.rays != "auto":
        raise SonoluxError(f"accuracy is for rays = 'auto' (a progressive bake); rays = "
                           f"{options.rays!r} fixes the count: give one or the other")
    if not isinstance(accuracy, progressive.Accuracy):
        accuracy = progressive.Accuracy(fraction_of_jnd=accuracy)
    field, _ = progressive.bake(scene, options, accuracy, client=client, checkpoint=checkpoint,
                                resume=resume, restart=restart,
                                checkpoint_every_s=checkpoint_every_s, range_rays=range_rays,
                                tasks=tasks, progress=progress, log=log)
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)
    return field
