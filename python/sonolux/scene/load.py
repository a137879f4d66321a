"""Loading a scene: from a TOML file, a dict of the same shape, or a built-in name.

There is one schema (documented in ``docs/scene.md``); a TOML file is parsed into a dict and
read like any other. The steps:

1. parse (TOML syntax errors name the line) and check the top-level keys;
2. read ``[settings]`` and the scene's ``[materials]``;
3. build every ``[[geometry]]`` entry (shoebox or mesh) and join them into one triangle set,
   welding vertices that coincide (within a micrometre) so that edges are shared;
4. hand the triangles to the core for its report; reject an empty or volume-less geometry, and
   turn the report's mesh problems into warnings that say where;
5. place sources (which must be in the room's air), lights and receivers.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.engine import Geometry
from sonolux.errors import CoreMissingError, SceneError, SonoluxError, close_matches
from sonolux.limits import MAX_COORDINATE_M, MAX_SEED, MAX_THREADS, MAX_TIME_S
from sonolux.scene import builtin
from sonolux.scene.band_settings import held_band_warnings, read_bands
from sonolux.scene.early import read_early
from sonolux.scene.emitters import place_sources, read_lights, read_sources, resolve_lights
from sonolux.scene.inside import RoomSpace
from sonolux.scene.lighting import place_workplane, read_daylight
from sonolux.scene.material_names import MaterialNames
from sonolux.scene.materials import Library
from sonolux.scene.meshes import build_mesh
from sonolux.scene.receivers import place_receivers, read_receivers
from sonolux.scene.schema import (
    WALL_MODELS,
    Air,
    Context,
    GeometryPart,
    Material,
    Scene,
    Settings,
    Table,
)
from sonolux.scene.shoebox import build_shoebox
from sonolux.scene.speech import read_speech
from sonolux.scene.waves import read_waves

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

ROOT_KEYS = ("name", "settings", "materials", "geometry", "sources", "lights", "receivers",
             "daylight", "workplane", "early", "speech", "waves")
SETTINGS_KEYS = ("sample_rate_hz", "bands", "bands_hz", "band_range_hz", "energy_drop_db",
                 "max_time_s", "seed", "threads", "air", "wall_model")
AIR_KEYS = ("temperature_c", "humidity_percent", "pressure_kpa")
GEOMETRY_TYPES = ("shoebox", "mesh")
#: Vertices closer than this are joined.
WELD_TOLERANCE_M = 1e-6
#: A geometry whose |signed volume| is below this share of its bounding-box diagonal cubed
#: encloses nothing.
MIN_RELATIVE_VOLUME = 1e-6


def load_scene(scene: Any, *, library: Library | None = None,
               base_dir: str | os.PathLike | None = None) -> Scene:
    """Load a scene from a path to a ``.toml`` file, a dict, or a built-in name.

    ``library`` replaces the shipped material library (tests use a small one); ``base_dir`` is
    where a dict's relative mesh paths start (default: the current directory).
    """
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        ctx = Context("<dict>", None, Path(base_dir) if base_dir is not None else Path.cwd())
        return scene_from_dict(scene, ctx, library, default_name="scene")
    if isinstance(scene, (str, os.PathLike)):
        path = Path(scene)
        text = str(scene)
        if path.suffix.lower() == ".toml" or path.exists() or os.sep in text or "/" in text:
            data, source = read_toml(path, text)
            ctx = Context(text, source, Path(base_dir) if base_dir is not None else path.parent)
            return scene_from_dict(data, ctx, library, default_name=path.stem)
        if text in builtin.names():
            path = builtin.path(text)
            data, source = read_toml(path, f"built-in {text}")
            ctx = Context(f"built-in {text}", source, path.parent)
            return scene_from_dict(data, ctx, library, default_name=text)
        raise SceneError(text, message="not a scene file and not a built-in scene (built-in: "
                         + ", ".join(builtin.names()) + ")",
                         matches=close_matches(text, builtin.names()))
    raise SceneError(f"<{type(scene).__name__}>", message="a scene is a path to a .toml file, "
                     "a dict or the name of a built-in scene")


def read_toml(path: Path, shown: str) -> tuple[dict, str]:
    """(parsed dict, source text); a syntax error names its line."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(shown, message="no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(shown, message=f"cannot read the file: {exc}") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        line = int(m.group(1)) if m else None
        msg = re.sub(r"\s*\(at line \d+, column (\d+)\)", r" (column \1)", msg)
        if "end of document" in msg:
            msg = re.sub(r"\s*\(at end of document\)", " at the end of the file", msg)
        raise SceneError(shown, line=line, message=f"TOML syntax error: {msg}") from None


def read_settings(t: Table | None) -> Settings:
    if t is None:
        return Settings()
    t.check_keys(SETTINGS_KEYS)
    d = Settings()
    sample_rate_hz = t.integer("sample_rate_hz", d.sample_rate_hz, lo=8000, hi=192000)
    bands = read_bands(t, sample_rate_hz)
    air_t = t.table("air")
    air = Air()
    if air_t is not None:
        air_t.check_keys(AIR_KEYS)
        air = Air(air_t.number("temperature_c", air.temperature_c, lo=-20.0, hi=50.0),
                  air_t.number("humidity_percent", air.humidity_percent, lo=0.0, hi=100.0),
                  air_t.number("pressure_kpa", air.pressure_kpa, lo=50.0, hi=120.0))
    return Settings(
        sample_rate_hz=sample_rate_hz,
        bands_hz=bands.nominal_hz,
        bands=bands.kind,
        energy_drop_db=t.number("energy_drop_db", d.energy_drop_db, lo=0.0, lo_open=True,
                                hi=200.0),
        max_time_s=t.number("max_time_s", d.max_time_s, lo=0.0, hi=MAX_TIME_S),
        seed=t.integer("seed", d.seed, lo=0, hi=MAX_SEED),
        threads=t.integer("threads", d.threads, lo=0, hi=MAX_THREADS),
        air=air,
        wall_model=t.string("wall_model", None, choices=WALL_MODELS),
    )


def join_parts(parts: list[GeometryPart]) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                   list[Material], np.ndarray]:
    """(vertices_m float64[n, 3], triangles int64[m, 3], material_index int32[m], materials,
    surface_tag str[m]); coinciding vertices are welded, unused ones dropped."""
    vs, ts, mats, tags = [], [], [], []
    offset = 0
    for part in parts:
        vs.append(part.vertices_m)
        ts.append(part.triangles + offset)
        offset += part.vertices_m.shape[0]
        mats += [part.group_material[g] for g in part.group]
        tags += [part.group_tag[g] for g in part.group]
    vertices, triangles = weld(np.concatenate(vs), np.concatenate(ts))
    materials: list[Material] = []
    slot: dict[int, int] = {}
    material_index = np.empty(len(mats), dtype=np.int32)
    for k, m in enumerate(mats):
        material_index[k] = slot.setdefault(id(m), len(slot))
        if material_index[k] == len(materials):
            materials.append(m)
    return vertices, triangles, material_index, materials, np.array(tags, dtype=str)


def weld(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Join vertices within WELD_TOLERANCE_M and drop unused ones, keeping first-use order."""
    used, local = np.unique(triangles.reshape(-1), return_inverse=True)
    keys = np.round(vertices[used] / WELD_TOLERANCE_M).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # unique rows in order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(order.shape[0])
    new_index = rank[inverse.reshape(-1)]
    welded = np.ascontiguousarray(vertices[used][first[order]], dtype=np.float64)
    tri = np.ascontiguousarray(new_index[local].reshape(-1, 3), dtype=np.int64)
    return welded, tri


def mesh_warnings(report: dict, tags: np.ndarray) -> list[str]:
    """The core's findings as sentences that say where."""
    out = []
    if report["n_degenerate"]:
        idx = report["degenerate"][:5]
        where = ", ".join(f"{int(i)} ({tags[int(i)]})" for i in idx)
        out.append(f"{report['n_degenerate']} degenerate triangle(s) of zero area are skipped, "
                   f"e.g. triangle {where}")
    if report["n_open_edges"]:
        near = "; ".join("(" + ", ".join(f"{c:.3g}" for c in p) + ")"
                         for p in report["open_edge_midpoints"][:3])
        out.append(f"the geometry is not closed: {report['n_open_edges']} open edge(s), e.g. "
                   f"near {near}; sound and light can leak out there")
    if report["n_nonmanifold_edges"]:
        out.append(f"{report['n_nonmanifold_edges']} edge(s) are shared by more than two "
                   "triangles")
    if report["n_inconsistent_edges"]:
        out.append(f"{report['n_inconsistent_edges']} edge(s) join triangles wound opposite "
                   "ways: their normals do not agree on which side is inside")
    if report["signed_volume_m3"] > 0:
        out.append(f"the triangles face out of the room (signed volume "
                   f"+{report['signed_volume_m3']:.4g} m³): sonolux expects normals facing "
                   "into the room, towards the listener")
    return out


def scene_from_dict(data: Any, ctx: Context, library: Library | None,
                    default_name: str = "scene") -> Scene:
    """Validate ``data`` (the schema of docs/scene.md) and build the Scene."""
    root = Table(data, "", ctx)
    root.check_keys(ROOT_KEYS)
    name = root.string("name", default_name)
    settings = read_settings(root.table("settings"))
    names = MaterialNames(root.table("materials"), ctx, library)

    # Everything that needs no geometry is checked first, so that a slip is reported at once.
    source_tables, light_tables = root.tables("sources"), root.tables("lights")
    sources = read_sources(source_tables)
    light_specs = read_lights(light_tables)
    receiver_spec = read_receivers(root.table("receivers"))
    daylight = read_daylight(root.table("daylight"))
    early = read_early(root.table("early"))
    speech = read_speech(root.table("speech"))
    waves = read_waves(root.table("waves"))

    entries = root.tables("geometry")
    if not entries:
        raise ctx.error("geometry", allowed='at least one [[geometry]] entry (type = "shoebox" '
                        'or "mesh")')
    parts = []
    for t in entries:
        kind = t.string("type", choices=GEOMETRY_TYPES)
        part = build_shoebox(t, names) if kind == "shoebox" else build_mesh(t, names)
        reach = float(np.abs(part.vertices_m).max()) if part.vertices_m.size else 0.0
        if not reach <= MAX_COORDINATE_M:
            raise ctx.error(t.key, f"coordinates up to {reach:.3g} m",
                            allowed=f"a geometry within {MAX_COORDINATE_M:g} m of the origin "
                                    "in every axis")
        parts.append(part)
    warnings = [w for p in parts for w in p.warnings]
    vertices_m, triangles, material_index, materials, tags = join_parts(parts)
    if triangles.shape[0] == 0:
        raise ctx.error("geometry", message="the geometry has no triangles")

    try:
        geometry = Geometry(vertices_m, triangles, material_index)
        report = geometry.report()
    except CoreMissingError:
        raise
    except SonoluxError as exc:
        raise ctx.error("geometry", message=str(exc)) from None
    diagonal = float(np.linalg.norm(report["bbox_max"] - report["bbox_min"]))
    if abs(report["signed_volume_m3"]) <= MIN_RELATIVE_VOLUME * diagonal ** 3:
        raise ctx.error("geometry", message=(
            f"the geometry encloses no volume (signed volume {report['signed_volume_m3']:.3g} "
            "m³): a room must be a closed surface around its air"))
    warnings += mesh_warnings(report, tags)
    warnings += held_band_warnings(materials, settings.band_set)

    space = RoomSpace(geometry, vertices_m, triangles)
    place_sources(sources, source_tables, space, warnings)
    lights = resolve_lights(light_specs, vertices_m[triangles], materials, material_index, space,
                            warnings)
    receivers = place_receivers(receiver_spec, ctx, space, report["bbox_min"], report["bbox_max"],
                                warnings)
    workplane = place_workplane(root.table("workplane"), ctx, space, report["bbox_min"],
                                report["bbox_max"], warnings)
    if not sources:
        warnings.append("the scene has no sound source")
    return Scene(name=name, origin=ctx.file, vertices_m=vertices_m, triangles=triangles,
                 material_index=material_index, materials=materials, surface_tag=tags,
                 sources=sources, lights=lights, receivers=receivers, settings=settings,
                 mesh_report=report, warnings=warnings, geometry=geometry, daylight=daylight,
                 workplane=workplane, early=early, speech=speech, waves=waves)
