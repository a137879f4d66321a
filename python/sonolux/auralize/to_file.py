"""A dry signal heard at a point or along a walk, written as a WAV file, in one call
(``sonolux auralize`` and the report both use it).

The level follows :func:`sonolux.audio.set_level`: by default the peak is normalised to
:data:`NORMALIZE_PEAK_DBFS` (−1 dBFS) and the gain applied is reported; ``calibrated=True`` (or
a ``gain_db``) keeps the field's pressure units (docs/auralize.md) times the gain, with a
warning where that goes above full scale.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.audio import NORMALIZE_PEAK_DBFS, set_level, write_wav
from sonolux.auralize.offline import AuralizeSettings, auralize, load_dry
from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_GAIN_DB
from sonolux.sound.field import SoundField
from sonolux.sound.info import listener_warnings

__all__ = ["NORMALIZE_PEAK_DBFS", "SUBTYPES", "Listening", "Output", "auralize_to_file"]

SUBTYPES = ("FLOAT", "PCM_24", "PCM_16")


@dataclass(frozen=True)
class Listening:
    """Where the listener is: ``at_m`` (x, y) facing ``heading_deg`` (0 = +x, counter-clockwise),
    or a walk read from ``path_file`` (CSV time,x,y,heading or JSON) at ``speed_m_s`` for
    points without times; ``outside``: "error" or "clamp" when the walk leaves the field;
    ``loop`` repeats the dry signal to the end of the walk; ``png``: the walk's plan view
    (default: the output's name with .png)."""

    at_m: tuple[float, float] | None = None
    heading_deg: float = 0.0
    path_file: str | None = None
    speed_m_s: float = 1.2
    outside: str = "error"
    loop: bool = False
    png: str | None = None

    def validate(self) -> Listening:
        if (self.at_m is None) == (self.path_file is None):
            raise SonoluxError("give either a position (at_m / --at) or a walk (path_file / "
                               "--path), not both and not neither")
        return self


@dataclass(frozen=True)
class Output:
    """The level (:func:`sonolux.audio.set_level`): normalised to NORMALIZE_PEAK_DBFS by
    default; ``calibrated`` or a ``gain_db`` keeps the field's units times the gain (a peak above
    full scale is kept in float files with a warning, and refused for PCM, which would clip).
    ``allow_over_full_scale`` is the old name of ``calibrated``; ``normalize`` the default.
    subtype: FLOAT (32-bit float), PCM_24 or PCM_16."""

    gain_db: float | None = None
    normalize: bool = False
    allow_over_full_scale: bool = False
    subtype: str = "FLOAT"
    calibrated: bool = False

    @property
    def is_calibrated(self) -> bool:
        return not self.normalize and (self.calibrated or self.allow_over_full_scale
                                       or self.gain_db is not None)

    def validate(self) -> Output:
        if self.subtype not in SUBTYPES:
            raise SonoluxError(f"subtype {self.subtype!r} is not allowed: {', '.join(SUBTYPES)}")
        check_number("gain_db", self.gain_db, -MAX_GAIN_DB, MAX_GAIN_DB, none_ok=True, unit="dB")
        return self


def auralize_to_file(field: SoundField, dry: str | Mapping[str, str], output: str | Path,
                     listening: Listening, settings: AuralizeSettings | None = None,
                     out: Output | None = None, channel: int | None = None) -> dict[str, Any]:
    """Auralizes the dry signal (a sound file or ``builtin:NAME``) and writes ``output``:
    a dict with what (the dry signal), where (the listener), the renderer's info, the peak in
    dBFS and the scaling applied. ``dry`` may also map source names to dry signals: each
    source of the field plays its own (through its own field, :meth:`SoundField.for_source`),
    and what the listener hears is their sum."""
    listening = listening.validate()
    settings = (settings or AuralizeSettings()).validate()
    out = (out or Output()).validate()
    fs = field.sample_rate_hz
    if isinstance(dry, Mapping):
        if not dry:
            raise SonoluxError("no dry signal given: one per source, or one for all")
        parts = [_render(field.for_source(name), d, output, listening, settings, channel)
                 for name, d in dry.items()]
        n = max(p[0].shape[0] for p in parts)
        y = np.zeros((n, parts[0][0].shape[1]))
        for p in parts:
            y[: p[0].shape[0]] += p[0]
        _, info, _, where, notes = parts[0]
        what = "; ".join(f"{name}: {p[2]}" for name, p in zip(dry, parts))
        notes = [note for p in parts for note in p[4]]
        notes = list(dict.fromkeys(notes))
    else:
        y, info, what, where, notes = _render(field, dry, output, listening, settings, channel)
    return _write(y, info, what, where, notes, output, out, fs)


def _render(field: SoundField, dry: str, output: str | Path, listening: Listening,
            settings: AuralizeSettings,
            channel: int | None) -> tuple[np.ndarray, dict[str, Any], str, str, list[str]]:
    """(channels float[sample, channel], the renderer's info, what, where, notes) of one dry
    signal heard through ``field``."""
    fs = field.sample_rate_hz
    notes: list[str] = []
    if listening.path_file is None:
        assert listening.at_m is not None
        x, what = load_dry(dry, fs, channel=channel)
        y, info = auralize(field, x, listening.at_m, listening.heading_deg, settings)
        r = info["receivers"][0]
        notes.extend(listener_warnings(field, r))
        where = (f"at ({listening.at_m[0]:g}, {listening.at_m[1]:g}) m (cell #{r}, receiver at "
                 f"{', '.join(f'{v:g}' for v in field.positions_m[r][:2])}), facing "
                 f"{listening.heading_deg:g}°")
    else:
        from sonolux.auralize.walk import WalkSettings, auralize_walk, load_path, plot_walk

        walk = WalkSettings(speed_m_s=listening.speed_m_s, outside=listening.outside).validate()
        path = load_path(listening.path_file, walk.speed_m_s)
        x, what = load_dry(dry, fs, duration_s=path.duration_s, channel=channel)
        if listening.loop and x.size < path.duration_s * fs:
            x = np.resize(x, int(np.ceil(path.duration_s * fs)))
            what += ", looped"
        elif x.size < path.duration_s * fs:
            notes.append(f"the dry signal ({x.size / fs:.2f} s) is shorter than the walk "
                         f"({path.duration_s:.2f} s); --loop repeats it")
        try:
            y, info = auralize_walk(field, x, path, settings, walk)
        except SonoluxError as exc:  # name the path file in what the walk found wrong
            if str(listening.path_file) in str(exc):
                raise
            raise SonoluxError(f"{listening.path_file}: {exc}") from None
        png = Path(listening.png) if listening.png else Path(output).with_suffix(".png")
        plot_walk(field, path, info, png)
        where = (f"along {listening.path_file} ({path.duration_s:.2f} s, "
                 f"{len(info['events'])} cells: {' '.join(f'#{r}' for r in info['receivers'])}; "
                 f"plan view -> {png})")
    return y, info, what, where, notes


def _write(y: np.ndarray, info: dict[str, Any], what: str, where: str, notes: list[str],
           output: str | Path, out: Output, fs: int) -> dict[str, Any]:
    """Sets the level of ``y``, writes it, and says what was done."""
    y, gain_db, level_notes = set_level(y, out.gain_db, out.is_calibrated)
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    scaled = (f"calibrated, gain {gain_db:+.1f} dB" if out.is_calibrated
              else f"normalised to {NORMALIZE_PEAK_DBFS:g} dBFS: gain {gain_db:+.1f} dB")
    if out.subtype != "FLOAT" and peak > 1.0:
        raise SonoluxError(f"the peak is {20 * np.log10(peak):+.1f} dBFS: {out.subtype} would "
                           "clip; lower --gain-db, leave out --calibrated, or keep FLOAT")
    write_wav(output, y, fs, subtype=out.subtype, channel_names=info["channels"])
    notes.extend(level_notes)
    return {"what": what, "where": where, "info": info, "channels": int(y.shape[1]),
            "seconds": y.shape[0] / fs, "sample_rate_hz": fs,
            "peak_dbfs": 20 * np.log10(max(peak, 1e-30)), "scaled": scaled, "notes": notes,
            "output": str(output)}
