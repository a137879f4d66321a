"""Baking a sound field: the scene's arrays go to the Rust tracer, a :class:`SoundField` comes
back. Also the automatic ray count.

One ray, from the scene file to the field: ``load_scene`` resolves geometry, materials, sources
and receivers into arrays; :func:`bake` picks the bands' absorption, scattering and the air's
attenuation (ISO 9613-1), puts them in the engine's settings objects and hands them to
:func:`sonolux.engine.trace_sound`, which emits, traces and deposits (see
``crates/sonolux-core/src/sound``); the energies come back as
float32[receiver, direction, band, time] in J/m². The field also keeps what theory expects of
the room (:func:`sonolux.scene.summary.theory`), for the analysis.

A scene with an ``[early]`` table is baked as a hybrid (:mod:`sonolux.sound.early`): the core's
image sources and edge diffraction give the early arrivals exactly, the tracer leaves out the
specular-only paths they count, and the arrivals are added to the field in their bins.

With ``waves`` (:mod:`sonolux.sound.waves`), the bands below a crossover come from the wave
solver instead, and the field keeps the waves' pressure response below it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from sonolux import engine
from sonolux.acoustics.theory import fitzroy_t60, sabine_t60
from sonolux.errors import SonoluxError
from sonolux.memory import budget_bytes
from sonolux.progress import ProgressLine
from sonolux.scene.directivity import builtin_gains
from sonolux.scene.schema import Scene
from sonolux.scene.sofa_directivity import sofa_gains
from sonolux.scene.summary import band_air_attenuation_per_m, theory
from sonolux.sound import budget as sound_budget
from sonolux.sound import early as early_sound
from sonolux.sound import levels as sound_levels
from sonolux.sound import surfaces as sound_surfaces
from sonolux.sound import walls as sound_walls
from sonolux.sound import wave_memory, wave_sources
from sonolux.sound import waves as wave_sound
from sonolux.sound.field import SoundField, with_source_energy
from sonolux.sound.options import SoundOptions
from sonolux.sound.receiver_patterns import channels_record, receiver_patterns
from sonolux.sound.tiles import trace_tiles

#: A compact field's stored late bins: the shortest T60 over this many (0.6 dB of decay a bin),
#: at most MAX_COMPACT_LATE_BIN_S. Measured to keep EDT, T20 and T30 within 0.5 % of the full
#: field's on the paper rooms and the mesh room (tests/sound/test_compact.py).
LATE_BINS_PER_T60 = 100
MAX_COMPACT_LATE_BIN_S = 0.05
#: Sphere crossings wanted per receiver in each late time bin, for the automatic ray count.
HITS_PER_LATE_BIN = 20
#: The paper's budget, 3 million rays for the 6 m room and 48 million for the 24 m room, is
#: this constant × reflections to the energy drop × (largest dimension)².
PAPER_RULE_CONSTANT = 3e6 / (65 * 6.0**2)


def band_arrays(scene: Scene) -> dict[str, np.ndarray]:
    """Absorption and scattering float64[materials, bands] on the scene's bands (converted from
    each material's own octaves or thirds, docs/bands.md) and the air's energy attenuation
    float64[bands] (1/m) at each band's exact mid-band frequency (ISO 9613-1, clause 8)."""
    bands = scene.settings.band_set
    return {
        "absorption": np.ascontiguousarray([m.absorption_in(bands) for m in scene.materials],
                                           float),
        "scattering": np.ascontiguousarray(
            [m.scattering_in(bands, scene.settings.speed_of_sound_m_s) for m in scene.materials],
            float),
        "air": band_air_attenuation_per_m(bands, scene.settings.air),
    }


def bake_arrays(scene: Scene, options: SoundOptions) -> dict[str, np.ndarray]:
    """:func:`band_arrays` as a bake with ``options`` uses them (no air if it leaves air out)."""
    arrays = band_arrays(scene)
    if not options.air_absorption:
        arrays["air"] = np.zeros_like(arrays["air"])
    return arrays


def ray_count(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray] | None = None,
              log: Callable[[str], None] | None = None) -> int:
    """``options.rays``, or for "auto" the count of :func:`auto_rays` (its reason to ``log``)."""
    if options.rays != "auto":
        return int(options.rays)
    rays, why = auto_rays(scene, options, arrays or bake_arrays(scene, options))
    if log:
        log(why)
    return rays


def _absorption_area(scene: Scene, absorption: np.ndarray) -> np.ndarray:
    by_material = scene.area_by_material_m2()
    return sum(by_material[m.name] * absorption[i] for i, m in enumerate(scene.materials))


def auto_max_time(scene: Scene, arrays: dict[str, np.ndarray]) -> float:
    """1.5 × the longest T60 that Sabine's or Fitzroy's formula gives (air included) + the time
    to cross the room's box. Fitzroy's (:func:`sonolux.acoustics.theory.fitzroy_t60`) covers
    rooms whose absorption sits on one pair of surfaces (an absorbing ceiling over hard walls:
    sound flutters between the walls and decays far slower than Sabine says); each surface
    counts for the axis its normal is closest to."""
    if scene.settings.max_time_s > 0:
        return scene.settings.max_time_s
    c = scene.settings.speed_of_sound_m_s
    t60 = sabine_t60(scene.volume_m3, _absorption_area(scene, arrays["absorption"]), arrays["air"],
                     c)
    areas, alpha = _axis_absorption(scene, arrays["absorption"])
    if areas.sum() > 0:
        t60 = np.maximum(t60, fitzroy_t60(scene.volume_m3, areas, alpha, arrays["air"], c))
    diagonal = float(np.linalg.norm(scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"]))
    t = 1.5 * float(np.max(t60)) + diagonal / c
    return min(t, 60.0) if math.isfinite(t) else 60.0


def _axis_absorption(scene: Scene, absorption: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area float64[3] of the surfaces whose normals lie closest to x, y and z, and their
    area-weighted mean absorption float64[3, band]."""
    v, t = np.asarray(scene.vertices_m, float), np.asarray(scene.triangles)
    normal = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    axis = np.argmax(np.abs(normal), axis=1)
    per_triangle = absorption[np.asarray(scene.material_index)]
    areas = np.array([area[axis == k].sum() for k in range(3)])
    alpha = np.array([area[axis == k] @ per_triangle[axis == k] / areas[k] if areas[k] > 0
                      else np.zeros(absorption.shape[1]) for k in range(3)])
    return areas, alpha


def auto_rays(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray]) -> tuple[int, str]:
    """The ray count per source, and why.

    A receiver sphere of radius r in a room of volume V is crossed by N c π r² Δt / V of N
    rays in a late bin of width Δt (rays fill the room evenly by then), so asking for
    HITS_PER_LATE_BIN crossings gives N. The paper's own rule (reflections to the energy drop
    × the largest dimension², scaled to its 3 and 48 million rays) is printed beside it.
    """
    c = scene.settings.speed_of_sound_m_s
    r = scene.receivers.radius_m
    n_hits = HITS_PER_LATE_BIN * scene.volume_m3 / (c * math.pi * r * r * options.late_bin_s)
    mean_alpha = float(np.mean(_absorption_area(scene, arrays["absorption"]))) / scene.area_m2
    reflections = scene.settings.energy_drop_db / (-10 * math.log10(max(1 - mean_alpha, 1e-12)))
    size = float(np.max(scene.mesh_report["bbox_max"] - scene.mesh_report["bbox_min"]))
    n_paper = PAPER_RULE_CONSTANT * reflections * size**2
    n = int(min(max(n_hits, 1000), 50_000_000))
    bin_ms = options.late_bin_s * 1e3
    why = (f"{n:,} rays: {HITS_PER_LATE_BIN} sphere crossings per receiver per {bin_ms:g} ms "
           f"late bin (V = {scene.volume_m3:.4g} m³, r = {r:g} m); the paper's rule "
           f"({reflections:.0f} reflections to -{scene.settings.energy_drop_db:g} dB × "
           f"{size:g} m²) would take {n_paper:,.0f}")
    return n, why


def bake(scene: Scene, options: SoundOptions | None = None, *,
         progress: bool | Callable[[int, int, float], bool] = False,
         log: Callable[[str], None] | None = None, tail: tuple[np.ndarray, int] | None = None,
         **overrides: Any) -> SoundField:
    """Traces the scene's sound sources into a sound field over its receivers.

    ``options`` (or keyword overrides such as ``rays=100_000``, ``estimator="paper"``) set the
    bake; ``progress=True`` prints a progress line, or pass ``f(done, total, elapsed_s) ->
    bool`` (False stops the bake). ``log`` receives one-line notes (ray count and why).
    """
    options = wave_sound.with_scene(scene, replace(options or SoundOptions(), **overrides).validate())
    if options.estimator == "auto":
        raise SonoluxError("estimator = 'auto' is chosen by sonolux.bake (a pilot of each "
                           "estimator: sonolux.sound.progressive.choose_estimator); "
                           "sound.bake.bake needs 'paper', 'rain' or 'nee'")
    if options.waves:
        wave_sound.check_scene(scene)
    if not scene.sources:
        raise SonoluxError(f"{scene.origin}: the scene has no sound source to bake")
    if scene.receivers.count == 0:
        raise SonoluxError(f"{scene.origin}: the scene has no receiver left to bake into")
    if options.waves and scene.receivers.channels:
        raise SonoluxError(f"{scene.origin}: directional receiver channels are not available "
                           "with waves (the wave solver records pressure, not directions)")
    arrays = bake_arrays(scene, options)
    rays = ray_count(scene, options, arrays, log)
    first, end = options.ray_range or (0, rays)
    if end > rays:
        raise SonoluxError(f"ray_range {options.ray_range} goes past the bake's {rays} rays")
    max_time_s = options.max_time_s or auto_max_time(scene, arrays)
    # The hybrid's check before any ray: the clearance of every range, the memory of the one
    # that computes the waves.
    check_waves(scene, options, arrays, max_time_s, from_ray_zero=first == 0, log=log)
    early_s, stored_late_s, split = stored_axis(scene, options, arrays)
    groups = late_groups(scene, options, arrays, stored_late_s)
    picked = traced_sources(scene, options)
    # Each source traced alone (its own field), unless waves join them (one field, "all").
    runs: list[int | None] = [None] if options.waves and len(scene.sources) > 1 else picked
    src = [scene.sources[k] for k in picked]
    callback = ProgressLine(f"sound {scene.name}") if progress is True else (progress or None)
    base = dict(
        rays=rays, first_ray=first, end_ray=end, seed=scene.settings.seed,
        threads=scene.settings.threads, estimator=options.estimator,
        nee_receivers=options.nee_receivers,
        speed_of_sound_m_s=scene.settings.speed_of_sound_m_s,
        air_attenuation_per_m=arrays["air"].tolist(), energy_drop_db=scene.settings.energy_drop_db,
        max_time_s=max_time_s, sample_rate_hz=float(scene.settings.sample_rate_hz),
        early_s=early_s, late_bin_s=stored_late_s,
        azimuth_bands=options.azimuth_bands, elevation_bands=options.elevation_bands,
        max_field_bytes=options.max_field_bytes or budget_bytes(),
        keep_counts=options.ray_range is not None)
    settings = engine.SoundSettings(**base)
    wall_model, wall_why = sound_walls.resolve(scene, options)
    acoustics = engine.Acoustics(arrays["absorption"], arrays["scattering"],
                                 wall_model=sound_walls.core_model(wall_model),
                                 by_angle=sound_surfaces.tables_by_angle(scene),
                                 grazing=sound_walls.grazing_table(scene, wall_model,
                                                                   arrays["absorption"],
                                                                   log=log))
    wall_kept = [list(k) for k in acoustics.kept_constant()]
    if log:
        log(wall_why)
        note = sound_walls.describe_kept(acoustics.kept_constant(),
                                         [m.name for m in scene.materials], scene.settings.bands_hz)
        if note:
            log(note)
    edges_hz = scene.settings.band_set.edges_hz
    sources = [engine.SoundSource(tuple(s.position_m), s.power_w, _directivity(s, edges_hz))
               for s in scene.sources]
    patterns = receiver_patterns(scene)
    receivers = engine.Receivers(np.ascontiguousarray(scene.receivers.positions_m, float),
                                 scene.receivers.radius_m, patterns)
    started = time.perf_counter()
    early, arrivals = None, None
    if scene.early is not None:
        early = early_sound.early_settings(scene, scene.early, arrays["air"], log)
    levels = sound_levels.plan(scene, arrays, log, wall_model)
    if tail is not None and levels is None and len(runs) == 1 and \
            np.shape(tail[0]) == (scene.receivers.count, acoustics.n_bands):  # sound/tail.py
        base = dict(base, tail_from_s=np.ravel(tail[0]).tolist(), tail_keep=int(tail[1]))

    def parts(b: slice) -> tuple[Any, Any, Any]:
        """A level's bands: its sources' directivities, early settings and air."""
        return ([engine.SoundSource(tuple(s.position_m), s.power_w, _directivity(s, edges_hz[b]))
                 for s in scene.sources],
                early_sound.early_settings(scene, scene.early, arrays["air"], bands=b),
                arrays["air"][b].tolist())
    if early is not None and first == 0:
        # The arrivals are deterministic and belong to the bake, not to a ray range: the range
        # that starts at ray 0 computes and stores them once (docs/early-sound.md).
        found = engine.early_arrivals(scene.geometry, acoustics, sources, receivers, early,
                                      settings) if levels is None else \
            sound_levels.early_arrivals(levels, scene, receivers, settings, parts,
                                        len(scene.settings.bands_hz), acoustics.wall_model,
                                        sound_levels.level_receivers(scene))
        arrivals = _stacked_arrivals(early_sound.arrival_table(found), runs,
                                     scene.receivers.count)
        early_stats = dict(found["stats"], seconds=time.perf_counter() - started)
    memory = memory_plan(scene, options, arrays, settings_of=(end - first, max_time_s),
                         group_bands=sound_levels.largest_group(levels))
    if log:
        log(memory.describe())
    out = trace_tiles(scene, geometry_args=(acoustics, sources, levels, parts), runs=runs,
                       base=base,
                       memory=memory,
                       early=early, callback=callback, split=split,
                       keep_counts=options.ray_range is not None,
                       reduce=(*reduction(options, scene.settings.sample_rate_hz), groups))
    seconds = time.perf_counter() - started
    stats = dict(out["stats"], **({"tail": out["tail"]} if "tail" in out else {}))
    stats.update(seconds=seconds, rays_per_second=stats["rays"] / seconds if seconds > 0 else None,
                 segments_per_second=stats["segments"] / seconds if seconds > 0 else None,
                 mean_free_path_theory_m=4 * scene.volume_m3 / scene.area_m2,
                 saturated=bool(out["saturated"]), cancelled=bool(out["cancelled"]),
                 tiles=memory.tiles, memory_budget_bytes=memory.budget_bytes,
                 memory_estimate_bytes=memory.total_bytes)
    energy = out["energy"]
    if arrivals is not None:
        stats["early"] = early_stats
        energy = early_sound.add_arrivals(energy, arrivals)
    if out["saturated"]:
        raise SonoluxError("the sound field overflowed its fixed-point range (a bug: please report "
                           "the scene)")
    record = {
        "rays": rays, "ray_range": [first, end], "estimator": options.estimator,
        "nee_receivers": options.nee_receivers,
        "seed": scene.settings.seed, "speed_of_sound_m_s": scene.settings.speed_of_sound_m_s,
        "sample_rate_hz": scene.settings.sample_rate_hz, "energy_drop_db": scene.settings.energy_drop_db,
        "max_time_s": max_time_s, "early_bins": int(out["early_bins"]),
        "late_bin_s": options.late_bin_s, "storage": options.storage,
        "compact_arrivals": options.compact_arrivals,
        "compact_envelope_s": options.compact_envelope_s,
        "stored_late_bin_s": stored_late_s, "compact_late_groups": groups, "early_s": early_s,
        "azimuth_bands": options.azimuth_bands,
        "elevation_bands": options.elevation_bands, "air_attenuation_per_m": arrays["air"].tolist(),
        "source_names": None if runs == [None] else [scene.sources[k].name for k in picked],
        "bands": scene.settings.bands,
        "wall_model": wall_model, "wall_model_kept_constant": wall_kept,
        "speech": None if scene.speech is None else scene.speech.as_dict(),
        "receiver_channels": channels_record(scene),
        "source_directivity": [s.directivity for s in src],
        "source_axis_gain": [axis_gains(s, edges_hz) for s in src],
        "volume_m3": scene.volume_m3, "area_m2": scene.area_m2,
        "early": None if early is None else {
            "max_order": early.max_order, "transition_s": early.max_time_s,
            "diffraction": scene.early.diffraction, "level_of_detail": scene.early.level_of_detail,
            "level_of_detail_rays": scene.early.level_of_detail_rays,
            "diffraction_piece_m": scene.early.diffraction_piece_m,
            "diffuse_connections": scene.early.diffuse_connections},
        "air": {"temperature_c": scene.settings.air.temperature_c,
                "humidity_percent": scene.settings.air.humidity_percent,
                "pressure_kpa": scene.settings.air.pressure_kpa},
    }
    field = SoundField(
        energy=np.zeros((0,), np.float32), bin_start_s=out["bin_start_s"], bin_width_s=out["bin_width_s"],
        bands_hz=np.asarray(scene.settings.bands_hz, float),
        positions_m=np.asarray(scene.receivers.positions_m, float), radius_m=scene.receivers.radius_m,
        grid_index=scene.receivers.grid_index, grid_spacing_m=scene.receivers.spacing_m,
        source_positions_m=np.array([s.position_m for s in src], float),
        source_powers_w=np.array([s.power_w for s in src], float),
        settings=record, stats=stats, scene_name=scene.name, scene_origin=scene.origin,
        counts=out.get("counts"), quantum=float(out["quantum"]), theory=theory(scene),
        early=arrivals)
    field = with_source_energy(field, energy)
    if not options.waves:
        return field
    if options.ray_range is None:
        return add_waves(scene, options, field, progress=progress, log=log)
    return with_wave_range(scene, options, field, first, progress=progress, log=log)


def check_waves(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray] | None = None,
                max_time_s: float | None = None, *, from_ray_zero: bool = True,
                log: Callable[[str], None] | None = None) -> wave_memory.WaveMemory | None:
    """The hybrid's one check at the edge, before any ray or pilot (issue 18): every entry that
    traces rays calls it first (:func:`bake`, ``sonolux.bake``, the range baker
    :class:`sonolux.sound.ranges.SoundRanges` and the progressive bake). The crossover is chosen
    once, as :func:`wave_part` will choose it (a function of the scene and the options, not of
    the machine: no timing run), on the field's own time axis; then

    - a directional source must have room for its cluster of monopoles on that grid
      (:func:`sonolux.sound.wave_sources.check_clearance`, SettingError);
    - for the bake or range that computes the waves (``from_ray_zero``: the one from ray 0), the
      waves must fit in memory (:mod:`sonolux.sound.wave_memory`, MemoryLimitError), the
      estimate logged.

    Returns the memory estimate (its ``crossover_hz`` the crossover), or None without waves."""
    options = wave_sound.with_scene(scene, options)
    if not options.waves:
        return None
    wave_sound.check_scene(scene)
    arrays = bake_arrays(scene, options) if arrays is None else arrays
    max_time_s = max_time_s or options.max_time_s or auto_max_time(scene, arrays)
    early_s, stored_late_s, split = stored_axis(scene, options, arrays)
    time_bins, end_s = wave_memory.field_axis(early_s, stored_late_s, split,
                                              float(scene.settings.sample_rate_hz), max_time_s)
    cross = wave_crossover(scene, options, arrays["absorption"], end_s, measure=False)
    if any(s.directivity != "omni" for s in scene.sources):
        wave_sources.check_clearance(scene, cross.max_frequency_hz, [
            _directivity(s, scene.settings.band_set.edges_hz) for s in scene.sources])
    memory = wave_memory.estimate(scene, cross, duration_s=end_s, time_bins=time_bins,
                                  directions=options.azimuth_bands * options.elevation_bands,
                                  max_field_bytes=options.max_field_bytes,
                                  absorption=arrays["absorption"])
    if from_ray_zero:
        if log:
            log(f"waves: about {wave_memory.gb(memory.total_bytes)} at most ({memory.describe()})")
        wave_memory.check(memory, options.max_field_bytes, options.memory_bytes)
    return memory


def wave_crossover(scene: Scene, options: SoundOptions, absorption: np.ndarray, end_s: float, *,
                   measure: bool) -> wave_sound.Crossover:
    """The crossover of a hybrid bake whose field ends at ``end_s``: the same arguments before
    the rays (:func:`check_waves`, ``measure=False``) and for the waves (:func:`wave_part`,
    which measures the machine's speed for the printed time only)."""
    return wave_sound.choose_crossover(
        scene, end_s, crossover_hz=options.crossover_hz,
        time_budget_s=options.wave_time_budget_s or wave_sound.DEFAULT_TIME_BUDGET_S,
        absorption=absorption, measure=measure,
        memory_limit_bytes=options.max_field_bytes or wave_sound.GRID_MEMORY_BYTES)


def with_wave_range(scene: Scene, options: SoundOptions, field: SoundField, first: int, *,
                    progress: bool | Callable[[int, int, float], bool] = False,
                    log: Callable[[str], None] | None = None) -> SoundField:
    """A ray-range part of a hybrid bake: the waves are deterministic and belong to the bake,
    not to a range, so the part that starts at ray 0 computes them once and carries them
    unjoined (``waves["energy"]``, the wave bands); every part says it belongs to a hybrid
    (``settings["with_waves"]``). The merge that completes the rays joins them
    (:func:`sonolux.sound.waves.with_wave_part`): the bits of the bake done at once."""
    field = replace(field, settings=dict(field.settings, with_waves=True))
    if first != 0:
        return field
    return replace(field, waves=wave_part(scene, options, field, progress=progress, log=log))


def add_waves(scene: Scene, options: SoundOptions, field: SoundField, *,
              progress: bool | Callable[[int, int, float], bool] = False,
              log: Callable[[str], None] | None = None) -> SoundField:
    """The field with its bands below the crossover from the wave solver, and the waves'
    pressure kept (:mod:`sonolux.sound.waves`): the hybrid's second half, after the rays (whole,
    or summed from ranges). The waves use the field's own bins, air and speed of sound."""
    return wave_sound.with_wave_part(field, wave_part(scene, options, field, progress=progress,
                                                      log=log))


def wave_part(scene: Scene, options: SoundOptions, field: SoundField, *,
              progress: bool | Callable[[int, int, float], bool] = False,
              log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """The waves of a hybrid bake, not yet joined to ``field`` (whose bins, air and speed of
    sound they use): ``energy`` float32[receiver, direction, wave band, time], the pressure, the
    crossover and the runs' statistics (:func:`sonolux.sound.waves.with_wave_part` joins them)."""
    started = time.perf_counter()
    rec = field.settings
    arrays = band_arrays(scene)
    arrays["air"] = np.asarray(rec["air_attenuation_per_m"], float)
    # The waves' record reaches the field's last bin (a compact field's coarse late bins may end
    # a bin or two past max_time_s): the wave bands are never cut short of the rays'.
    end_s = max(float(rec["max_time_s"]),
                float(np.max(np.asarray(field.bin_start_s) + np.asarray(field.bin_width_s))))
    binning = engine.SoundSettings(
        rays=1, first_ray=0, end_ray=1, seed=0, threads=scene.settings.threads,
        estimator="paper", speed_of_sound_m_s=rec["speed_of_sound_m_s"],
        air_attenuation_per_m=arrays["air"].tolist(), energy_drop_db=rec["energy_drop_db"],
        max_time_s=end_s, sample_rate_hz=float(rec["sample_rate_hz"]),
        early_s=rec["early_bins"] / float(rec["sample_rate_hz"]), late_bin_s=rec["late_bin_s"],
        azimuth_bands=rec["azimuth_bands"], elevation_bands=rec["elevation_bands"],
        max_field_bytes=options.max_field_bytes or budget_bytes())
    limit = wave_sound.memory_limit(options.max_field_bytes)
    cross = wave_crossover(scene, options, arrays["absorption"], end_s, measure=True)
    edges_hz = scene.settings.band_set.edges_hz
    part = wave_sound.bake_waves(scene, arrays, binning, cross, end_s, limit,
                                 (field.bin_start_s, field.bin_width_s),
                                 (rec["azimuth_bands"], rec["elevation_bands"]),
                                 progress=progress, log=log,
                                 directivities=[_directivity(s, edges_hz) for s in scene.sources])
    part["energy"] = np.ascontiguousarray(part["energy"][:, :, :cross.wave_bands])
    part.update(crossover_hz=cross.crossover_hz, wave_bands=cross.wave_bands,
                max_frequency_hz=cross.max_frequency_hz, schroeder_hz=cross.schroeder_hz,
                seconds=time.perf_counter() - started)
    return part


def _directivity(source: Any, edges_hz: np.ndarray) -> Any:
    """The engine's directivity of a scene's source, tabulated for the bake's bands."""
    if source.directivity == "cone":
        return engine.Directivity.cone(tuple(float(v) for v in source.axis),
                                       float(source.cone_half_angle_deg))
    if source.directivity == "omni":
        return engine.Directivity.omni()
    gains = (sofa_gains(source.sofa, edges_hz) if source.directivity == "sofa"
             else builtin_gains(source.directivity, edges_hz))
    return engine.Directivity.pattern(np.ascontiguousarray(gains, float),
                                      tuple(source.forward), tuple(source.up))


def axis_gains(source: Any, edges_hz: np.ndarray) -> list[float]:
    """A source's energy gain per band on its own axis (``forward``, a cone's ``axis``; 1 for
    omni), relative to an omnidirectional source of the same power: the talker's on-axis level
    that STI's speech level refers to (IEC 60268-16:2020 A.2.3, speech level at 1 m in front)."""
    if source.directivity == "omni":
        return [1.0] * len(edges_hz)
    axis = source.axis if source.directivity == "cone" else source.forward
    gains = _directivity(source, edges_hz).gains(np.asarray([axis], float), len(edges_hz))
    return [float(g) for g in gains[0]]


def stored_axis(scene: Scene, options: SoundOptions,
                arrays: dict[str, np.ndarray]) -> tuple[float, float, int]:
    """(early_s, stored late bin width, view bins per stored late bin) of the bake.

    Full storage: ``options.early_s`` and ``late_bin_s`` as given. Compact storage: the
    one-sample part reaches the later of ``early_s`` and the mixing time (20 V/S + 12 ms,
    Lindau, Kosanke and Weinzierl, JAES 60(11), 2012) *after the direct sound of the farthest
    receiver*, so that C50, C80, D50 and JLF, counted from each receiver's onset, fall on
    one-sample bins; the late part is stored at ``compact_late_bin_s`` and shown at
    ``late_bin_s`` (:func:`sonolux.sound.compact.spread_late`)."""
    if options.storage == "full":
        return options.early_s, options.late_bin_s, 1
    mixing_s = (20.0 * scene.volume_m3 / scene.area_m2 + 12.0) * 1e-3
    positions = np.asarray(scene.receivers.positions_m, float).reshape(-1, 3)
    sources = np.array([s.position_m for s in scene.sources], float).reshape(-1, 3)
    farthest_m = float(np.max(np.linalg.norm(positions[:, None] - sources[None], axis=2))) \
        if positions.size and sources.size else 0.0
    early_s = max(options.early_s, mixing_s) + farthest_m / scene.settings.speed_of_sound_m_s
    early_s = math.ceil(early_s * 1e3) / 1e3
    if options.compact_late_bin_s == "auto":
        t60 = sabine_t60(scene.volume_m3, _absorption_area(scene, arrays["absorption"]),
                         arrays["air"], scene.settings.speed_of_sound_m_s)
        shortest = float(np.min(t60)) if np.all(np.isfinite(t60)) else 1.0
        width = min(shortest / LATE_BINS_PER_T60, MAX_COMPACT_LATE_BIN_S)
        split = max(1, math.floor(width / options.late_bin_s + 1e-9))
    else:
        split = round(float(options.compact_late_bin_s) / options.late_bin_s)
    return early_s, split * options.late_bin_s, split


def late_groups(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray],
                stored_late_s: float) -> list[int] | None:
    """A compact field's late bins per band: band b's stored bins summed in groups of
    floor(T60_b / LATE_BINS_PER_T60 / stored width) (at most MAX_COMPACT_LATE_BIN_S wide), so
    that every band's late bin spans the same decay, 60 dB / LATE_BINS_PER_T60 (0.6 dB), as the
    shortest T60's does (T60_b: Sabine's, air included). None for full storage, a given
    ``compact_late_bin_s``, or when no band's bins would widen."""
    if options.storage == "full" or options.compact_late_bin_s != "auto":
        return None
    t60 = sabine_t60(scene.volume_m3, _absorption_area(scene, arrays["absorption"]),
                     arrays["air"], scene.settings.speed_of_sound_m_s)
    if not np.all(np.isfinite(t60)):
        return None
    width = np.minimum(np.asarray(t60, float) / LATE_BINS_PER_T60, MAX_COMPACT_LATE_BIN_S)
    groups = [max(1, math.floor(w / stored_late_s + 1e-9)) for w in width]
    return groups if max(groups) > 1 else None


def field_shape(scene: Scene, options: SoundOptions, max_time_s: float,
                arrays: dict[str, np.ndarray]) -> sound_budget.FieldShape:
    """The bake's field, as the core lays it out (``SoundSettings::layout``)."""
    fs = float(scene.settings.sample_rate_hz)
    early_s, late_bin_s, _ = stored_axis(scene, options, arrays)
    early_bins = round(early_s * fs)
    late_bins = math.ceil(max(max_time_s - early_bins / fs, 0.0) / late_bin_s)
    return sound_budget.FieldShape(scene.receivers.count,
                                   options.azimuth_bands * options.elevation_bands,
                                   len(scene.settings.bands_hz), early_bins, late_bins)


def memory_plan(scene: Scene, options: SoundOptions, arrays: dict[str, np.ndarray], *,
                settings_of: tuple[int, float],
                group_bands: int | None = None) -> sound_budget.MemoryPlan:
    """How the bake fits its budget (``options.memory_bytes``, default
    :func:`sonolux.memory.budget_bytes`) with ``settings_of`` = (rays traced, max_time_s) and,
    with level of detail, ``group_bands`` the largest band group traced at once; refused up
    front with what would fit."""
    traced, max_time_s = settings_of
    shape = field_shape(scene, options, max_time_s, arrays)
    compact = options.storage == "compact"
    cells = sound_budget.early_cells_estimate(
        shape, rays=traced, sources=len(scene.sources), estimator=options.estimator,
        sample_rate_hz=float(scene.settings.sample_rate_hz),
        speed_of_sound_m_s=scene.settings.speed_of_sound_m_s, volume_m3=scene.volume_m3,
        area_m2=scene.area_m2, radius_m=scene.receivers.radius_m)
    fields = 1 if options.waves else len(traced_sources(scene, options))
    if fields > 1:  # each source's field holds its own crossings only
        cells = sound_budget.early_cells_estimate(
            shape, rays=traced, sources=1, estimator=options.estimator,
            sample_rate_hz=float(scene.settings.sample_rate_hz),
            speed_of_sound_m_s=scene.settings.speed_of_sound_m_s, volume_m3=scene.volume_m3,
            area_m2=scene.area_m2, radius_m=scene.receivers.radius_m)
    partial = options.ray_range is not None and tuple(options.ray_range) != (0, options.rays)
    return sound_budget.plan(shape, options.memory_bytes or budget_bytes(), compact=compact,
                             keep_counts=options.ray_range is not None, early_cells=cells,
                             fields=fields, group_bands=group_bands,
                             reduced=None if partial else
                             reduction(options, scene.settings.sample_rate_hz))


def traced_sources(scene: Scene, options: SoundOptions) -> list[int]:
    """The indices of the scene's sources the bake traces: ``options.sources`` by name (in the
    scene's order), or all; an unknown name is an error naming the scene's sources."""
    names = [s.name for s in scene.sources]
    if options.sources is None:
        return list(range(len(names)))
    unknown = [n for n in options.sources if n not in names]
    if unknown:
        raise SonoluxError(f"sources: {', '.join(map(repr, unknown))} not in {scene.origin}; "
                           f"its sources are {', '.join(names)}")
    if options.waves and len(options.sources) < len(names):
        raise SonoluxError("sources: a bake with waves bakes every source of the scene "
                           "together (the wave solver does not bake sources apart yet)")
    return [k for k, n in enumerate(names) if n in options.sources]


def _stacked_arrivals(arrivals: dict[str, np.ndarray], runs: list[int | None],
                      n_receivers: int) -> dict[str, np.ndarray]:
    """A hybrid's early arrivals of the traced sources, each run's receivers offset as the
    fields are stacked (run j's receiver r is row j × n_receivers + r) and its ``source`` the
    run's index (into the field's ``source_names``)."""
    if runs == [None]:
        return arrivals
    source = np.asarray(arrivals["source"])
    keep = np.isin(source, [k for k in runs if k is not None])
    out = {k: np.asarray(v)[keep] for k, v in arrivals.items()}
    slot = {k: j for j, k in enumerate(runs)}
    run = np.array([slot[int(k)] for k in out["source"]], dtype=np.int64)
    out["source"] = run.astype(source.dtype)  # the index into the field's source_names
    out["receiver"] = out["receiver"] + (n_receivers * run).astype(out["receiver"].dtype)
    return out


def reduction(options: SoundOptions, sample_rate_hz: float) -> tuple[int, int]:
    """(arrivals kept, samples per envelope bin) of a compact field's early part."""
    return options.compact_arrivals, max(1, round(options.compact_envelope_s * sample_rate_hz))
