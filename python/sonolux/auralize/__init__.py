"""Auralization: hearing a sound field (the paper's playback, section 2.3).

A listener's cell is found from their position; its responses, one per direction bin, are
convolved with a dry (anechoic) signal; each direction becomes a virtual source at its bin's
centre, rotated by the listener's heading; the virtual sources go to a layout: headphones
(binaural), the paper's cube of eight loudspeakers, ambisonics, stereo, 5.1 or 7.1.

- :mod:`.convolve`: the cells' responses, multi-band equivalence, the partitioned convolver;
- :mod:`.layouts`, :mod:`.binaural`, :mod:`.ambisonics`: the outputs; :mod:`.render`: rotation
  and spatializers; :mod:`.stream`: the block renderer; :mod:`.offline`: whole signals;
  :mod:`.walk`: walk-throughs; :mod:`.signals`: built-in dry signals; :mod:`.cli`: the command.

See docs/auralize.md for the conventions, channel orders and latency. The names below are
imported on first use, so that ``sonolux --help`` stays fast.
"""

from __future__ import annotations

_EXPORTS = {"AuralizeSettings": "offline", "auralize": "offline", "load_dry": "offline",
            "StreamRenderer": "stream", "WalkSettings": "walk", "auralize_walk": "walk",
            "load_path": "walk"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(f"sonolux.auralize.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'sonolux.auralize' has no attribute {name!r}")
