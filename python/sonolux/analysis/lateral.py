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

from sonolux.scene.receiver_channels import LATERAL_PRODUCT


def companions(field_, r: int) -> tuple[int, int] | None:
    """(figure-of-eight receiver, |cos| receiver) at receiver r's point when r is the point's
    omni channel and the point has a figure-of-eight; else None."""
    record = field_.settings.get("receiver_channels")
    if not record:
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
    record = field_.settings.get("receiver_channels")
    if not record:
        return []
    return [record["channels"][k]["name"] for k in record["channel_of"]]


def channel_groups(field_) -> list[tuple[str, list[int]]]:
    """[(channel name, its receivers)] in channel order; [] without channels."""
    names = channel_names(field_)
    order = list(dict.fromkeys(names))
    return [(n, [r for r, m in enumerate(names) if m == n]) for n in order]
