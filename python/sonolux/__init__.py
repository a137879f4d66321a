"""sonolux: one particle tracer for light and sound, to see and hear a virtual space.

The Rust core (``sonolux._core``) traces; this package loads scenes, checks them, and analyses
what the core returns. Start with :func:`load_scene` and the ``sonolux`` command line.
"""

from __future__ import annotations

import os

# numpy's OpenBLAS threads spin while idle and steal the cores the tracers run on; sonolux does
# no heavy linear algebra, so one BLAS thread is enough (a user's own setting wins).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from sonolux.errors import SceneError, SonoluxError
from sonolux.fieldfile import open_field as open
from sonolux.fieldfile import open_light_field
from sonolux.light.bake import bake_light
from sonolux.light.field import LightField
from sonolux.light.options import LightOptions
from sonolux.scene import Scene, load_scene
from sonolux.sound.bake import bake
from sonolux.sound.field import SoundField
from sonolux.sound.options import SoundOptions
from sonolux.version import __version__

__all__ = ["LightField", "LightOptions", "Scene", "SceneError", "SonoluxError", "SoundField",
           "SoundOptions", "__version__", "bake", "bake_light", "load_scene", "open",
           "open_light_field"]
