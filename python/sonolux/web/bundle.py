"""``sonolux export FIELD --web DIR``: the bundle the browser viewer reads.

Two kinds: ``sonolux-web/3`` (the default, ``responses="compact"``): each cell holds the
compact field of every source field (:mod:`sonolux.web.compact_cells`) and the browser
synthesises the responses; ``sonolux-web/2`` (``responses="pcm"``, and for fields with a wave
part): each cell holds the synthesised responses, as described below.

Files (format ``sonolux-web/2``), written into a temporary folder beside DIR and renamed into
place, so that a reader never sees half a bundle:

- ``scene.glb``: the scene (see :mod:`sonolux.web.geometry`), glTF axes (y up).
- ``responses.bin``: one block a cell: that cell's full responses, direction by direction, then
  its direct-sound responses, each as :mod:`sonolux.web.responses` packs it (8-byte aligned);
  with ``encoding`` "deflate" (the default) each block is stored zlib-compressed, its inflated
  size in the cell's ``raw_length``. A viewer fetches one cell's block with an HTTP range.
- ``field.json``: the index, in sonolux's axes (metres, z up, azimuth 0° = +x,
  counter-clockwise). Per cell: ``position_m``, ``grid_index``, ``byte_offset`` and
  ``byte_length`` of its block in ``responses.bin``, its ``crc32``, and per direction
  ``full`` and ``direct`` entries ``[delay, length, offset, scale]``: ``delay`` zeros, then
  ``length`` samples starting ``offset`` samples into the (inflated) block, each times
  ``scale``. ``byte_offset``, ``byte_length`` and ``crc32`` are of the block as stored.
  ``playback_gain`` scales every response so that the loudest cell (all directions) has unit
  energy: a dry signal of RMS a gives at most RMS a.

Responses are pressures in sqrt(W/m²) (see :mod:`sonolux.sound.synthesis`); levels between
cells are kept, so walking away from a source makes it quieter.
"""

from __future__ import annotations

import json
import math
import os
import time
import zlib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.outputs import atomic_folder
from sonolux.sound.field import SoundField
from sonolux.sound.synthesis import PAD_PERIODS
from sonolux.web.compact_cells import (
    Axis,
    axis_of,
    check_synthesisable,
    cut_bins,
    cut_cell,
    exact_arrivals,
    pressure_energy,
    receiver_compact,
    reduced_energy,
    stored_energy_per_bin,
)
from sonolux.web.geometry import glb_triangles, plan_segments, write_scene_glb
from sonolux.web.options import WebExportOptions
from sonolux.web.responses import FADE_OUT_S, cell_responses, pack

FORMAT = "sonolux-web/2"
FORMAT_COMPACT = "sonolux-web/3"
FILES = ("field.json", "responses.bin", "scene.glb")
_ALIGN = 8


@dataclass
class BundleSummary:
    path: Path
    cells: int
    directions: int
    responses_bytes: int
    response_length_s: float
    scene_source: str
    seconds: float
    warnings: list[str] = field(default_factory=list)
    format: str = FORMAT

    def describe(self) -> str:
        what = ("compact cells, synthesised by the browser" if self.format == FORMAT_COMPACT
                else "responses")
        return (f"web bundle {self.path} ({self.format}): {self.cells} cells × {self.directions} "
                f"directions, {what} {self.responses_bytes / 1e6:.1f} MB (up to "
                f"{self.response_length_s:.2f} s), scene from {self.scene_source}, in "
                f"{self.seconds:.1f} s")


def direction_table(sound: SoundField) -> list[dict]:
    """Name, azimuth and elevation (degrees) of every direction bin, in index order.
    Elevation bands have equal solid angle: band e of n spans sin(el) in
    [−1 + 2e/n, −1 + 2(e+1)/n] and is centred on the middle of that."""
    n_az, n_el = sound.azimuth_bands, sound.elevation_bands
    out = []
    for k, name in enumerate(sound.direction_names):
        e, a = divmod(k, n_az)
        el = 0.0 if n_el == 1 else math.degrees(math.asin(-1 + (2 * e + 1) / n_el))
        out.append({"name": name, "azimuth_deg": 360.0 * a / n_az, "elevation_deg": round(el, 6)})
    return out


def export_web(field_path: str | Path, out_dir: str | Path, options: WebExportOptions | None = None,
               log: Callable[[str], None] | None = None) -> BundleSummary:
    """Writes the bundle of the field file ``field_path`` into ``out_dir`` (replaced whole if it
    is a bundle already; a folder holding anything else is refused)."""
    from sonolux.fieldfile import open_field

    options = (options or WebExportOptions()).validate()
    say = log or (lambda _m: None)
    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    _check_target(out_dir)
    sound = open_field(field_path)
    if sound.n_receivers == 0:
        raise SonoluxError(f"{field_path}: the field has no receivers, so nothing to walk through")
    if options.responses == "compact" and sound.waves is not None:
        say("note: the field has a wave part (a hybrid bake), which the browser cannot "
            "synthesise: writing its responses (sonolux-web/2)")
    elif options.responses == "compact":
        return write_compact_bundle(source_fields(sound), field_path, out_dir, options, say, t0)
    with atomic_folder(out_dir) as tmp:
        glb = write_scene_glb(sound, field_path, tmp / "scene.glb")
        for w in glb.warnings:
            say(f"warning: {w}")
        cells, gain, n_bytes, longest = _write_responses(sound, tmp / "responses.bin", options, say)
        tris = glb_triangles(tmp / "scene.glb")
        head_z = float(np.mean(sound.positions_m[:, 2]))
        index = _index(sound, options, cells, gain, n_bytes, longest, tris, head_z, glb)
        (tmp / "field.json").write_text(json.dumps(index, indent=1, ensure_ascii=False) + "\n",
                                        encoding="utf-8")
    return BundleSummary(out_dir, sound.n_receivers, sound.energy.shape[1], n_bytes,
                         longest / sound.sample_rate_hz, glb.source, time.perf_counter() - t0,
                         glb.warnings)


def source_fields(sound: SoundField) -> list[tuple[str, SoundField]]:
    """(name, field) of every source: ``SoundField.for_source`` where the field holds several
    (a field per source, issue 19), else the one field as "all"."""
    names = list(getattr(sound, "source_names", None) or [])
    if len(names) > 1 and hasattr(sound, "for_source"):
        return [(n, sound.for_source(k)) for k, n in enumerate(names)]
    return [("all", sound)]


def write_compact_bundle(fields: list[tuple[str, SoundField]], field_path: str | Path,
                         out_dir: str | Path, options: WebExportOptions | None = None,
                         say: Callable[[str], None] | None = None,
                         t0: float | None = None) -> BundleSummary:
    """Writes a ``sonolux-web/3`` bundle of the source fields ``fields`` (name, field: the same
    receivers, bands and time axis) into ``out_dir``; the scene comes from ``field_path``."""
    options = (options or WebExportOptions()).validate()
    say = say or (lambda _m: None)
    t0 = time.perf_counter() if t0 is None else t0
    out_dir = Path(out_dir)
    _check_target(out_dir)
    if not fields:
        raise SonoluxError("no source fields to write")
    sound = fields[0][1]
    names = [n for n, _ in fields]
    if len(set(names)) != len(names) or not all(isinstance(n, str) and n for n in names):
        raise SonoluxError(f"source names {names} are not allowed: distinct, non-empty names")
    for name, f in fields:
        check_synthesisable(f, name)
        if f.n_receivers != sound.n_receivers or f.energy.shape[1:3] != sound.energy.shape[1:3] \
                or not np.array_equal(f.bin_start_s, sound.bin_start_s) \
                or not np.allclose(f.positions_m, sound.positions_m):
            raise SonoluxError(f"source field {name!r} does not have the receivers, directions, "
                               "bands and time axis of the first")
    axes = [axis_of(f) for _, f in fields]
    if any(a != axes[0] for a in axes):
        raise SonoluxError("the source fields are not stored alike (compact settings differ)")
    axis = axes[0]
    with atomic_folder(out_dir) as tmp:
        glb = write_scene_glb(sound, field_path, tmp / "scene.glb")
        for w in glb.warnings:
            say(f"warning: {w}")
        cells, energy_max, n_bytes, longest = _write_compact_cells(fields, axis, tmp, options, say)
        tris = glb_triangles(tmp / "scene.glb")
        head_z = float(np.mean(sound.positions_m[:, 2]))
        gain = 1.0 / math.sqrt(energy_max) if energy_max > 0 else 1.0
        index = _index(sound, options, cells, gain, n_bytes, longest, tris, head_z, glb)
        index.update(format=FORMAT_COMPACT, encoding="deflate" if options.compress else "none")
        index.pop("sample_format")
        index["synthesis"] = {
            **axis.as_json(), "bands_hz": [float(b) for b in sound.synthesis_bands_hz],
            "azimuth_bands": sound.azimuth_bands,
            "volume_m3": float(sound.settings["volume_m3"]),
            "speed_of_sound_m_s": float(sound.settings["speed_of_sound_m_s"]),
            "fade_out_s": FADE_OUT_S, "pad_periods": PAD_PERIODS,
            "playback_gain_rule": "the loudest cell's pressure energy (all directions and "
                                  "source fields) is one"}
        index["source_fields"] = [
            {"name": n, "positions_m": [[float(v) for v in p]
                                        for p in np.atleast_2d(f.source_positions_m)],
             "power_w": [float(w) for w in np.atleast_1d(f.source_powers_w)]} for n, f in fields]
        (tmp / "field.json").write_text(json.dumps(index, indent=1, ensure_ascii=False) + "\n",
                                        encoding="utf-8")
    return BundleSummary(out_dir, sound.n_receivers, sound.energy.shape[1], n_bytes,
                         longest / sound.sample_rate_hz, glb.source, time.perf_counter() - t0,
                         glb.warnings, FORMAT_COMPACT)


def _write_compact_cells(fields: list[tuple[str, SoundField]], axis: Axis, tmp: Path,
                         options: WebExportOptions, say: Callable[[str], None]):
    """Every cell's block (all source fields) appended to responses.bin: (cells, the largest
    cell energy, bytes, the longest response in samples)."""
    reduced = [reduced_energy(f) for _, f in fields]
    fs = fields[0][1].sample_rate_hz
    n = fields[0][1].n_receivers
    cells, energy_max, offset, longest = [], 0.0, 0, 0
    bands = fields[0][1].synthesis_bands_hz
    limit = None if options.max_length_s is None else int(round(options.max_length_s * fs))
    with open(tmp / "responses.bin", "wb") as f:
        for r in range(n):
            parts = [receiver_compact(fld, red, arr, split, r)
                     for (_, fld), (red, arr, split) in zip(fields, reduced)]
            per_bin = pressure_energy(sum(stored_energy_per_bin(c, axis) for c in parts),
                                      bands, fs)
            energy_max = max(energy_max, float(np.sum(per_bin)))
            late_bins, length = cut_bins(per_bin, axis, options.tail_db)
            if limit is not None:
                length = min(length, limit)
            stored = [cut_cell(c, late_bins, exact_arrivals(fld, r, c))
                      for c, (_, fld) in zip(parts, fields)]
            entries, raw, at = [], [], 0
            for c in stored:
                entries.append({"onset": c.onset, "arrivals": int(c.cell.size),
                                "envelope_bins": int(c.envelope.shape[-1]),
                                "late_bins": int(c.late.shape[-1]),
                                "exact_arrivals": int(c.exact_sample.shape[0]), "byte_offset": at})
                raw.append(c.to_bytes())
                at += c.nbytes
            data = b"".join(raw)
            extra = {}
            if options.compress:
                extra = {"raw_length": len(data)}
                data = zlib.compress(data, 6)
            f.write(data)
            longest = max(longest, length)
            cells.append({"byte_offset": offset, "byte_length": len(data),
                          "crc32": zlib.crc32(data), **extra, "length_samples": int(length),
                          "fields": entries})
            offset += len(data)
            if (r + 1) * 10 // n > r * 10 // n:
                say(f"cells: {r + 1}/{n}")
    return cells, energy_max, offset, longest


def _write_responses(sound: SoundField, path: Path, options: WebExportOptions,
                     say: Callable[[str], None]):
    """Synthesizes every cell (in threads, in order) and appends its block to ``path``."""
    n = sound.n_receivers
    threads = options.threads or os.cpu_count() or 1
    cells, energy_max, offset, longest = [], 0.0, 0, 0

    def one(r: int):
        return cell_responses(sound, r, options.seed, options.max_length_s, options.tail_db)

    with open(path, "wb") as f, ThreadPoolExecutor(max_workers=threads) as pool:
        for r, resp in enumerate(pool.map(one, range(n))):
            energy = sum(float(np.sum(x * x)) for x in resp.full)
            energy_max = max(energy_max, energy)
            block, entries = [], {"full": [], "direct": []}
            at = 0
            for kind in ("full", "direct"):
                for x in getattr(resp, kind):
                    longest = max(longest, x.size)
                    p = pack(x, options.sample_format)
                    entries[kind].append([p.delay, int(p.samples.size), at, float(p.scale)])
                    block.append(p.samples)
                    at += p.samples.size
            data = np.concatenate(block).tobytes() if block else b""
            data += b"\0" * (-len(data) % _ALIGN)
            raw = {}
            if options.compress:
                raw = {"raw_length": len(data)}
                data = zlib.compress(data, 6)  # level 6: 9 saves < 1 % here, at 4× the time
            f.write(data)
            cells.append({"byte_offset": offset, "byte_length": len(data),
                          "crc32": zlib.crc32(data), **raw, **entries})
            offset += len(data)
            if (r + 1) * 10 // n > r * 10 // n:  # every tenth
                say(f"responses: {r + 1}/{n} cells")
    gain = 1.0 / math.sqrt(energy_max) if energy_max > 0 else 1.0
    return cells, gain, offset, longest


def _index(sound: SoundField, options: WebExportOptions, cells: list[dict], gain: float,
           n_bytes: int, longest: int, tris: np.ndarray, head_z: float, glb) -> dict:
    from sonolux.version import __version__

    pos = sound.positions_m
    if len(tris):
        lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    else:
        half = (sound.grid_spacing_m or 2 * sound.radius_m) / 2
        lo = np.append(pos[:, :2].min(0) - half, 0.0)
        hi = np.append(pos[:, :2].max(0) + half, pos[:, 2].max() + 1.0)
    for k, cell in enumerate(cells):
        cell["position_m"] = [float(v) for v in pos[k]]
        cell["grid_index"] = None if sound.grid_index is None else [int(v) for v in sound.grid_index[k]]
    fs = sound.sample_rate_hz
    return {
        "format": FORMAT,
        "sonolux_version": __version__,
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "axes": "sonolux: metres, z up, azimuth 0 deg = +x, counter-clockwise seen from above; "
                "scene.glb is glTF (y up): (x, y, z) -> (x, z, -y)",
        "scene": {"name": sound.scene_name, "origin": sound.scene_origin, "file": "scene.glb",
                  "lit": glb.lit, "source": glb.source},
        "field": {"estimator": sound.settings.get("estimator"), "rays": sound.settings.get("rays"),
                  "bands_hz": [float(b) for b in sound.bands_hz],
                  **({"bands": sound.band_set.kind} if sound.band_set is not None else {})},
        "sample_rate_hz": fs,
        "response_length_samples": int(longest),
        "response_length_s": longest / fs,
        "max_length_s": options.max_length_s,
        "seed": options.seed,
        "sample_format": options.sample_format,
        "encoding": "deflate" if options.compress else "none",
        "tail_db": options.tail_db,
        "responses_file": "responses.bin",
        "responses_bytes": int(n_bytes),
        "playback_gain": gain,
        "head_height_m": head_z,
        "directions": direction_table(sound),
        "grid": {"spacing_m": sound.grid_spacing_m, "radius_m": sound.radius_m},
        "sources": [{"position_m": [float(v) for v in p], "power_w": float(w)}
                    for p, w in zip(np.atleast_2d(sound.source_positions_m), sound.source_powers_w)],
        "bounds_m": {"min": [float(v) for v in lo], "max": [float(v) for v in hi]},
        "plan_segments_m": [[round(float(v), 6) for v in s] for s in plan_segments(tris, head_z)],
        "cells": cells,
    }


def _check_target(out_dir: Path) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise SonoluxError(f"{out_dir}: exists and is not a folder")
    if out_dir.is_dir():
        foreign = [p.name for p in out_dir.iterdir() if p.name not in FILES]
        if foreign:
            raise SonoluxError(f"{out_dir}: holds files that are not a web bundle's "
                               f"({', '.join(sorted(foreign)[:5])}); choose an empty or new folder")
