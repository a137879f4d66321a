"""sonolux: one particle tracer for light and sound, to see and hear a virtual space.

The Rust core (``sonolux._core``) traces; this package loads scenes, checks them, and analyses
what the core returns. Start with :func:`load_scene` and the ``sonolux`` command line.

The names below are imported on first use, so that ``import sonolux.errors`` (and the command
line, which must answer Ctrl-C from its first moment) does not load numpy, scipy and the core.
"""

from __future__ import annotations

import importlib
import os
from typing import TYPE_CHECKING, Any

# numpy's OpenBLAS threads spin while idle and steal the cores the tracers run on; sonolux does
# no heavy linear algebra, so one BLAS thread is enough (a user's own setting wins).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

if TYPE_CHECKING:
    from sonolux.errors import SceneError, SonoluxError
    from sonolux.fieldfile import open_field as open
    from sonolux.fieldfile import open_light_field
    from sonolux.light.field import LightField
    from sonolux.light.options import LightOptions
    from sonolux.light.ranges import bake as bake_light
    from sonolux.scene import Scene, load_scene
    from sonolux.sound.baking import bake
    from sonolux.sound.field import SoundField
    from sonolux.sound.options import SoundOptions
    from sonolux.version import __version__

#: Public name -> (module, name in it).
_LAZY = {
    "__version__": ("sonolux.version", "__version__"),
    "SceneError": ("sonolux.errors", "SceneError"),
    "SonoluxError": ("sonolux.errors", "SonoluxError"),
    "open": ("sonolux.fieldfile", "open_field"),
    "open_light_field": ("sonolux.fieldfile", "open_light_field"),
    "bake_light": ("sonolux.light.ranges", "bake"),
    "LightField": ("sonolux.light.field", "LightField"),
    "LightOptions": ("sonolux.light.options", "LightOptions"),
    "Scene": ("sonolux.scene", "Scene"),
    "load_scene": ("sonolux.scene", "load_scene"),
    "bake": ("sonolux.sound.baking", "bake"),
    "SoundField": ("sonolux.sound.field", "SoundField"),
    "SoundOptions": ("sonolux.sound.options", "SoundOptions"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'sonolux' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = ["LightField", "LightOptions", "Scene", "SceneError", "SonoluxError", "SoundField",
           "SoundOptions", "__version__", "bake", "bake_light", "load_scene", "open",
           "open_light_field"]
