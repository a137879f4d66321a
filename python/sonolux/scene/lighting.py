"""What a scene says about daylight (``[daylight]``) and about where illuminance is measured
(``[workplane]``). Validated here, once; the physics lives in :mod:`sonolux.light.daylight` and
:mod:`sonolux.light.workplane`.

``[daylight]``: ``sky = "overcast"`` (the CIE standard overcast sky; ``sky_horizontal_lx``
defaults to 10 000 lx) or ``"clear"`` (the CIE standard clear sky with the sun; needs
``date_time`` (a TOML date-time with its UTC offset), ``latitude_deg``, ``longitude_deg``,
``sky_horizontal_lx`` and ``sun_normal_lx``); ``north_deg`` (the direction of north in the
scene, counter-clockwise from +y; default 0: +y is north, +x east) and ``ground_reflectance``
(default 0.2). Daylight enters through every triangle whose material has a transmittance.

``[workplane]``: ``height_m`` (default 0.8 m, the usual height of a desk's work plane),
``spacing_m`` (default from EN 12464-1:2011 §4.4 / EN 12464-1:2021 §5.2.3: p = 0.2 × 5^log10(d)
m, d the longer side of the floor plan), ``origin_m`` (default the floor plan's centre, as the
sound receivers' grid).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime

import numpy as np

from sonolux.scene.inside import IN_AIR, RoomSpace
from sonolux.scene.receivers import MAX_CANDIDATES, grid_candidates
from sonolux.scene.schema import Context, Table

DAYLIGHT_KEYS = ("sky", "sky_horizontal_lx", "sun_normal_lx", "date_time", "latitude_deg",
                 "longitude_deg", "north_deg", "ground_reflectance")
WORKPLANE_KEYS = ("height_m", "spacing_m", "origin_m")
DEFAULT_WORKPLANE_HEIGHT_M = 0.8


@dataclass(frozen=True)
class DaylightSpec:
    sky: str
    sky_horizontal_lx: float | None
    sun_normal_lx: float
    date_time: datetime | None
    latitude_deg: float | None
    longitude_deg: float | None
    north_deg: float
    ground_reflectance: float


def read_daylight(t: Table | None) -> DaylightSpec | None:
    if t is None:
        return None
    t.check_keys(DAYLIGHT_KEYS)
    sky = t.string("sky", "overcast", ("overcast", "clear"))
    common = {"north_deg": t.number("north_deg", 0.0, lo=-360.0, hi=360.0),
              "ground_reflectance": t.number("ground_reflectance", 0.2, lo=0.0, hi=1.0)}
    if sky == "overcast":
        for k in ("sun_normal_lx", "date_time", "latitude_deg", "longitude_deg"):
            if t.has(k):
                raise t.ctx.error(t.path(k), message='is only used with sky = "clear" (the '
                                                     'overcast sky has no sun)')
        return DaylightSpec(sky, t.number("sky_horizontal_lx", 10_000.0, lo=0.0, lo_open=True),
                            0.0, None, None, None, **common)
    when = t.data.get("date_time")
    if not isinstance(when, datetime) or when.tzinfo is None:
        raise t.ctx.error(t.path("date_time"), when, "a TOML date-time with its UTC offset, e.g. "
                                                     "2024-06-21T12:00:00+01:00")
    return DaylightSpec(sky, t.number("sky_horizontal_lx", lo=0.0, lo_open=True),
                        t.number("sun_normal_lx", lo=0.0), when,
                        t.number("latitude_deg", lo=-90.0, hi=90.0),
                        t.number("longitude_deg", lo=-180.0, hi=180.0), **common)


@dataclass(frozen=True, eq=False)
class WorkplaneSpec:
    """The work-plane grid: cells of ``spacing_m`` centred at ``origin_m + spacing_m * (i, j)``
    at ``height_m``; ``positions_m`` float64[k, 3] and ``grid_index`` int64[k, 2] of the cells
    whose centre is in the room's air (rows along +x, as the sound receivers)."""

    height_m: float
    spacing_m: float
    origin_m: np.ndarray
    positions_m: np.ndarray
    grid_index: np.ndarray
    candidates: int


def en12464_spacing_m(longer_side_m: float) -> float:
    """EN 12464-1 grid spacing p = 0.2 × 5^log10(d) m for an area whose longer side is d."""
    return 0.2 * 5 ** math.log10(max(longer_side_m, 1e-9))


def place_workplane(t: Table | None, ctx: Context, space: RoomSpace, bbox_min: np.ndarray,
                    bbox_max: np.ndarray, warnings: list[str]) -> WorkplaneSpec:
    if t is not None:
        t.check_keys(WORKPLANE_KEYS)
    extent = bbox_max[:2] - bbox_min[:2]
    default_spacing = en12464_spacing_m(float(extent.max()))
    height = t.number("height_m", DEFAULT_WORKPLANE_HEIGHT_M) if t else DEFAULT_WORKPLANE_HEIGHT_M
    spacing = t.number("spacing_m", default_spacing, lo=0.0, lo_open=True) if t else default_spacing
    origin = t.vector("origin_m", 2, None) if t else None
    estimate = float(np.prod(np.floor(extent / spacing) + 2))
    if estimate > MAX_CANDIDATES:
        raise ctx.error("workplane.spacing_m", spacing,
                        f"a spacing giving at most {MAX_CANDIDATES} cells (this gives about "
                        f"{estimate:.0f})")
    origin_m = (0.5 * (bbox_min[:2] + bbox_max[:2]) if origin is None
                else np.asarray(origin, float))
    positions, index = grid_candidates(bbox_min, bbox_max, origin_m, spacing, height)
    keep = space.classify(positions) == IN_AIR if positions.shape[0] else np.zeros(0, bool)
    if not np.any(keep):
        warnings.append(f"no work-plane cell at height {height:g} m is inside the room")
    return WorkplaneSpec(height, spacing, origin_m, np.ascontiguousarray(positions[keep]),
                         np.ascontiguousarray(index[keep]), int(positions.shape[0]))
