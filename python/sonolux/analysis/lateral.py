"""Lateral energy from a true figure-of-eight (ISO 3382-1:2009, A.2.4 and A.2.5), for fields
whose receivers carry directional channels (:mod:`sonolux.scene.receiver_channels`).

At a point with an omnidirectional channel (p) and a figure-of-eight channel (p_L, its maximum
calibrated to the omni's, its null towards the source when its ``forward`` is "lateral"):

- JLF = ∫_{5 ms}^{80 ms} p_L² dt / ∫_0^{80 ms} p² dt,
- JLFC = ∫_{5 ms}^{80 ms} |p_L · p| dt / ∫_0^{80 ms} p² dt: for an arrival from direction u,
  p_L = p (u·n), so |p_L p| = p² |u·n|, the energy of the figure-of-eight's ``|cos|``
  companion channel,
- LG = 10 lg(∫_{80 ms}^∞ p_L² dt / ∫ p_10² dt), p_10 the free-field response at 10 m (the
  reference of G, :func:`sonolux.analysis.decay.strength_g_db`),

times counted from the omni channel's direct sound (the onset of A.3.4). The values are shown
on the omni channel's row; the other channels' rows have NaN. This module finds a point's
channels; :func:`sonolux.analysis.params.room_parameters` integrates them.
"""

from __future__ import annotations

from typing import Any

from sonolux.errors import AnalysisError
from sonolux.scene.receiver_channels import LATERAL_PRODUCT


def channel_record(field_) -> dict[str, Any] | None:
    """The field's ``receiver_channels`` record, checked against its receivers (a damaged
    file is refused by name); None without channels."""
    record = (getattr(field_, "settings", None) or {}).get("receiver_channels")
    if not record:
        return None
    n = field_.n_receivers
    try:
        channels, channel_of, point_of = (record["channels"], record["channel_of"],
                                          record["point_of"])
        ok = (len(channel_of) == n and len(point_of) == n
              and all(isinstance(c["name"], str) and isinstance(c["pattern"], str)
                      for c in channels)
              and all(isinstance(k, int) and 0 <= k < len(channels) for k in channel_of)
              and all(isinstance(k, int) and 0 <= k < n for k in point_of))
    except (KeyError, TypeError):
        ok = False
    if not ok:
        raise AnalysisError(f"{getattr(field_, 'path', None) or 'the field'}: its "
                            f"receiver_channels record does not describe its {n} receivers "
                            "(a damaged file?)")
    return record


def companions(field_, r: int) -> tuple[int, int] | None:
    """(figure-of-eight receiver, |cos| receiver) at receiver r's point when r is the point's
    omni channel and the point has a figure-of-eight; else None."""
    record = channel_record(field_)
    if record is None:
        return None
    channels, channel_of, point_of = (record["channels"], record["channel_of"],
                                      record["point_of"])
    if channels[channel_of[r]]["pattern"] != "omni":
        return None
    same = [k for k in range(len(point_of)) if point_of[k] == point_of[r]]
    eight = [k for k in same if channels[channel_of[k]]["pattern"] == "figure-of-eight"]
    if not eight:
        return None
    name = channels[channel_of[eight[0]]]["name"] + "|cos|"
    product = [k for k in same if channels[channel_of[k]]["name"] == name
               and channels[channel_of[k]]["pattern"] == LATERAL_PRODUCT]
    return (eight[0], product[0]) if product else None


def channel_names(field_) -> list[str]:
    """The channel name of every receiver of the field ([] without channels)."""
    record = channel_record(field_)
    if record is None:
        return []
    return [record["channels"][k]["name"] for k in record["channel_of"]]


def channel_groups(field_) -> list[tuple[str, list[int]]]:
    """[(channel name, its receivers)] in channel order; [] without channels."""
    names = channel_names(field_)
    order = list(dict.fromkeys(names))
    return [(n, [r for r, m in enumerate(names) if m == n]) for n in order]
