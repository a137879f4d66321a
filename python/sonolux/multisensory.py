"""One bake, both senses: the paper's point is one model and one program for light and sound.

:func:`bake_senses` loads the scene once (its triangles, materials and the BVH that the core
builds with it), then runs the sound tracer and the light tracer one after the other on that
same geometry and BVH, with the same worker-thread setting (``settings.threads``), and returns
both fields with a note of what the sharing saved: two separate runs would each load the scene
and build the BVH.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sonolux.errors import SonoluxError
from sonolux.light.bake import bake_light
from sonolux.light.field import LightField
from sonolux.light.options import LightOptions
from sonolux.memory import check_patches
from sonolux.scene import Scene, load_scene
from sonolux.sound.bake import bake as bake_sound
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions
from sonolux.sound.waves import with_scene


@dataclass
class Baked:
    """What :func:`bake_senses` made: the scene, the fields asked for, and ``report`` (JSON-able:
    senses, seconds of each stage, what sharing saved)."""

    scene: Scene
    sound: SoundField | None
    light: LightField | None
    report: dict[str, Any] = field(default_factory=dict)

    def sharing_note(self) -> str:
        r = self.report
        if len(r["senses"]) < 2:
            return (f"{r['senses'][0]} only: scene loaded and BVH built in {r['scene_load_s']:.3f} s")
        return (f"one bake for sound and light: the scene was loaded and its BVH built once "
                f"({r['scene_load_s'] * 1e3:.1f} ms, of which BVH {r['bvh_build_s'] * 1e3:.2f} ms) "
                f"instead of twice: saved {r['saved_s'] * 1e3:.1f} ms "
                f"({r['saved_share']:.1%} of the {r['total_s']:.2f} s bake); both tracers ran on "
                f"the same {r['threads']} worker thread(s)")


def default_senses(scene: Scene) -> dict[str, bool]:
    """Sound when the scene has a source and a receiver; light when it has a light."""
    return {"sound": bool(scene.sources) and scene.receivers.count > 0, "light": bool(scene.lights)}


def bake_senses(scene: Scene | str | Path | dict, *, sound: bool | None = None,
                light: bool | None = None, sound_options: SoundOptions | None = None,
                light_options: LightOptions | None = None, progress: bool = False,
                log: Callable[[str], None] | None = None, load_s: float | None = None,
                sound_baker: Callable[..., SoundField] | None = None,
                light_baker: Callable[..., LightField] | None = None) -> Baked:
    """Bakes sound and light of one scene in one run (None = whatever the scene has).

    ``sound_baker`` replaces :func:`sonolux.sound.bake.bake` (same arguments), e.g. by the bake
    in checkpointed ranges or on a Dask cluster (:func:`sonolux.sound.ranges.bake`);
    ``light_baker`` does the same for :func:`sonolux.light.bake.bake_light`.

    ``scene`` may be loaded already; then ``load_s``, the seconds its loading took, lets the
    report say what sharing saved (otherwise it is timed here)."""
    started = time.perf_counter()
    if isinstance(scene, Scene):
        loaded = scene
        load_s = load_s if load_s is not None else 0.0
    else:
        loaded = load_scene(scene)
        load_s = time.perf_counter() - started
    defaults = default_senses(loaded)
    want = {"sound": defaults["sound"] if sound is None else sound,
            "light": defaults["light"] if light is None else light}
    if not any(want.values()):
        raise SonoluxError(f"{loaded.origin}: nothing to bake: "
                           + ("the scene has no sound source (with a receiver) and no light"
                              if sound is None and light is None else "both --no-sound and --no-light"))
    if want["light"]:  # refuse a light bake that cannot fit before the sound is traced
        check_patches(loaded.vertices_m, loaded.triangles,
                      (light_options or LightOptions()).validate().patch_size_m)
    seconds: dict[str, float] = {}
    out: dict[str, Any] = {"sound": None, "light": None}
    if want["sound"]:
        t = time.perf_counter()
        # The scene's [waves] table against the options, once, for whichever baker runs.
        sound_options = with_scene(loaded, sound_options or SoundOptions())
        out["sound"] = (sound_baker or bake_sound)(loaded, sound_options, progress=progress, log=log)
        seconds["sound_s"] = time.perf_counter() - t
    if want["light"]:
        t = time.perf_counter()
        out["light"] = (light_baker or bake_light)(loaded, light_options, progress=progress,
                                                   log=log)
        seconds["light_s"] = time.perf_counter() - t
    total = time.perf_counter() - started + (load_s if isinstance(scene, Scene) else 0.0)
    senses = [k for k in ("sound", "light") if want[k]]
    threads = loaded.settings.threads or (os.cpu_count() or 1)
    saved = load_s if len(senses) == 2 else 0.0
    report = {"senses": senses, "scene_load_s": load_s,
              "bvh_build_s": loaded.geometry.build_time_s, **seconds, "total_s": total,
              "saved_s": saved, "saved_share": saved / (total + saved) if total > 0 else 0.0,
              "threads": threads}
    return Baked(loaded, out["sound"], out["light"], report)
