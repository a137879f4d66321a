"""The engine's receiver patterns of a scene's directional channels
(:mod:`sonolux.scene.receiver_channels`), one per receiver, and what the field records of them.

A channel's ``forward = "lateral"`` is resolved per point here: horizontal and perpendicular to
the line to the first source (ISO 3382-1 A.2.4: the figure-of-eight's null towards the source).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.errors import SonoluxError
from sonolux.scene.receiver_channels import (
    FIRST_ORDER,
    LATERAL_PRODUCT,
    lateral_axis,
    sofa_receiver_gains,
)
from sonolux.scene.schema import Scene


def receiver_patterns(scene: Scene, bands: slice | None = None,
                      sofa_gains: dict[int, np.ndarray] | None = None) -> list[Any] | None:
    """One ``engine.ReceiverPattern`` a receiver of the scene, or None when all are omni.
    ``bands``: the patterns of those bands only (a level of detail's band group, whose tracer
    sees its own bands: only SOFA channels depend on the band); ``sofa_gains``: the SOFA
    channels' gains over every band, if already computed (:func:`banded_patterns`)."""
    rec = scene.receivers
    if not rec.channels:
        return None
    if sofa_gains is None:
        edges = scene.settings.band_set.edges_hz
        sofa_gains = {k: sofa_receiver_gains(c.sofa, edges)
                      for k, c in enumerate(rec.channels) if c.pattern == "sofa"}
    if bands is not None:  # each band's gains are its own (the band's mean |H|²): a slice
        sofa_gains = {k: np.ascontiguousarray(g[:, :, bands]) for k, g in sofa_gains.items()}
    assert rec.channel_of is not None
    out = []
    for r, k in enumerate(rec.channel_of):
        c = rec.channels[int(k)]
        forward = c.forward
        if isinstance(forward, str):  # "lateral"
            forward = lateral_axis(rec.positions_m[r], scene.sources[0].position_m)
        if c.pattern == "sofa":
            if abs(float(np.dot(forward, c.up))) > 1.0 - 1e-6:
                raise SonoluxError(f"receiver channel {c.name!r}: its up {np.asarray(c.up).tolist()} "
                                   f"is parallel to its forward {np.round(forward, 6).tolist()}")
            out.append(engine.ReceiverPattern.measured(sofa_gains[int(k)], tuple(forward),
                                                       tuple(c.up)))
        elif c.pattern == LATERAL_PRODUCT:
            out.append(engine.ReceiverPattern.first_order(0.0, tuple(forward), 1.0))
        elif c.pattern == "omni":
            out.append(engine.ReceiverPattern.omni())
        else:
            out.append(engine.ReceiverPattern.first_order(FIRST_ORDER[c.pattern], tuple(forward)))
    return out


def banded_patterns(scene: Scene) -> Callable[[slice], list[Any]] | None:
    """The receivers' patterns as a function of a band group (:func:`receiver_patterns` with
    ``bands``), the SOFA gains computed once; None when no channel depends on the band (then the
    patterns of every band serve every group)."""
    rec = scene.receivers
    if not rec.channels or not any(c.pattern == "sofa" for c in rec.channels):
        return None
    edges = scene.settings.band_set.edges_hz
    gains = {k: sofa_receiver_gains(c.sofa, edges)
             for k, c in enumerate(rec.channels) if c.pattern == "sofa"}

    def of(bands: slice) -> list[Any]:
        patterns = receiver_patterns(scene, bands, gains)
        assert patterns is not None
        return patterns
    return of


def channels_record(scene: Scene) -> dict[str, Any] | None:
    """The field's record of the channels (settings JSON ``receiver_channels``): ``channels``
    (one description each), ``channel_of`` and ``point_of`` (one index a receiver); None for
    omnidirectional receivers."""
    rec = scene.receivers
    if not rec.channels:
        return None
    return {"channels": [c.describe() for c in rec.channels],
            "channel_of": np.asarray(rec.channel_of).tolist(),
            "point_of": np.asarray(rec.point_of).tolist()}
