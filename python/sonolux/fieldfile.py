"""The field file: one HDF5 file (h5py) for what a bake computed, sound and light side by side.

It is written to a temporary file beside its target and renamed into place, so that an
interrupted bake never leaves a broken file behind. This module is the only one that reads or
writes it; the layout, one axis order for every array, is documented in ``docs/fieldfile.md``.

Schema ``sonolux-field/2`` (lengths in metres, times in seconds, energies in J/m²):

    /                      attrs: schema, sonolux_version, created_utc, scene_name, scene_origin,
                                  bake (JSON: what the bake shared between the senses, timings)
    /sound                 attrs: settings (JSON), stats (JSON), theory (JSON: volume_m3,
                                  area_m2, mean_free_path_m, mean_absorption, Sabine and Eyring
                                  T60 per band), radius_m, grid_spacing_m (NaN for listed
                                  points), quantum
    /sound/energy          float32[receiver, direction, band, time], gzip, a chunk a receiver
    /sound/counts          uint64[receiver, direction, band, time] (ray-range bakes only:
                           energy = counts × quantum, exactly)
    /sound/bin_start_s, /sound/bin_width_s   float64[time]
    /sound/bands_hz        float64[band];  /sound/directions  str[direction]
    /sound/receivers_m     float64[receiver, 3];  /sound/grid_index  int64[receiver, 2]
    /sound/sources_m       float64[source, 3];    /sound/source_powers_w  float64[source]
    /sound/sources/<k>/... (bakes of several sources: a field per source; attrs names (JSON)
                           on /sound/sources, name on each; each group holds energy, counts
                           and early as /sound does for a bake of one source; /sound has no
                           energy then)
    /sound/early/...       (hybrid bakes only: the exact early arrivals, already in energy)
                           source, receiver, kind (0 specular, 1 diffracted), order,
                           direction_bin, time_bin (-1 past the end) int64[arrival];
                           time_s float64[arrival]; from_direction float64[arrival, 3];
                           energy float64[arrival, band]
    /sound/waves/pressure  (hybrid bakes with waves only) float32[receiver, time]: the waves'
                           pressure response below the crossover, in sqrt(W/m²), time 0 at
                           emission; attrs sample_rate_hz, crossover_hz, wave_bands (bands
                           [0, wave_bands) of energy came from the waves), max_frequency_hz,
                           schroeder_hz
    /sound/waves/energy    (the ray-range part from ray 0 of a hybrid bake only) float32[receiver,
                           direction, wave band, time]: the waves' energy, not yet in
                           /sound/energy; joined when the parts are merged (docs/waves-hybrid.md)
    /light                 attrs: settings (JSON), stats (JSON), patch_size_m
    /light/patch_resolution uint32[triangle];  /light/patch_offset  uint64[triangle + 1]
    /light/patch_area_m2   float64[patch];  /light/flux_w  float64[patch, channel]
    /light/hits            uint64[patch]
    /light/scene/...       vertices_m float64[vertex, 3], triangles int64[triangle, 3],
                           material_index int32[triangle], surface_tag str[triangle],
                           material_names str[material], rho float64[material, channel],
                           specular and roughness float64[material],
                           emitted_radiance float64[triangle, channel]
    /light/emitters/...    triangles_m float64[emitter, corner, 3], radiance
                           float64[emitter, channel], light int32[emitter]
    /light/lights/...      names and kinds str[light], power_w float64[light]
    /light/workplane       (when the scene has a work plane) attrs: height_m, spacing_m;
                           positions_m float64[cell, 3] (centres), grid_index int64[cell, 2],
                           illuminance_lx float64[cell], hits uint64[cell], and
                           daylight_factor_percent float64[cell] when an overcast sky is the
                           only light

Both groups are optional, at least one is there; readers ignore groups they do not know.
Format 1 (``sonolux-field/1``) still opens: its ``/sound/counts`` was [time, receiver,
direction, band] and it had no ``theory``.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import FieldFileError, SonoluxError
from sonolux.fieldcheck import Checker, check_light, check_sound
from sonolux.light.field import LightField
from sonolux.light.workplane import WorkplaneResult
from sonolux.outputs import atomic_output
from sonolux.sound.compact import CompactArray
from sonolux.sound.field import SoundField, with_source_energy

SCHEMA = "sonolux-field/3"
#: Schemas this version reads: the current one and the two before it.
READABLE = (SCHEMA, "sonolux-field/2", "sonolux-field/1")
#: What /sound/waves carries besides its pressure.
WAVE_ATTRS = ("sample_rate_hz", "crossover_hz", "wave_bands", "max_frequency_hz", "schroeder_hz")
LIGHT_SCENE_ARRAYS = ("vertices_m", "triangles", "material_index", "rho", "specular",
                      "roughness", "emitted_radiance")


def json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.integer, np.floating)):
        return o.item()
    return str(o)


def _json(value: Any) -> str:
    return json.dumps(value, default=json_default)


# --- writing ---------------------------------------------------------------------------------
def save_fields(path: str | Path, *, sound: SoundField | None = None,
                light: LightField | None = None, bake: dict[str, Any] | None = None) -> Path:
    """Writes the fields given to ``path`` (a temporary file beside it, then renamed)."""
    import h5py

    from sonolux.version import __version__

    if sound is None and light is None:
        raise SonoluxError(f"{path}: nothing to write (neither a sound nor a light field)")
    first: SoundField | LightField = sound if sound is not None else light  # type: ignore[assignment]
    path = Path(path)
    with atomic_output(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs.update(schema=SCHEMA, sonolux_version=__version__,
                       created_utc=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                       scene_name=first.scene_name, scene_origin=first.scene_origin)
        if bake is not None:
            f.attrs["bake"] = _json(bake)
        if sound is not None:
            _write_sound(f, sound)
        if light is not None:
            _write_light(f, light)
    for field in (sound, light):
        if field is not None:
            field.path = str(path)
    return path


def _write_sound(f: Any, field: SoundField) -> None:
    import h5py

    g = f.create_group("sound")
    g.attrs["settings"] = _json(field.settings)
    g.attrs["stats"] = _json(field.stats)
    if field.theory is not None:
        g.attrs["theory"] = _json(field.theory)
    g.attrs["radius_m"] = field.radius_m
    g.attrs["grid_spacing_m"] = field.grid_spacing_m if field.grid_spacing_m else np.nan
    g.attrs["quantum"] = field.quantum
    if field.per_source is None:
        _write_source(g, field)
    else:  # a field per source: /sound/sources/<k>/ as /sound holds one (docs/fieldfile.md)
        sources = g.create_group("sources")
        sources.attrs["names"] = _json(field.source_names)
        for k, name in enumerate(field.source_names):
            h = sources.create_group(str(k))
            h.attrs["name"] = name
            _write_source(h, field.for_source(k))
    g["bin_start_s"] = field.bin_start_s
    g["bin_width_s"] = field.bin_width_s
    g["bands_hz"] = field.bands_hz
    g["directions"] = np.array(field.direction_names, dtype=h5py.string_dtype())
    g["receivers_m"] = field.positions_m
    if field.grid_index is not None:
        g["grid_index"] = np.asarray(field.grid_index, np.int64)
    g["sources_m"] = field.source_positions_m
    g["source_powers_w"] = field.source_powers_w
    if field.waves is not None:
        w = g.create_group("waves")
        p = np.asarray(field.waves["pressure"], np.float32)
        w.create_dataset("pressure", data=p, compression="gzip", shuffle=True,
                         chunks=(1, p.shape[1]) if p.size else None)
        for k in WAVE_ATTRS:
            w.attrs[k] = field.waves[k]
        if "energy" in field.waves:  # a ray range's waves, not yet joined (docs/waves-hybrid.md)
            w.create_dataset("energy", data=np.asarray(field.waves["energy"], np.float32),
                             compression="gzip", shuffle=True)


def _write_source(g: Any, field: SoundField) -> None:
    """One source's (or all sources') energy, counts and early arrivals into group ``g``."""
    _write_array(g, "energy", field.energy)
    if field.counts is not None:
        _write_array(g, "counts", field.counts)
    if field.early is not None:
        early = g.create_group("early")
        for name, values in field.early.items():
            early.create_dataset(name, data=values, compression="gzip", shuffle=True)


def _write_array(g: Any, name: str, a: Any) -> None:
    """A [receiver, direction, band, time] array: a dataset when dense; a group when compact
    (``early_bins`` attr; ``offset``, ``cell``, ``early``, ``late``: docs/fieldfile.md)."""
    if isinstance(a, CompactArray):
        c = g.create_group(name)
        c.attrs["early_bins"] = a.early_bins
        c.attrs["late_split"] = a.late_split
        c.attrs["envelope_split"] = a.envelope_split
        c.attrs["reduced"] = a.envelope is not None
        if a.late_groups is not None:
            c.attrs["late_groups"] = np.asarray(a.late_groups, np.int64)
        if a.onset is not None:
            c.create_dataset("onset", data=a.onset, compression="gzip", shuffle=True)
        if a.envelope is not None:
            env = a.envelope
            c.create_dataset("envelope", data=env, compression="gzip", compression_opts=4,
                             shuffle=True, chunks=(1, *env.shape[1:]) if env.size else None)
        c.create_dataset("offset", data=a.offset, compression="gzip", shuffle=True)
        for key, data in (("cell", a.cell), ("early", a.value)):
            c.create_dataset(key, data=data, compression="gzip", compression_opts=4,
                             shuffle=True, chunks=(min(max(data.size, 1), 65536),))
        late = a.late
        chunks = (1, *late.shape[1:]) if late.shape[0] and late.size else None
        c.create_dataset("late", data=late, compression="gzip", compression_opts=4,
                         shuffle=True, chunks=chunks)
        return
    per_receiver = (1, *a.shape[1:]) if a.shape[0] and a.size else None
    g.create_dataset(name, data=a, compression="gzip", compression_opts=4, shuffle=True,
                     chunks=per_receiver)


def _read_array(c: Checker, g: Any, name: str) -> Any:
    """What :func:`_write_array` wrote, checked for consistency."""
    import h5py

    if not isinstance(g.get(name), h5py.Group):
        return c.dataset(g, name)
    h = g[name]
    early_bins = int(h.attrs["early_bins"])
    offset = c.array(f"{name}/offset", c.dataset(h, "offset"), 1, lo=0, kind="iu")
    cell = c.array(f"{name}/cell", c.dataset(h, "cell"), 1, lo=0, kind="iu")
    early, late = c.dataset(h, "early"), c.dataset(h, "late")
    if late.ndim != 4 or offset.ndim != 1 or offset.size != late.shape[0] + 1:
        raise c.fail(name, f"has {offset.size} offsets for {late.shape[0] if late.ndim else 0} "
                           "receivers (one more than receivers expected)")
    if offset[0] != 0 or np.any(np.diff(offset) < 0) or offset[-1] != cell.size \
            or cell.size != early.size:
        raise c.fail(name, "has offsets that do not match its cells")
    per = late.shape[1] * late.shape[2] * early_bins
    if cell.size and int(np.max(cell)) >= per:
        raise c.fail(name, f"has a cell index ≥ {per}, past a receiver's early cells")
    reduced = bool(h.attrs.get("reduced", "envelope" in h))
    envelope = c.array(f"{name}/envelope", c.dataset(h, "envelope"), 4, lo=0.0, kind="f") \
        if reduced else None
    split = int(h.attrs.get("envelope_split", 1))
    if envelope is not None and (envelope.shape[:3] != late.shape[:3] or split < 1
                                 or envelope.shape[3] != -(-early_bins // split)):
        raise c.fail(f"{name}/envelope", f"has shape {envelope.shape}, not that of "
                                         f"{early_bins} early bins in bins of {split}")
    late_split = int(h.attrs.get("late_split", 1))
    if late_split < 1:
        raise c.fail(name, f"has late_split = {late_split}, not a whole number ≥ 1")
    onset = c.array(f"{name}/onset", c.dataset(h, "onset"), 1, lo=0, kind="iu") \
        if reduced else None
    if onset is not None and (onset.shape != (late.shape[0],) or onset.size
                              and (np.min(onset) < 0 or np.max(onset) >= max(early_bins, 1))):
        raise c.fail(f"{name}/onset", "is not one early sample per receiver")
    groups = h.attrs.get("late_groups")
    if groups is not None:
        groups = np.asarray(groups)
        if groups.shape != (late.shape[2],) or groups.dtype.kind not in "iu" \
                or np.any(groups < 1) or not reduced:
            raise c.fail(f"{name}", f"has late_groups {groups.tolist()}: one whole number ≥ 1 a "
                                    f"band ({late.shape[2]}) of a reduced field expected")
        groups = groups.astype(np.int64)
    return CompactArray(early_bins, offset.astype(np.int64), cell.astype(np.uint32), early, late,
                        late_split, envelope, split,
                        None if onset is None else onset.astype(np.int64), groups)


def _write_light(f: Any, field: LightField) -> None:
    import h5py

    text = h5py.string_dtype()
    g = f.create_group("light")
    g.attrs["settings"] = _json(field.settings)
    g.attrs["stats"] = _json(field.stats)
    g.attrs["patch_size_m"] = field.patch_size_m
    g["patch_resolution"] = np.asarray(field.patch_resolution, np.uint32)
    g["patch_offset"] = np.asarray(field.patch_offset, np.uint64)
    g.create_dataset("patch_area_m2", data=field.patch_area_m2, compression="gzip", shuffle=True)
    g.create_dataset("flux_w", data=field.flux_w, compression="gzip", shuffle=True)
    g.create_dataset("hits", data=np.asarray(field.hits, np.uint64), compression="gzip",
                     shuffle=True)
    s = g.create_group("scene")
    for name in LIGHT_SCENE_ARRAYS:
        s[name] = getattr(field, name)
    s["surface_tag"] = np.array([str(t) for t in field.surface_tag], dtype=text)
    s["material_names"] = np.array(field.material_names, dtype=text)
    e = g.create_group("emitters")
    e["triangles_m"] = field.emitter_triangles_m
    e["radiance"] = field.emitter_radiance
    e["light"] = np.asarray(field.emitter_light, np.int32)
    lights = g.create_group("lights")
    lights["names"] = np.array(field.light_names, dtype=text)
    lights["kinds"] = np.array(field.light_kinds, dtype=text)
    lights["power_w"] = field.light_power_w
    wp = field.workplane
    if wp is not None:
        w = g.create_group("workplane")
        w.attrs["height_m"] = float(wp.height_m)
        w.attrs["spacing_m"] = float(wp.spacing_m)
        w["positions_m"] = np.asarray(wp.positions_m, np.float64)
        w["grid_index"] = np.asarray(wp.grid_index, np.int64)
        w["illuminance_lx"] = np.asarray(wp.illuminance_lx, np.float64)
        w["hits"] = np.asarray(wp.hits, np.uint64)
        if wp.daylight_factor_percent is not None:
            w["daylight_factor_percent"] = np.asarray(wp.daylight_factor_percent, np.float64)


# --- reading ---------------------------------------------------------------------------------
@contextmanager
def open_file(path: str | Path) -> Iterator[Any]:
    """The open h5py file, after checking that it is a sonolux field file this version reads."""
    import h5py

    path = Path(path)
    if not path.exists():
        raise FieldFileError(f"{path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise FieldFileError(f"{path}: not an HDF5 file sonolux can read ({exc})") from None
    with f:
        try:
            schema = f.attrs.get("schema")
        except (OSError, ValueError, TypeError) as exc:
            raise FieldFileError(f"{path}: damaged HDF5 file ({' '.join(str(exc).split())})") from None
        if isinstance(schema, bytes):
            schema = schema.decode()
        if schema not in READABLE:
            raise FieldFileError(f"{path}: not a sonolux field file this version reads (schema "
                                 f"{schema!r}; readable: {', '.join(READABLE)})")
        yield f


def schema_of(path: str | Path) -> str:
    with open_file(path) as f:
        return str(f.attrs["schema"])


def contents(path: str | Path) -> dict[str, Any]:
    """What the file holds: {"sound": bool, "light": bool, "bake": dict or None, "schema": str}."""
    with open_file(path) as f:
        bake = f.attrs.get("bake")
        return {"sound": "sound" in f, "light": "light" in f, "schema": str(f.attrs["schema"]),
                "bake": json.loads(bake) if bake is not None else None}


def open_field(path: str | Path) -> SoundField:
    """The sound field of a field file; a missing, unreadable or foreign file, or one baked
    without sound, is a clear error."""
    with open_file(path) as f:
        return _read_sound(f, str(path))


def open_light_field(path: str | Path) -> LightField:
    """The light field of a field file; a clear error when the file has none."""
    with open_file(path) as f:
        return _read_light(f, str(path))


def _read_sound(f: Any, path: str) -> SoundField:
    if "sound" not in f:
        raise FieldFileError(f"{path}: the file holds no sound field (/sound is missing; it was "
                             "baked without sound: run sonolux bake with --sound)")
    g = f["sound"]
    c = Checker(path, "sound")
    try:
        spacing = float(g.attrs["grid_spacing_m"])
        theory = g.attrs.get("theory")
        arrays = dict(
            energy=None, bin_start_s=c.dataset(g, "bin_start_s"),
            bin_width_s=c.dataset(g, "bin_width_s"), bands_hz=c.dataset(g, "bands_hz"),
            positions_m=c.dataset(g, "receivers_m"), radius_m=float(g.attrs["radius_m"]),
            grid_index=c.dataset(g, "grid_index") if "grid_index" in g else None,
            grid_spacing_m=None if np.isnan(spacing) else spacing,
            source_positions_m=c.dataset(g, "sources_m"),
            source_powers_w=c.dataset(g, "source_powers_w"),
            settings=json.loads(g.attrs["settings"]), stats=json.loads(g.attrs["stats"]),
            counts=None, quantum=float(g.attrs["quantum"]),
            theory=json.loads(theory) if theory is not None else None)
        if "sources" in g:
            stacked, arrays["counts"], early = _read_sources(c, g["sources"], arrays)
        else:
            arrays["counts"] = _read_array(c, g, "counts") if "counts" in g else None
            if arrays["counts"] is not None and f.attrs["schema"] == "sonolux-field/1":
                # was [time, r, d, b]
                arrays["counts"] = np.ascontiguousarray(arrays["counts"].transpose(1, 2, 3, 0))
            arrays["energy"] = stacked = _read_array(c, g, "energy")
            check_sound(path, arrays)
            early = {k: g["early"][k][...] for k in g["early"]} if "early" in g else None
        waves = _read_waves(c, g, dict(arrays, energy=stacked)) if "waves" in g else None
        field = SoundField(**dict(arrays, energy=stacked),
                           scene_name=str(f.attrs.get("scene_name", "")),
                           scene_origin=str(f.attrs.get("scene_origin", "")), path=path,
                           early=early, waves=waves)
        return with_source_energy(field, stacked)
    except KeyError as exc:
        raise FieldFileError(f"{path}: the sound field is incomplete ({exc.args[0]} is "
                             "missing)") from None
    except (ValueError, TypeError, OSError) as exc:  # JSON, attributes, truncated chunks
        raise FieldFileError(f"{path}: the sound field cannot be read "
                             f"({' '.join(str(exc).split())})") from None


def _read_sources(c: Checker, s: Any, arrays: dict[str, Any]) -> tuple[Any, Any, Any]:
    """/sound/sources/<k>/: each source's energy, counts and early arrivals, each checked
    as a field of its own, stacked along the receiver axis (source k's rows k × receivers …)."""
    names = json.loads(s.attrs["names"])
    if not (isinstance(names, list) and names and all(isinstance(n, str) for n in names)) \
            or [str(k) for k in range(len(names))] != sorted(s, key=lambda n: int(n)
                                                             if n.isdigit() else -1):
        raise c.fail("sources", f"has groups {sorted(s)} for the names {names!r}: one group "
                                "0, 1, … per name expected")
    if arrays["settings"].get("source_names") != names:
        raise c.fail("sources", f"names {names!r} differ from settings.source_names")
    energies, counts, early = [], [], []
    n = len(arrays["positions_m"])
    for k in range(len(names)):
        h = s[str(k)]
        part = dict(arrays, energy=_read_array(c, h, "energy"),
                    counts=_read_array(c, h, "counts") if "counts" in h else None)
        check_sound(c.path, part)
        energies.append(part["energy"])
        counts.append(part["counts"])
        if "early" in h:
            e = {key: h["early"][key][...] for key in h["early"]}
            e["receiver"] = e["receiver"] + k * n
            e["source"] = np.full_like(e["source"], k)
            early.append(e)
    if any(c_ is None for c_ in counts) and any(c_ is not None for c_ in counts):
        raise c.fail("sources", "hold counts for some sources and not for others")
    join = CompactArray.concatenate if isinstance(energies[0], CompactArray) else np.concatenate
    if len({type(e) for e in energies}) != 1 or len({type(e) for e in counts}) != 1:
        raise c.fail("sources", "mix compact and full storage")
    arrivals = None if not early else {key: np.concatenate([e[key] for e in early])
                                       for key in early[0]}
    return join(energies), None if counts[0] is None else join(counts), arrivals


def _read_waves(c: Checker, g: Any, arrays: dict[str, Any]) -> dict[str, Any]:
    """/sound/waves, checked against the field it belongs to."""
    w = g["waves"]
    waves: dict[str, Any] = {k: float(w.attrs[k]) for k in WAVE_ATTRS}
    waves["wave_bands"] = int(waves["wave_bands"])
    waves["pressure"] = c.dataset(w, "pressure")
    p = waves["pressure"]
    n_rec, n_bands = arrays["energy"].shape[0], arrays["energy"].shape[2]
    if p.ndim != 2 or p.shape[0] != n_rec or not np.all(np.isfinite(p)):
        raise FieldFileError(f"{c.path}: /sound/waves/pressure must be finite float[receiver "
                             f"= {n_rec}, time], not shape {p.shape}")
    if not (0 < waves["wave_bands"] < n_bands + 1 and waves["sample_rate_hz"] > 0):
        raise FieldFileError(f"{c.path}: /sound/waves: wave_bands = {waves['wave_bands']} and "
                             f"sample_rate_hz = {waves['sample_rate_hz']} do not fit a field "
                             f"of {n_bands} bands")
    if "energy" in w:  # a ray range's waves, joined when the ranges are merged
        e = waves["energy"] = c.dataset(w, "energy")
        shape = (n_rec, arrays["energy"].shape[1], waves["wave_bands"])
        if e.ndim != 4 or e.shape[:3] != shape or not np.all(np.isfinite(e)):
            raise FieldFileError(f"{c.path}: /sound/waves/energy must be finite float[receiver, "
                                 f"direction, wave band = {shape}, time], not shape {e.shape}")
    return waves


def _strings(d: Any) -> list[str]:
    return [v.decode() if isinstance(v, bytes) else str(v) for v in d[...]]


def _read_workplane(w: Any) -> WorkplaneResult:
    df = w["daylight_factor_percent"][...] if "daylight_factor_percent" in w else None
    return WorkplaneResult(float(w.attrs["height_m"]), float(w.attrs["spacing_m"]),
                           w["positions_m"][...], w["grid_index"][...], w["illuminance_lx"][...],
                           w["hits"][...], df)


def _read_light(f: Any, path: str) -> LightField:
    if "light" not in f:
        raise FieldFileError(f"{path}: the file holds no light field (/light is missing; it was "
                             "baked without light: run sonolux bake with --light)")
    g = f["light"]
    c = Checker(path, "light")
    try:
        s, e, lights = g["scene"], g["emitters"], g["lights"]
        arrays = dict(
            patch_size_m=float(g.attrs["patch_size_m"]),
            patch_resolution=c.dataset(g, "patch_resolution"),
            patch_offset=c.dataset(g, "patch_offset"), patch_area_m2=c.dataset(g, "patch_area_m2"),
            flux_w=c.dataset(g, "flux_w"), hits=c.dataset(g, "hits"),
            **{name: c.dataset(s, name) for name in LIGHT_SCENE_ARRAYS},
            emitter_triangles_m=c.dataset(e, "triangles_m"),
            emitter_radiance=c.dataset(e, "radiance"), emitter_light=c.dataset(e, "light"),
            light_power_w=c.dataset(lights, "power_w"))
        check_light(path, arrays, len(lights["names"]))
        return LightField(
            **arrays, surface_tag=np.array(_strings(s["surface_tag"]), dtype=str),
            material_names=_strings(s["material_names"]), light_names=_strings(lights["names"]),
            light_kinds=_strings(lights["kinds"]),
            settings=json.loads(g.attrs["settings"]), stats=json.loads(g.attrs["stats"]),
            scene_name=str(f.attrs.get("scene_name", "")),
            scene_origin=str(f.attrs.get("scene_origin", "")), path=path,
            workplane=_read_workplane(g["workplane"]) if "workplane" in g else None)
    except KeyError as exc:
        raise FieldFileError(f"{path}: the light field is incomplete ({exc.args[0]} is "
                             "missing)") from None
    except (ValueError, TypeError, OSError) as exc:  # JSON, attributes, truncated chunks
        raise FieldFileError(f"{path}: the light field cannot be read "
                             f"({' '.join(str(exc).split())})") from None
