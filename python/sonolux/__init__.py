"""sonolux: one particle tracer for light and sound, to see and hear a virtual space.

The Rust core (``sonolux._core``) traces; this package loads scenes, checks them, and analyses
what the core returns. Start with :func:`load_scene` and the ``sonolux`` command line.
"""

from __future__ import annotations

from sonolux.errors import SceneError, SonoluxError
from sonolux.scene import Scene, load_scene

try:
    from importlib.metadata import PackageNotFoundError, version

    __version__ = version("sonolux")
except PackageNotFoundError:  # running from the source tree (PYTHONPATH=python)
    __version__ = "0.1.0"

__all__ = ["Scene", "SceneError", "SonoluxError", "__version__", "load_scene"]
