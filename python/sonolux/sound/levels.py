"""A bake with per-band geometry (level of detail, :mod:`sonolux.scene.simplify`): each group of
bands that sees the same simplified mesh is traced against its own geometry (its own BVH), with
its own bands and its own rays, and the groups' fields are joined along the band axis.

Both parts of a hybrid use a level's geometry: its image sources (and diffraction) and the
particles that leave their paths out, so nothing is counted twice in any band. Each group's rays
choose their bounces by their own bands' scattering and stop when their own bands have decayed,
so a group of low bands keeps its rays alive as long as those bands need (no re-weighting across
bands with very different scattering). Light keeps the full mesh.

With ``[early] level_of_detail_rays = "octave"`` (the default is ``"level"`` since session 11)
each level's bands are further cut into groups within one octave (:func:`by_octave`), each with
its own rays.

A scene without level of detail is traced exactly as before (one call, the same bits).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.errors import SonoluxError
from sonolux.scene.schema import Scene
from sonolux.scene.simplify import Level, band_levels
from sonolux.sound.receiver_patterns import banded_patterns
from sonolux.sound.surfaces import level_tables, tables_by_angle
from sonolux.sound.walls import grazing_table


@dataclass
class LevelGeometry:
    """A level and the core's handle of its mesh (its BVH built once), with the α(θ)/s(θ)
    tables of its described surfaces cut to its bands (:func:`sonolux.sound.surfaces.level_tables`;
    None without) and, under wall model "locally-reacting-modes", its rays' grazing-modes table
    (:func:`sonolux.sound.walls.grazing_table` of the level: its mesh, materials and bands;
    None otherwise or without a clear pair of parallel planes)."""

    level: Level
    geometry: Any
    by_angle: dict[int, np.ndarray] | None = None
    grazing: Any = None


def plan(scene: Scene, arrays: dict[str, np.ndarray],
         log: Callable[[str], None] | None = None,
         wall_model: str | None = None) -> list[LevelGeometry] | None:
    """The bake's levels, or None when it has one geometry (no level of detail, or no band
    with a small feature): then the bake is the plain one. ``wall_model``: the bake's (the
    Python name, :mod:`sonolux.sound.walls`), for the grazing modes' table of each level."""
    if scene.early is None or not scene.early.level_of_detail:
        return None
    levels = band_levels(scene.vertices_m, scene.triangles, scene.material_index,
                         arrays["absorption"], arrays["scattering"],
                         scene.settings.band_set.exact_hz, scene.settings.speed_of_sound_m_s)
    if scene.early.level_of_detail_rays == "octave":
        levels = by_octave(levels, scene.settings.band_set.exact_hz)
    if len(levels) == 1 and levels[0].removed == 0:
        return None
    out: list[LevelGeometry] = []
    labels = scene.settings.band_set.labels()
    tables = tables_by_angle(scene)
    for lv in levels:
        if not lv.removed:
            geometry = scene.geometry
        elif out and out[-1].level.triangles is lv.triangles:  # one octave of the same level
            geometry = out[-1].geometry
        else:
            geometry = engine.Geometry(scene.vertices_m, lv.triangles, lv.material_index)
        out.append(LevelGeometry(lv, geometry, level_tables(tables, lv), grazing_table(
            scene, wall_model or "", lv.absorption[:, lv.bands], lv)))
        if log:
            b = lv.bands
            span = f"{labels[b.start]}–{labels[b.stop - 1]} Hz"
            log(f"level of detail {span}: " + (
                f"{lv.removed} small feature(s) replaced by the surfaces they sit on "
                f"(+{lv.volume_added_m3:.3g} m³ of air)" if lv.removed else "the full mesh"))
    return out


def largest_group(levels: list[LevelGeometry] | None) -> int | None:
    """The bands of the largest group :func:`trace` traces at once (None without levels): what
    the memory plan counts beside the joined field (:func:`sonolux.sound.budget.plan`)."""
    if levels is None:
        return None
    return max(lg.level.bands.stop - lg.level.bands.start for lg in levels)


def level_receivers(scene: Scene) -> Callable[[slice], Any] | None:
    """A level's receivers (every one) with its band group's patterns, when they depend on the
    band (SOFA channels); else None (the bake's receivers serve every level)."""
    banded = banded_patterns(scene)
    if banded is None:
        return None
    positions = np.ascontiguousarray(scene.receivers.positions_m, float)
    return lambda b: engine.Receivers(positions, scene.receivers.radius_m, banded(b))


#: A band group spans less than an octave: IEC 61260-1's base-10 octave ratio 10^(3/10).
OCTAVE_RATIO = 10.0 ** 0.3


def by_octave(levels: list[Level], bands_hz: Sequence[float]) -> list[Level]:
    """Each level's bands cut into groups within one octave, each traced with its own rays.

    Why (measured before hero-band sampling, docs/early-sound.md "One bounce for all bands"):
    a ray carried its group's bands and chose each bounce by their mean scattering s',
    re-weighting each band by s'_b / p or (1 − s'_b)/(1 − p). With level of detail s' differs
    most between bands (Rindel's K ∝ f, or f², below a panel's cut-offs: a small face scatters
    almost everything at 250 Hz and little at 4 kHz), so the weights' products over many
    reflections grow heavy-tailed and late decays fall in steps. Within an octave K changes by
    at most 2× (4× below both cut-offs); an octave bake traces each band alone (no weights at
    all), a third-octave bake the three thirds of an octave together."""
    f = np.asarray(bands_hz, float)
    out = []
    for lv in levels:
        lo = lv.bands.start
        for b in range(lv.bands.start + 1, lv.bands.stop + 1):
            if b == lv.bands.stop or f[b] >= f[lo] * OCTAVE_RATIO * (1.0 - 1e-6):
                out.append(replace(lv, bands=slice(lo, b)))
                lo = b
    return out


def _joined_stats(parts: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The statistics of the levels together: per-band energies joined along the band axis,
    counts summed, ``rays`` the rays of one level (every band saw that many)."""
    out = dict(parts[0])
    for k in parts[0]:
        if k.startswith("energy_"):
            out[k] = np.concatenate([np.asarray(p[k]) for p in parts])
        elif k in ("segments", "surface_hits", "deposits", "escaped_rays", "shadow_rays", "draws"):
            out[k] = sum(p[k] for p in parts)
    out["max_reflections"] = max(p.get("max_reflections", 0) for p in parts)
    hits = sum(p.get("surface_hits", 0) for p in parts)
    for k in ("mean_free_path_m", "free_path_relative_variance"):
        if hits > 0 and all(k in p for p in parts):
            out[k] = sum(p[k] * p.get("surface_hits", 0) for p in parts) / hits
    out["escapes"] = [e for p in parts for e in p.get("escapes", [])][:20]
    return out


def trace(levels: list[LevelGeometry] | None, scene: Scene, acoustics: Any, sources: Any,
          receivers: Any, settings: dict[str, Any], progress: Any, early: Any,
          parts: Callable[[slice], tuple[Any, Any, Any]],
          receivers_of: Callable[[slice], tuple[Any, dict[str, Any]]] | None = None,
          **whole: Any) -> dict[str, Any]:
    """``engine.trace_sound`` of one tile and run: plain without levels; with them, each level
    on its geometry and bands (``parts(bands)`` gives that level's (sources, early settings,
    air)), the fields joined along the band axis. ``whole``: passed on to every trace (the
    bake's receivers when this is a tile of them). ``receivers_of(bands)``: (the receivers,
    ``whole``) of a level's bands, when the receivers' patterns depend on the band (SOFA
    channels: :func:`sonolux.sound.receiver_patterns.banded_patterns`)."""
    if levels is None:
        return engine.trace_sound(scene.geometry, acoustics, sources, receivers,
                                  engine.SoundSettings(**settings), progress, early, **whole)
    # The joined field is allocated once, when the first level gives its shape, and each
    # level's bands are copied in and dropped at once: the bake holds the field and one level's
    # part, not every part and the join (twice the field).
    # One fixed-point quantum for every group: the whole bake's sources and receivers, every
    # band (each group's own, from its bands' gains, is no larger: the core checks), so that
    # the groups' counts share a scale and ray ranges merge exactly whatever the groups' peaks.
    if settings.get("quantum") is None:  # the caller's (the whole bake's, over tiles) else ours
        settings = dict(settings, quantum=engine.sound_quantum(sources, receivers))
    out: dict[str, Any] = {}
    parts_stats: list[dict[str, Any]] = []
    cancelled = saturated = False
    for j, lg in enumerate(levels):
        b = lg.level.bands
        src, early_b, air = parts(b)
        acoustics_b = engine.Acoustics(np.ascontiguousarray(lg.level.absorption[:, b]),
                                       np.ascontiguousarray(lg.level.scattering[:, b]),
                                       wall_model=acoustics.wall_model, by_angle=lg.by_angle,
                                       grazing=lg.grazing)
        step = None if progress is None else _level_progress(progress, j, len(levels))
        rec, extra = (receivers, whole) if receivers_of is None else receivers_of(b)
        part = engine.trace_sound(lg.geometry, acoustics_b, src, rec,
                                  engine.SoundSettings(**dict(settings, air_attenuation_per_m=air)),
                                  step, early_b, **extra)
        if not out:
            out = dict(part)
            shape = list(part["energy"].shape)
            shape[2] = max(lv.level.bands.stop for lv in levels)
            # A cancelled bake stops at once; the levels not traced are zeros (the field is
            # discarded).
            out["energy"] = np.zeros(shape, part["energy"].dtype)
            if "counts" in part:
                out["counts"] = np.zeros(shape, part["counts"].dtype)
        out["energy"][:, :, b] = part.pop("energy")
        if "counts" in part:
            if part["quantum"] != out["quantum"]:  # one quantum was given: a broken core
                raise SonoluxError("level of detail: the band groups' fixed-point quanta differ")
            out["counts"][:, :, b] = part.pop("counts")
        parts_stats.append(part["stats"])
        cancelled |= bool(part["cancelled"])
        saturated |= bool(part["saturated"])
        del part
        if cancelled:
            break
    out["cancelled"] = cancelled
    out["saturated"] = saturated
    out["stats"] = _joined_stats(parts_stats)
    return out


def _level_progress(progress: Callable[[int, int, float], bool], j: int,
                    n: int) -> Callable[[int, int, float], bool]:
    def report(done: int, total: int, elapsed: float) -> bool:
        return progress(j * total + done, n * total, elapsed)
    return report


#: The per-arrival arrays that identify one path (its bands may come from several levels).
_PATH_KEYS = ("source", "receiver", "time_s", "kind", "order")


def early_arrivals(levels: list[LevelGeometry], scene: Scene, receivers: Any, settings: Any,
                   parts: Callable[[slice], tuple[Any, Any, Any]],
                   n_bands: int, wall_model: str,
                   receivers_of: Callable[[slice], Any] | None = None) -> dict[str, Any]:
    """The image sources and diffraction of every level on its own geometry and bands, as one
    arrival list over all bands: a path found by several levels (a reflection off the floor is
    in every level) is one arrival holding each level's bands; a path of one level only has
    zeros in the other bands. ``receivers_of(bands)``: a level's receivers when their patterns
    depend on the band (SOFA channels)."""
    rows: dict[tuple, int] = {}
    table: dict[str, list[Any]] = {}
    energy: list[np.ndarray] = []
    stats: dict[str, Any] = {}
    first: dict[str, np.ndarray] = {}
    for lg in levels:
        b = lg.level.bands
        src, early_b, _ = parts(b)
        acoustics_b = engine.Acoustics(np.ascontiguousarray(lg.level.absorption[:, b]),
                                       np.ascontiguousarray(lg.level.scattering[:, b]),
                                       wall_model=wall_model, by_angle=lg.by_angle)
        rec = receivers if receivers_of is None else receivers_of(b)
        found = engine.early_arrivals(lg.geometry, acoustics_b, src, rec, early_b, settings)
        for k, v in found["stats"].items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                stats[k] = stats.get(k, 0) + v
        e = np.asarray(found["energy"])
        cols = {k: np.asarray(v) for k, v in found.items() if k != "stats"}
        first = first if first else cols
        for i in range(e.shape[0]):
            key = tuple(cols[k][i].item() for k in _PATH_KEYS) + tuple(cols["from_direction"][i])
            row = rows.get(key)
            if row is None:
                row = rows[key] = len(energy)
                for k, v in cols.items():
                    if k != "energy":
                        table.setdefault(k, []).append(v[i])
                energy.append(np.zeros(n_bands))
            energy[row][b] = e[i]
    if rows:
        out: dict[str, Any] = {k: np.asarray(v) for k, v in table.items()}
    else:  # no arrival at all: the first level's empty arrays keep their dtypes
        out = {k: v[:0] for k, v in first.items()}
    out["energy"] = np.asarray(energy, float).reshape(-1, n_bands)
    out["stats"] = stats
    return out


__all__ = ["LevelGeometry", "early_arrivals", "largest_group", "level_receivers", "plan", "trace"]
