"""A dry signal heard at a point or along a walk, written as a WAV file, in one call
(``sonolux auralize`` and the report both use it).

The output is in the field's pressure units (docs/auralize.md). By default it is never written
above full scale: when the peak exceeds 0 dBFS the whole signal is scaled down to
:data:`NORMALIZE_PEAK_DBFS` and the result says so; ``normalize=True`` always scales the peak
there, ``allow_over_full_scale=True`` keeps the float samples as they are.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.audio import write_wav
from sonolux.auralize.offline import AuralizeSettings, auralize, load_dry
from sonolux.errors import SonoluxError
from sonolux.sound.field import SoundField

NORMALIZE_PEAK_DBFS = -1.0
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
    """gain_db: a fixed gain; normalize: scale the peak to NORMALIZE_PEAK_DBFS;
    allow_over_full_scale: keep float samples above ±1 instead of scaling them down;
    subtype: FLOAT (32-bit float), PCM_24 or PCM_16."""

    gain_db: float = 0.0
    normalize: bool = False
    allow_over_full_scale: bool = False
    subtype: str = "FLOAT"

    def validate(self) -> Output:
        if self.subtype not in SUBTYPES:
            raise SonoluxError(f"subtype {self.subtype!r} is not allowed: {', '.join(SUBTYPES)}")
        if not np.isfinite(self.gain_db) or abs(self.gain_db) > 200:
            raise SonoluxError(f"gain_db = {self.gain_db!r} is not allowed: a gain from -200 to "
                               "200 dB")
        return self


def auralize_to_file(field: SoundField, dry: str, output: str | Path, listening: Listening,
                     settings: AuralizeSettings | None = None,
                     out: Output | None = None, channel: int | None = None) -> dict[str, Any]:
    """Auralizes the dry signal (a sound file or ``builtin:NAME``) and writes ``output``:
    a dict with what (the dry signal), where (the listener), the renderer's info, the peak in
    dBFS and the scaling applied."""
    listening = listening.validate()
    settings = (settings or AuralizeSettings()).validate()
    out = (out or Output()).validate()
    fs = field.sample_rate_hz
    notes: list[str] = []
    if listening.path_file is None:
        assert listening.at_m is not None
        x, what = load_dry(dry, fs, channel=channel)
        y, info = auralize(field, x, listening.at_m, listening.heading_deg, settings)
        r = info["receivers"][0]
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
        y, info = auralize_walk(field, x, path, settings, walk)
        png = Path(listening.png) if listening.png else Path(output).with_suffix(".png")
        plot_walk(field, path, info, png)
        where = (f"along {listening.path_file} ({path.duration_s:.2f} s, "
                 f"{len(info['events'])} cells: {' '.join(f'#{r}' for r in info['receivers'])}; "
                 f"plan view -> {png})")
    y = y * np.float32(10 ** (out.gain_db / 20))
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    scaled = ""
    target = 10 ** (NORMALIZE_PEAK_DBFS / 20)
    if peak > 0 and (out.normalize or (peak > 1.0 and not out.allow_over_full_scale)):
        y = y * np.float32(target / peak)
        scaled = ("normalized" if out.normalize else
                  f"scaled down by {20 * np.log10(peak / target):.1f} dB to stay below full scale")
        peak = target
    if out.subtype != "FLOAT" and peak > 1.0:
        raise SonoluxError(f"the peak is {20 * np.log10(peak):+.1f} dBFS: {out.subtype} would "
                           "clip; drop allow_over_full_scale or keep the float format")
    write_wav(output, y, fs, subtype=out.subtype)
    if peak > 1.0:
        notes.append("samples exceed ±1 (kept in the float file, as asked); players may clip")
    return {"what": what, "where": where, "info": info, "channels": int(y.shape[1]),
            "seconds": y.shape[0] / fs, "sample_rate_hz": fs,
            "peak_dbfs": 20 * np.log10(max(peak, 1e-30)), "scaled": scaled, "notes": notes,
            "output": str(output)}
