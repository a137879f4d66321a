"""Sound receivers: spheres of ``radius_m`` where arriving sound is recorded.

``type = "grid"`` (the default) lays candidate centres on a square grid at ``height_m``:
``origin_m + spacing_m * (i, j)`` for every integer (i, j) whose centre lies strictly inside the
geometry's bounding box in x and y. ``origin_m`` defaults to the centre of that box, so a
cell sits at the centre of the floor plan (where the paper puts its talker). ``type =
"points"`` takes the centres as given in ``positions_m``.

Candidates are then dropped, each for the first reason that applies, and counted:
outside the room; inside a closed obstacle; closer than ``radius_m`` to a surface (the
sphere would cut it). See :mod:`sonolux.scene.inside` for how inside is decided.

Points may carry directional ``channels`` (:mod:`sonolux.scene.receiver_channels`): each kept
point then holds one receiver per channel, consecutive in the field.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.scene.inside import IN_AIR, IN_OBSTACLE, OUTSIDE, RoomSpace
from sonolux.scene.receiver_channels import read_channels
from sonolux.scene.schema import Context, Receivers, Table, check_vector

RECEIVER_TYPES = ("grid", "points")
GRID_KEYS = ("type", "height_m", "spacing_m", "radius_m", "origin_m")
POINTS_KEYS = ("type", "positions_m", "radius_m", "channels")
DEFAULT_HEIGHT_M = 1.5
DEFAULT_SPACING_M = 1.0
DEFAULT_RADIUS_M = 0.25
#: The smallest receiver sphere (the core divides by its volume; 0.1 mm, as the binding).
MIN_RADIUS_M = 1e-4
#: More candidates than this is almost surely a spacing given in the wrong unit.
MAX_CANDIDATES = 200_000


def grid_candidates(bbox_min: np.ndarray, bbox_max: np.ndarray, origin_m: np.ndarray,
                    spacing_m: float, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(positions float64[k, 3], grid_index int64[k, 2]) strictly inside the xy bounding box.

    Ordered by j (y) then i (x), so that rows run along +x.
    """
    lo = np.floor((bbox_min[:2] - origin_m) / spacing_m).astype(np.int64)
    hi = np.ceil((bbox_max[:2] - origin_m) / spacing_m).astype(np.int64)
    i = np.arange(lo[0], hi[0] + 1)
    j = np.arange(lo[1], hi[1] + 1)
    jj, ii = np.meshgrid(j, i, indexing="ij")
    index = np.stack([ii.reshape(-1), jj.reshape(-1)], axis=1)
    xy = origin_m + spacing_m * index
    # Strictly inside, with a margin of a nanometre per metre against rounding.
    eps = 1e-9 * max(1.0, float(np.max(np.abs(bbox_max - bbox_min))))
    keep = np.all((xy > bbox_min[:2] + eps) & (xy < bbox_max[:2] - eps), axis=1)
    xy, index = xy[keep], index[keep]
    positions = np.column_stack([xy, np.full(xy.shape[0], height_m)])
    return np.ascontiguousarray(positions), np.ascontiguousarray(index)


@dataclass(frozen=True, eq=False)
class ReceiverSpec:
    """``[receivers]`` as written; ``origin_m`` None means the floor plan's centre."""

    kind: str = "grid"
    radius_m: float = DEFAULT_RADIUS_M
    height_m: float = DEFAULT_HEIGHT_M
    spacing_m: float = DEFAULT_SPACING_M
    origin_m: np.ndarray | None = None
    positions_m: np.ndarray | None = None  # points: float64[k, 3]
    key: str = "receivers"
    channels: tuple = ()  # points: the directional channels (empty: omni)


def read_receivers(t: Table | None) -> ReceiverSpec:
    """Validate ``[receivers]`` (None: the default grid)."""
    if t is None:
        return ReceiverSpec()
    kind = t.string("type", "grid", RECEIVER_TYPES)
    if kind == "grid":
        if "channels" in t.data:
            raise t.ctx.error(t.path("channels"), t.data["channels"],
                              message="directional channels are for type = \"points\" only; "
                              "a grid's receivers are omnidirectional")
        t.check_keys(GRID_KEYS)
        spacing_m = t.number("spacing_m", DEFAULT_SPACING_M, lo=0.0, lo_open=True)
        return ReceiverSpec(
            kind, height_m=t.number("height_m", DEFAULT_HEIGHT_M), spacing_m=spacing_m,
            radius_m=t.number("radius_m", min(DEFAULT_RADIUS_M, spacing_m), lo=MIN_RADIUS_M,
                              hi=spacing_m),
            origin_m=t.vector("origin_m", 2, None), key=t.key)
    t.check_keys(POINTS_KEYS)
    radius_m = t.number("radius_m", DEFAULT_RADIUS_M, lo=MIN_RADIUS_M, hi=1e4)
    raw = t.data.get("positions_m")
    key = t.path("positions_m")
    if not isinstance(raw, list) or not raw:
        raise t.ctx.error(key, raw, "a non-empty list of [x, y, z] positions")
    positions = np.array([check_vector(t.ctx, f"{key}[{i}]", p, 3, "a list of 3 numbers")
                          for i, p in enumerate(raw)], dtype=np.float64)
    channels = read_channels(t) if "channels" in t.data else ()
    if len(channels) == 1 and channels[0].pattern == "omni":
        channels = ()
    return ReceiverSpec(kind, radius_m=radius_m, positions_m=positions, key=t.key,
                        channels=channels)


def place_receivers(spec: ReceiverSpec, ctx: Context, space: RoomSpace, bbox_min: np.ndarray,
                    bbox_max: np.ndarray, warnings: list[str]) -> Receivers:
    """Lay out the candidates and keep those in the room's air, clear of every surface."""
    if spec.kind == "points":
        positions = spec.positions_m
        assert positions is not None
        kept, counts, why = _filter(positions, spec.radius_m, space)
        for i in np.flatnonzero(~kept):
            warnings.append(f"{spec.key}.positions_m[{i}] = {positions[i].tolist()} is dropped: "
                            f"{why[i]}")
        points = positions[kept]
        if not spec.channels:
            return Receivers("points", np.ascontiguousarray(points), spec.radius_m,
                             candidates=positions.shape[0], **counts)
        n_ch = len(spec.channels)
        return Receivers("points", np.ascontiguousarray(np.repeat(points, n_ch, axis=0)),
                         spec.radius_m, candidates=positions.shape[0], **counts,
                         channels=spec.channels,
                         channel_of=np.tile(np.arange(n_ch, dtype=np.int64), len(points)),
                         point_of=np.repeat(np.arange(len(points), dtype=np.int64), n_ch))
    extent = bbox_max[:2] - bbox_min[:2]
    estimate = float(np.prod(np.floor(extent / spec.spacing_m) + 2))
    if estimate > MAX_CANDIDATES:
        raise ctx.error(f"{spec.key}.spacing_m", message=(
            f"{spec.spacing_m:g} m gives about {estimate:.0f} receivers over {extent[0]:g} x "
            f"{extent[1]:g} m; at most {MAX_CANDIDATES} are allowed"))
    origin_m = (0.5 * (bbox_min[:2] + bbox_max[:2]) if spec.origin_m is None
                else np.asarray(spec.origin_m, dtype=np.float64))
    positions, index = grid_candidates(bbox_min, bbox_max, origin_m, spec.spacing_m,
                                       spec.height_m)
    kept, counts, _ = _filter(positions, spec.radius_m, space)
    if not np.any(kept):
        warnings.append(f"no receiver is left of the {positions.shape[0]} grid candidates at "
                        f"height {spec.height_m:g} m (outside: {counts['dropped_outside']}, "
                        f"inside obstacles: {counts['dropped_inside_obstacle']}, nearer than "
                        f"{spec.radius_m:g} m to a surface: {counts['dropped_near_surface']})")
    return Receivers("grid", np.ascontiguousarray(positions[kept]), spec.radius_m,
                     height_m=spec.height_m, spacing_m=spec.spacing_m, origin_m=origin_m,
                     grid_index=np.ascontiguousarray(index[kept]),
                     candidates=positions.shape[0], **counts)


def _filter(positions: np.ndarray, radius_m: float,
            space: RoomSpace) -> tuple[np.ndarray, dict[str, int], list[str]]:
    """(kept bool[k], counts of each reason, reason of each point ("" when kept))."""
    where = space.classify(positions)
    in_air = where == IN_AIR
    near = np.zeros(positions.shape[0], dtype=bool)
    if np.any(in_air):
        near[in_air] = space.distance_to_surface(positions[in_air]) < radius_m
    kept = in_air & ~near
    why = ["outside the room" if w == OUTSIDE else "inside an obstacle" if w == IN_OBSTACLE
           else "nearer to a surface than its radius" if n else ""
           for w, n in zip(where, near)]
    return kept, {"dropped_outside": int(np.sum(where == OUTSIDE)),
                  "dropped_inside_obstacle": int(np.sum(where == IN_OBSTACLE)),
                  "dropped_near_surface": int(np.sum(near))}, why
