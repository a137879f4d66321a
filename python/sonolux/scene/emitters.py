"""What emits: sound sources (``[[sources]]``) and lights (``[[lights]]``).

A sound source must lie in the room's air (not outside the closed volume, not inside an
obstacle). It radiates ``power_w`` either in every direction (``directivity = "omni"``) or
uniformly inside a cone of ``cone_half_angle_deg`` around ``axis`` (``"cone"``).

A light is resolved to emitting triangles:

- ``type = "rectangle"``: a ``size_m[0]`` x ``size_m[1]`` rectangle centred at ``center_m``,
  its first side along ``tangent`` (made perpendicular to ``normal``), emitting on the
  ``normal`` side. It is an emitter only: it is not added to the scene's surfaces.
- ``type = "surface"``: every scene triangle whose material is ``material`` emits, on the side
  its normal faces (into the room).

The light's ``power_w`` (radiant flux) is shared among its triangles by area.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.errors import close_matches
from sonolux.scene.inside import IN_AIR, IN_OBSTACLE, OUTSIDE, RoomSpace
from sonolux.scene.schema import Light, Material, SoundSource, Table

SOURCE_KEYS = ("name", "position_m", "power_w", "directivity", "cone_half_angle_deg", "axis")
LIGHT_TYPES = ("rectangle", "surface")
RECTANGLE_KEYS = ("name", "type", "center_m", "size_m", "normal", "tangent", "power_w",
                  "color_rgb")
SURFACE_KEYS = ("name", "type", "material", "power_w", "color_rgb")
#: A source or light nearer than this to a surface is reported (it may leak through).
NEAR_SURFACE_M = 1e-3


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _unique_name(t: Table, default: str, seen: set[str]) -> str:
    name = t.string("name", default)
    if name in seen:
        raise t.ctx.error(t.path("name"), name, "a name not used by another entry")
    seen.add(name)
    return name


def read_sources(tables: list[Table]) -> list[SoundSource]:
    """The scene's sound sources as written (see :func:`place_sources` for the room check)."""
    sources, seen = [], set()
    for i, t in enumerate(tables):
        t.check_keys(SOURCE_KEYS)
        name = _unique_name(t, f"S{i + 1}", seen)
        position_m = t.vector("position_m", 3)
        power_w = t.number("power_w", 1.0, lo=0.0, lo_open=True)
        directivity = t.string("directivity", "omni", ("omni", "cone"))
        half_angle, axis = None, None
        if directivity == "cone":
            half_angle = t.number("cone_half_angle_deg", 45.0, lo=0.0, hi=180.0, lo_open=True)
            axis = _unit(t.vector("axis", 3, nonzero=True))
        else:
            for k in ("cone_half_angle_deg", "axis"):
                if t.has(k):
                    raise t.ctx.error(t.path(k), message='is only allowed with directivity = '
                                                         '"cone"')
        sources.append(SoundSource(name, position_m, power_w, directivity, half_angle, axis))
    return sources


def place_sources(sources: list[SoundSource], tables: list[Table], space: RoomSpace,
                  warnings: list[str]) -> None:
    """Reject a source outside the room's air; warn of one (almost) on a surface."""
    if not sources:
        return
    positions = np.array([s.position_m for s in sources])
    where = space.classify(positions)
    distance = space.distance_to_surface(positions)
    for s, t, w, d in zip(sources, tables, where, distance):
        if w != IN_AIR:
            why = {OUTSIDE: "this one is outside the closed volume",
                   IN_OBSTACLE: "this one is inside an obstacle"}[int(w)]
            raise t.ctx.error(t.path("position_m"), s.position_m,
                              f"a point inside the room; {why}")
        if d < NEAR_SURFACE_M:
            warnings.append(f"{t.path('position_m')}: source {s.name!r} is within "
                            f"{NEAR_SURFACE_M * 1000:g} mm of a surface")


def rectangle_triangles(center_m: np.ndarray, size_m: np.ndarray, normal: np.ndarray,
                        tangent: np.ndarray) -> np.ndarray:
    """float64[2, 3, 3]: two triangles covering the rectangle, normals along ``normal``.

    ``tangent`` must already be a unit vector perpendicular to the unit ``normal``.
    """
    bitangent = np.cross(normal, tangent)
    a, b = 0.5 * size_m[0] * tangent, 0.5 * size_m[1] * bitangent
    p00, p10, p11, p01 = center_m - a - b, center_m + a - b, center_m + a + b, center_m - a + b
    # cross(p10 - p00, p11 - p00) = tangent x bitangent (scaled) = normal.
    return np.ascontiguousarray([[p00, p10, p11], [p00, p11, p01]], dtype=np.float64)


@dataclass(frozen=True, eq=False)
class LightSpec:
    """A light as written; a surface light's triangles are found once the geometry is built."""

    table: Table
    name: str
    kind: str
    power_w: float
    color_rgb: np.ndarray
    triangles_m: np.ndarray | None = None  # rectangle: float64[2, 3, 3]
    material: str | None = None  # surface: the emitting material's name


def read_lights(tables: list[Table]) -> list[LightSpec]:
    """The scene's lights as written (see :func:`resolve_lights`)."""
    specs, seen = [], set()
    for i, t in enumerate(tables):
        kind = t.string("type", "rectangle", LIGHT_TYPES)
        t.check_keys(RECTANGLE_KEYS if kind == "rectangle" else SURFACE_KEYS)
        name = _unique_name(t, f"L{i + 1}", seen)
        power_w = t.number("power_w", 100.0, lo=0.0, lo_open=True)
        color_rgb = t.vector("color_rgb", 3, (1.0, 1.0, 1.0), lo=0.0)
        if kind == "surface":
            specs.append(LightSpec(t, name, kind, power_w, color_rgb,
                                   material=t.string("material")))
            continue
        center_m = t.vector("center_m", 3)
        size_m = t.vector("size_m", 2, lo=0.0, lo_open=True)
        normal = _unit(t.vector("normal", 3, (0.0, 0.0, -1.0), nonzero=True))
        tangent_given = t.vector("tangent", 3, (1.0, 0.0, 0.0), nonzero=True)
        tangent = tangent_given - np.dot(tangent_given, normal) * normal
        if np.linalg.norm(tangent) < 1e-6 * np.linalg.norm(tangent_given):
            raise t.ctx.error(t.path("tangent"), tangent_given,
                              "a direction not parallel to normal")
        tris = rectangle_triangles(center_m, size_m, normal, _unit(tangent))
        specs.append(LightSpec(t, name, kind, power_w, color_rgb, triangles_m=tris))
    return specs


def resolve_lights(specs: list[LightSpec], triangles_m: np.ndarray, materials: list[Material],
                   material_index: np.ndarray, space: RoomSpace,
                   warnings: list[str]) -> list[Light]:
    """Lights with their emitting triangles; triangles_m float64[m, 3, 3] is the scene's."""
    lights = []
    used = [m.name for m in materials]
    for spec in specs:
        t = spec.table
        if spec.kind == "rectangle":
            tris = spec.triangles_m
            assert tris is not None
            centre = tris[0, [0, 2]].mean(axis=0)
            if int(space.classify(centre)[0]) != IN_AIR:
                warnings.append(f"{t.path('center_m')}: light {spec.name!r} is not inside the "
                                "room")
        else:
            if spec.material not in used:
                raise t.ctx.error(t.path("material"), spec.material,
                                  "the name of a material used by the geometry ("
                                  + ", ".join(used) + ")",
                                  matches=close_matches(str(spec.material), used))
            tris = np.ascontiguousarray(triangles_m[material_index == used.index(spec.material)])
        lights.append(Light(spec.name, spec.kind, tris, spec.power_w, spec.color_rgb,
                            material=spec.material))
    return lights
