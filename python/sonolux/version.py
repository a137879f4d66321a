"""The version of sonolux: the installed distribution's, or the source tree's."""

from __future__ import annotations

try:
    from importlib.metadata import PackageNotFoundError, version

    __version__ = version("sonolux")
except PackageNotFoundError:  # running from the source tree (PYTHONPATH=python)
    __version__ = "0.1.0"
