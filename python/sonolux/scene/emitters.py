"""What emits: sound sources (``[[sources]]``) and lights (``[[lights]]``).

A sound source must lie in the room's air (not outside the closed volume, not inside an
obstacle). It radiates ``power_w`` in every band, either in every direction
(``directivity = "omni"``), uniformly inside a cone of ``cone_half_angle_deg`` around ``axis``
(``"cone"``), or by a tabulated pattern oriented by ``forward`` and ``up`` (default +x and +z):
a built-in (``"cardioid"``, ``"supercardioid"``, ``"hypercardioid"``, ``"figure-of-eight"``,
``"dodecahedron"``, ``"talker"``; :mod:`sonolux.scene.directivity`) or a measured one,
``directivity = { sofa = "file.sofa" }`` (relative to the scene file;
:mod:`sonolux.scene.sofa_directivity`).

A light is resolved to emitting triangles:

- ``type = "rectangle"``: a ``size_m[0]`` x ``size_m[1]`` rectangle centred at ``center_m``,
  its first side along ``tangent`` (made perpendicular to ``normal``), emitting on the
  ``normal`` side. It is an emitter only: it is not added to the scene's surfaces.
- ``type = "surface"``: every scene triangle whose material is ``material`` emits, on the side
  its normal faces (into the room).

- ``type = "ies"``: a luminaire whose intensity distribution is read from an IES LM-63 file
  (``file``, relative to the scene file), placed at ``position_m`` with its γ = 0° axis along
  ``aim`` (default straight down) and its C = 0° plane towards ``c0_direction`` (default +x,
  made perpendicular to ``aim``); C grows counter-clockwise seen against the aim (from above
  for a downlight). It emits from that point (a far-field point source).

The light's ``power_w`` (radiant flux) is shared among its triangles by area. ``flux_lm``
gives it in lumens instead (see :mod:`sonolux.light.photometry`: 683 lm per radiant-equivalent
watt, photopic weighting of the colour). An "ies" luminaire emits the candela of its file
(absolute photometry) unless ``flux_lm`` is given, which scales the distribution to that flux.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError, close_matches
from sonolux.light.ies import read_ies
from sonolux.light.photometry import LUMINANCE_RGB, channel_flux_from_lumens
from sonolux.scene.directivity import BUILTIN
from sonolux.scene.inside import IN_AIR, IN_OBSTACLE, OUTSIDE, RoomSpace
from sonolux.scene.schema import Light, Material, SoundSource, Table
from sonolux.scene.sofa_directivity import read_sofa_directivity

SOURCE_KEYS = ("name", "position_m", "power_w", "directivity", "cone_half_angle_deg", "axis",
               "forward", "up")
LIGHT_TYPES = ("rectangle", "surface", "ies")
RECTANGLE_KEYS = ("name", "type", "center_m", "size_m", "normal", "tangent", "power_w",
                  "flux_lm", "color_rgb")
SURFACE_KEYS = ("name", "type", "material", "power_w", "flux_lm", "color_rgb")
IES_KEYS = ("name", "type", "file", "position_m", "aim", "c0_direction", "flux_lm", "color_rgb")
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
        sofa = None
        if isinstance(t.data.get("directivity"), dict):
            sofa = _read_sofa(t)
            directivity = "sofa"
        else:
            directivity = t.string("directivity", "omni", BUILTIN)
        half_angle, axis, forward, up = None, None, None, None
        if directivity == "cone":
            half_angle = t.number("cone_half_angle_deg", 45.0, lo=0.0, hi=180.0, lo_open=True)
            axis = _unit(t.vector("axis", 3, nonzero=True))
        else:
            for k in ("cone_half_angle_deg", "axis"):
                if t.has(k):
                    raise t.ctx.error(t.path(k), message='is only allowed with directivity = '
                                                         '"cone"')
        if directivity in ("omni", "cone"):
            for k in ("forward", "up"):
                if t.has(k):
                    raise t.ctx.error(t.path(k), message="is only allowed with a tabulated "
                                      "directivity (" + ", ".join(BUILTIN[2:]) + ", or sofa)")
        else:
            forward, up = _frame(t)
        sources.append(SoundSource(name, position_m, power_w, directivity, half_angle, axis,
                                   forward, up, sofa))
    return sources


def _frame(t: Table) -> tuple[np.ndarray, np.ndarray]:
    """A source's forward and up, unit and perpendicular (up made perpendicular to forward)."""
    forward = _unit(t.vector("forward", 3, [1.0, 0.0, 0.0], nonzero=True))
    up = t.vector("up", 3, [0.0, 0.0, 1.0], nonzero=True)
    across = up - forward * float(up @ forward)
    if np.linalg.norm(across) < 1e-6 * np.linalg.norm(up):
        raise t.ctx.error(t.path("up"), up.tolist(),
                          f"a direction not parallel to forward {forward.tolist()}")
    return forward, _unit(across)


def _read_sofa(t: Table) -> Any:
    """A ``directivity = { sofa = "file.sofa" }`` table: the file read and checked."""
    spec = t.table("directivity")
    assert spec is not None
    spec.check_keys(("sofa",))
    file = spec.string("sofa")
    path = Path(file) if Path(file).is_absolute() else t.ctx.base_dir / file
    try:
        return read_sofa_directivity(path)
    except SonoluxError as exc:
        raise spec.ctx.error(spec.path("sofa"), file,
                             f"a readable AES69 directivity ({exc})") from None


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
    position_m: np.ndarray | None = None  # ies
    frame: np.ndarray | None = None  # ies: float64[3, 3]
    photometry: Any = None  # ies


def read_lights(tables: list[Table]) -> list[LightSpec]:
    """The scene's lights as written (see :func:`resolve_lights`)."""
    specs, seen = [], set()
    for i, t in enumerate(tables):
        kind = t.string("type", "rectangle", LIGHT_TYPES)
        t.check_keys({"rectangle": RECTANGLE_KEYS, "surface": SURFACE_KEYS, "ies": IES_KEYS}[kind])
        name = _unique_name(t, f"L{i + 1}", seen)
        color_rgb = t.vector("color_rgb", 3, (1.0, 1.0, 1.0), lo=0.0)
        if kind == "ies":
            specs.append(_read_ies_light(t, name, color_rgb))
            continue
        if t.has("flux_lm") and t.has("power_w"):
            raise t.ctx.error(t.path("flux_lm"), message="give power_w or flux_lm, not both")
        if t.has("flux_lm"):
            flux_lm = t.number("flux_lm", lo=0.0, lo_open=True)
            if float(color_rgb @ LUMINANCE_RGB) <= 0:
                raise t.ctx.error(t.path("color_rgb"), color_rgb.tolist(),
                                  "a colour with some luminance when flux_lm is given")
            power_w = float(channel_flux_from_lumens(flux_lm, color_rgb).mean())
        else:
            power_w = t.number("power_w", 100.0, lo=0.0, lo_open=True)
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


def _read_ies_light(t: Table, name: str, color_rgb: np.ndarray) -> LightSpec:
    """An "ies" luminaire: its file read, its frame built, its candela scaled."""
    file = t.string("file")
    path = Path(file) if Path(file).is_absolute() else t.ctx.base_dir / file
    try:
        photometry = read_ies(path)
    except SonoluxError as exc:
        raise t.ctx.error(t.path("file"), file, f"a readable IES LM-63 file ({exc})") from None
    position_m = t.vector("position_m", 3)
    aim = _unit(t.vector("aim", 3, (0.0, 0.0, -1.0), nonzero=True))
    c0_given = t.vector("c0_direction", 3, (1.0, 0.0, 0.0), nonzero=True)
    c0 = c0_given - np.dot(c0_given, aim) * aim
    if np.linalg.norm(c0) < 1e-6 * np.linalg.norm(c0_given):
        raise t.ctx.error(t.path("c0_direction"), c0_given, "a direction not parallel to aim")
    c0 = _unit(c0)
    # C = 90° is counter-clockwise from C = 0° seen against the aim: c0 × aim, which for a
    # downlight (aim −z, c0 +x) is +y, as LM-63 type C photometry seen from above.
    c90 = np.cross(c0, aim)
    frame = np.ascontiguousarray([c0, c90, aim])
    file_flux = photometry.flux_lm()
    if file_flux <= 0:
        raise t.ctx.error(t.path("file"), file, "a luminaire that emits (all candela are zero)")
    if t.has("flux_lm"):
        target = t.number("flux_lm", lo=0.0, lo_open=True)
        photometry = replace(photometry, candela=photometry.candela * (target / file_flux))
        file_flux = target
    if float(color_rgb @ LUMINANCE_RGB) <= 0:
        raise t.ctx.error(t.path("color_rgb"), color_rgb.tolist(), "a colour with some luminance")
    power_w = float(channel_flux_from_lumens(file_flux, color_rgb).mean())
    return LightSpec(t, name, "ies", power_w, color_rgb, triangles_m=np.zeros((0, 3, 3)),
                     position_m=position_m, frame=frame, photometry=photometry)


def resolve_lights(specs: list[LightSpec], triangles_m: np.ndarray, materials: list[Material],
                   material_index: np.ndarray, space: RoomSpace,
                   warnings: list[str]) -> list[Light]:
    """Lights with their emitting triangles; triangles_m float64[m, 3, 3] is the scene's."""
    lights = []
    used = [m.name for m in materials]
    for spec in specs:
        t = spec.table
        if spec.kind == "ies":
            assert spec.position_m is not None
            if int(space.classify(spec.position_m)[0]) != IN_AIR:
                warnings.append(f"{t.path('position_m')}: luminaire {spec.name!r} is not inside "
                                "the room")
            lights.append(Light(spec.name, spec.kind, np.zeros((0, 3, 3)), spec.power_w,
                                spec.color_rgb, position_m=spec.position_m, frame=spec.frame,
                                photometry=spec.photometry))
            continue
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
