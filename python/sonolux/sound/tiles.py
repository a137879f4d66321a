"""A bake's rays traced receiver tile by receiver tile, so that a field larger than memory is
made in pieces with the bits of one piece (each tile retraces every ray; the nee estimator still
draws among all the bake's receivers). The memory plan that sets the tiles is
:func:`sonolux.sound.bake.memory_plan`; the levels of detail each tile traces are
:mod:`sonolux.sound.levels`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.scene.schema import Scene
from sonolux.sound import budget as sound_budget
from sonolux.sound import levels as sound_levels
from sonolux.sound.compact import CompactArray
from sonolux.sound.receiver_patterns import banded_patterns, receiver_patterns
from sonolux.sound.stats import combine_stats


def trace_tiles(scene: Scene, *, geometry_args: tuple[Any, Any, Any, Any], runs: list[int | None],
                 base: dict[str, Any], memory: sound_budget.MemoryPlan, early: Any,
                 callback: Any, split: int, keep_counts: bool,
                 reduce: tuple[int, int]) -> dict[str, Any]:
    """Traces the receivers tile by tile (each tile every ray: the same bits as all at once),
    and in each tile the sources of ``runs`` one by one (None: all sources together), on the
    one geometry (its BVH built once). Each tile's field is kept compact, its stored late bins
    shown ``split`` to a bin (or dense for ``storage="full"``). The fields of the runs come
    back one after the other along the receiver axis; the time axis returned is the one shown."""
    compact = memory.compact
    partial = (base["first_ray"], base["end_ray"]) != (0, base["rays"])
    acoustics, sources, levels, parts = geometry_args
    positions = np.ascontiguousarray(scene.receivers.positions_m, float)
    patterns = receiver_patterns(scene)
    n, size = positions.shape[0], memory.tile_receivers
    steps = memory.tiles * len(runs)
    energies: list[list[Any]] = [[] for _ in runs]
    counts: list[list[Any]] = [[] for _ in runs]
    out: dict[str, Any] = {}
    stats: dict[str, Any] | None = None
    # Work done in every tile (the rays' segments are the first tile's: the bake's).
    per_tile = {"deposits": 0, "shadow_rays": 0, "draws": 0}
    t0 = time.perf_counter()
    # Tiled, the nee estimator and the hybrid's early diffuse connections draw among all the
    # bake's receivers (the untiled bits).
    draws = base.get("estimator") == "nee" or (
        early is not None and getattr(scene.early, "diffuse_connections", False))
    whole = ({"bake_receivers": engine.Receivers(positions, scene.receivers.radius_m, patterns)}
             if memory.tiles > 1 and draws else {})
    # One fixed-point quantum for every tile (and band group): the whole bake's sources and
    # receivers. A tile's own would follow its receivers' peak gain (an omni tile beside a SOFA
    # channel's), and its counts would not share the bake's scale. The same as the tile's own
    # when every receiver peaks alike (the same bits as before).
    base = dict(base, quantum=engine.sound_quantum(sources, engine.Receivers(
        positions, scene.receivers.radius_m, patterns)))
    # With levels, SOFA channels take each band group's own gains (per-level receivers).
    banded = None if levels is None else banded_patterns(scene)
    if memory.tiles > 1:  # a progressive round's late tail is watched untiled only (tail.py)
        base = {k: v for k, v in base.items() if not k.startswith("tail_")}
    for k, lo in enumerate(range(0, n, size)):
        hi = min(lo + size, n)
        receivers = engine.Receivers(np.ascontiguousarray(positions[lo:hi]),
                                     scene.receivers.radius_m,
                                     None if patterns is None else patterns[lo:hi])
        for j, only in enumerate(runs):
            step = k * len(runs) + j
            progress = None if callback is None else tile_progress(callback, step, steps, t0)
            per_level = None if banded is None else _level_receivers(
                banded, positions, scene.receivers.radius_m, (lo, hi), bool(whole))
            out = sound_levels.trace(levels, scene, acoustics, sources, receivers,
                                     dict(base, first_receiver=lo, only_source=only), progress,
                                     early, parts, receivers_of=per_level, **whole)
            for key in per_tile:
                per_tile[key] += int(out["stats"].get(key, 0))
            if k == 0:  # every tile retraces the same rays: the first tile's are the bake's
                stats = out["stats"] if stats is None else combine_stats(stats, out["stats"])
            early_bins = int(out["early_bins"])
            energy = out.pop("energy")
            if compact:
                # A part of a bake keeps every early cell (parts add up exactly); a whole bake
                # keeps its strongest early arrivals and an envelope of the rest.
                energy = CompactArray.of(energy, early_bins, split)
                energy = energy if partial else energy.reduce(*reduce)
            energies[j].append(energy)
            if keep_counts:
                counts[j].append(CompactArray.of(out.pop("counts"), early_bins, split)
                                 if compact else out.pop("counts"))
            if out["cancelled"] or out["saturated"]:
                break
        if out["cancelled"] or out["saturated"]:
            break
    join = CompactArray.concatenate if compact else np.concatenate
    pieces = [e for per in energies for e in per]
    out["energy"] = pieces[0] if len(pieces) == 1 else join(pieces)
    if keep_counts:
        pieces = [c for per in counts for c in per]
        out["counts"] = pieces[0] if len(pieces) == 1 else join(pieces)
    out["stats"] = dict(stats or out["stats"], **per_tile)
    if split > 1:
        eb = int(out["early_bins"])
        start, width = np.asarray(out["bin_start_s"]), np.asarray(out["bin_width_s"])
        n_late = (start.size - eb) * split
        fine = float(width[-1]) / split if n_late else 0.0
        late0 = float(start[eb]) if n_late else 0.0
        out["bin_start_s"] = np.concatenate([start[:eb], late0 + fine * np.arange(n_late)])
        out["bin_width_s"] = np.concatenate([width[:eb], np.full(n_late, fine)])
    return out


def _level_receivers(banded: Callable[[slice], list[Any]], positions: np.ndarray,
                     radius_m: float, tile: tuple[int, int],
                     whole: bool) -> Callable[[slice], tuple[Any, dict[str, Any]]]:
    """(the tile's receivers, and the bake's for a tiled nee bake) with a band group's patterns."""
    lo, hi = tile

    def of(bands: slice) -> tuple[Any, dict[str, Any]]:
        patterns = banded(bands)
        tile_receivers = engine.Receivers(np.ascontiguousarray(positions[lo:hi]), radius_m,
                                          patterns[lo:hi])
        return tile_receivers, ({"bake_receivers": engine.Receivers(positions, radius_m, patterns)}
                                if whole else {})
    return of


def tile_progress(callback: Callable[[int, int, float], bool], tile: int, tiles: int,
                   t0: float) -> Callable[[int, int, float], bool]:
    """The progress of one tile as the progress of the whole bake."""
    def report(done: int, total: int, _elapsed: float) -> bool:
        return callback(tile * total + done, tiles * total, time.perf_counter() - t0)
    return report
