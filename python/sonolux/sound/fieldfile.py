"""The ``/sound`` group of a field file, and the sound-only ways to write and read one (the
file itself, with ``/light`` beside ``/sound``: :mod:`sonolux.fieldfile`; it is written to a
temporary file and renamed, so that an interrupted bake never leaves a broken file behind).

Schema ``sonolux-field/1`` (all lengths in metres, times in seconds, energies in J/m²):

    /                      attrs: schema, sonolux_version, created_utc, scene_name, scene_origin
    /sound                 attrs: settings (JSON: rays, estimator, seed, sample_rate_hz, early_bins,
                                  late_bin_s, azimuth_bands, elevation_bands, max_time_s,
                                  speed_of_sound_m_s, air, volume_m3, area_m2, ...),
                                  stats (JSON: rays, segments, surface_hits, escaped_rays,
                                  energy balance per band, mean free path, seconds, ...),
                                  radius_m, grid_spacing_m (NaN for listed points), quantum
    /sound/energy          float32[receiver, direction, band, time], gzip, one chunk a receiver
    /sound/bin_start_s     float64[time];  /sound/bin_width_s  float64[time]
    /sound/bands_hz        float64[band]   octave-band centres
    /sound/directions      str[direction]  names in index order (see sonolux.sound.field)
    /sound/receivers_m     float64[receiver, 3];  /sound/grid_index  int64[receiver, 2] (grids)
    /sound/sources_m       float64[source, 3];    /sound/source_powers_w  float64[source]
    /sound/counts          uint64[time, receiver, direction, band] (only for ray-range bakes:
                           the exact fixed-point sums, energy = counts × quantum)

``/light`` may stand beside ``/sound`` (:mod:`sonolux.light.fieldfile`), and a file baked
with ``--no-sound`` has no ``/sound``; readers ignore groups they do not know.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.fieldfile import SCHEMA, json_default
from sonolux.sound.field import SoundField

__all__ = ["SCHEMA", "open_field", "read_group", "save", "write_group"]
_json_default = json_default  # the name earlier versions exported


def write_group(f: Any, field: SoundField, json_default: Any = json_default) -> None:
    """Writes ``field`` into a new ``/sound`` group of the open h5py file ``f``."""
    import h5py

    g = f.create_group("sound")
    g.attrs["settings"] = json.dumps(field.settings, default=json_default)
    g.attrs["stats"] = json.dumps(field.stats, default=json_default)
    g.attrs["radius_m"] = field.radius_m
    g.attrs["grid_spacing_m"] = field.grid_spacing_m if field.grid_spacing_m else np.nan
    g.attrs["quantum"] = field.quantum
    e = field.energy
    g.create_dataset("energy", data=e, compression="gzip", compression_opts=4,
                     shuffle=True, chunks=(1, *e.shape[1:]) if e.shape[0] else None)
    g["bin_start_s"] = field.bin_start_s
    g["bin_width_s"] = field.bin_width_s
    g["bands_hz"] = field.bands_hz
    g["directions"] = np.array(field.direction_names, dtype=h5py.string_dtype())
    g["receivers_m"] = field.positions_m
    if field.grid_index is not None:
        g["grid_index"] = np.asarray(field.grid_index, np.int64)
    g["sources_m"] = field.source_positions_m
    g["source_powers_w"] = field.source_powers_w
    if field.counts is not None:
        g.create_dataset("counts", data=field.counts, compression="gzip", shuffle=True)


def save(field: SoundField, path: str | Path) -> Path:
    """Writes the field to ``path`` (a temporary file beside it, then renamed)."""
    from sonolux.fieldfile import save_fields

    return save_fields(path, sound=field)


def read_group(f: Any, path: str) -> SoundField:
    """The sound field in the open h5py file ``f`` (a clear error when /sound is missing)."""
    if "sound" not in f:
        raise SonoluxError(f"{path}: the file holds no sound field (/sound is missing; it was "
                           "baked without sound: run sonolux bake with --sound)")
    g = f["sound"]
    try:
        spacing = float(g.attrs["grid_spacing_m"])
        return SoundField(
            energy=g["energy"][...], bin_start_s=g["bin_start_s"][...],
            bin_width_s=g["bin_width_s"][...], bands_hz=g["bands_hz"][...],
            positions_m=g["receivers_m"][...], radius_m=float(g.attrs["radius_m"]),
            grid_index=g["grid_index"][...] if "grid_index" in g else None,
            grid_spacing_m=None if np.isnan(spacing) else spacing,
            source_positions_m=g["sources_m"][...], source_powers_w=g["source_powers_w"][...],
            settings=json.loads(g.attrs["settings"]), stats=json.loads(g.attrs["stats"]),
            scene_name=str(f.attrs.get("scene_name", "")),
            scene_origin=str(f.attrs.get("scene_origin", "")),
            counts=g["counts"][...] if "counts" in g else None,
            quantum=float(g.attrs["quantum"]), path=str(path))
    except KeyError as exc:
        raise SonoluxError(f"{path}: the sound field is incomplete ({exc.args[0]} is "
                           "missing)") from None


def open_field(path: str | Path) -> SoundField:
    """Reads a sound field file; a missing, unreadable or foreign file is a clear error."""
    from sonolux.fieldfile import open_field as open_shared

    return open_shared(path)
