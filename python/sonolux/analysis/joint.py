"""One map for both senses: light on the work plane beside the room-acoustic parameters, cell
by cell, with the cells that fail chosen criteria flagged.

The cells are the sound receivers (the grid at head height) when the field has sound, else the
work plane's cells. Each cell carries:

- the single-number room-acoustic values of ISO 3382-1:2009 Annex A.1 (the mean of the 500 Hz
  and 1 kHz octave bands; the broadband column when the bake has not both), for EDT, T30, C50,
  C80, D50, G, and STI when the parameters hold it;
- the illuminance (and daylight factor) of the work-plane cell whose centre is nearest in plan,
  when one lies within one work-plane spacing; otherwise undefined. The two grids are read
  where they are (the work plane at its height, 0.8 m by default; the receivers at theirs):
  nothing is interpolated.

A criterion is ``name >= limit`` or ``name <= limit`` on one of those values. A cell whose value
is undefined (NaN: no nearby work-plane cell, a decay fit that failed) neither passes nor fails:
it is counted as undefined and named so in the table, never as a number.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError

#: Room-acoustic values a cell carries: key in RoomParameters.values -> (label, unit).
SOUND_VALUES = {"edt_s": ("EDT", "s"), "t30_s": ("T30", "s"), "c50_db": ("C50", "dB"),
                "c80_db": ("C80", "dB"), "d50": ("D50", ""), "g_db": ("G", "dB"),
                "sti": ("STI", "")}
LIGHT_VALUES = {"illuminance_lx": ("E", "lx"), "daylight_factor_percent": ("DF", "%")}
#: ISO 3382-1 Annex A.1: single numbers are the mean over the 500 Hz and 1 kHz octaves.
SINGLE_NUMBER_BANDS_HZ = (500.0, 1000.0)
#: What ``sonolux maps`` and the report check unless told otherwise (each only where the field
#: has the value): common design targets, not a standard's verdict; a project states its own
#: (EN 12464-1:2021 for a task's illuminance, IEC 60268-16:2020 Annex G for the STI a use needs).
DEFAULT_CRITERIA = ("illuminance_lx>=300", "sti>=0.6")
_CRITERION = re.compile(r"^\s*([a-z_0-9]+)\s*(>=|<=)\s*([-+0-9.eE]+)\s*$")


@dataclass(frozen=True)
class Criterion:
    """``name op limit``, e.g. illuminance_lx >= 300."""

    name: str
    op: str
    limit: float

    @classmethod
    def parse(cls, text: str) -> Criterion:
        m = _CRITERION.match(text)
        known = sorted({*SOUND_VALUES, *LIGHT_VALUES})
        if not m or m.group(1) not in known or not math.isfinite(float(m.group(3))):
            raise SonoluxError(f"criterion {text!r} is not allowed: NAME>=LIMIT or NAME<=LIMIT "
                               f"with a finite limit, NAME one of {', '.join(known)}")
        return cls(m.group(1), m.group(2), float(m.group(3)))

    def __str__(self) -> str:
        return f"{self.name}{self.op}{self.limit:g}"

    def passes(self, values: np.ndarray) -> np.ndarray:
        """float[cell] -> int8[cell]: 1 pass, 0 fail, -1 undefined."""
        ok = values >= self.limit if self.op == ">=" else values <= self.limit
        return np.where(np.isfinite(values), ok.astype(np.int8), np.int8(-1))


@dataclass
class JointMap:
    """Per cell k: ``positions_m`` float[k, 3], ``grid_index`` int[k, 2] or None (listed
    points) with the grid's ``spacing_m``, ``values``
    {name: float[k]}; ``verdicts`` {criterion text: int8[k]} (1 pass, 0 fail, -1 undefined);
    the work plane itself (or None) for the light panel; notes."""

    scene_name: str
    positions_m: np.ndarray
    grid_index: np.ndarray | None
    spacing_m: float | None
    values: dict[str, np.ndarray]
    criteria: list[Criterion]
    verdicts: dict[str, np.ndarray]
    workplane: Any
    notes: list[str]

    @property
    def failing(self) -> np.ndarray:
        """bool[cell]: fails at least one criterion."""
        if not self.verdicts:
            return np.zeros(self.positions_m.shape[0], bool)
        return np.any([v == 0 for v in self.verdicts.values()], axis=0)

    def summary(self) -> dict[str, Any]:
        out: dict[str, Any] = {"cells": int(self.positions_m.shape[0]),
                               "failing_any": int(self.failing.sum()), "criteria": {}}
        for c in self.criteria:
            v = self.verdicts[str(c)]
            out["criteria"][str(c)] = {"pass": int((v == 1).sum()), "fail": int((v == 0).sum()),
                                       "undefined": int((v == -1).sum())}
        for name, v in self.values.items():
            ok = v[np.isfinite(v)]
            out[f"mean_{name}"] = float(ok.mean()) if ok.size else None
        out["notes"] = list(self.notes)
        return out

    def rows(self) -> list[dict[str, Any]]:
        out = []
        for k in range(self.positions_m.shape[0]):
            row: dict[str, Any] = {"x_m": float(self.positions_m[k, 0]),
                                   "y_m": float(self.positions_m[k, 1]),
                                   "z_m": float(self.positions_m[k, 2])}
            for name, v in self.values.items():
                row[name] = float(v[k]) if np.isfinite(v[k]) else None
            for text, v in self.verdicts.items():
                row[text] = {1: "pass", 0: "fail", -1: "undefined"}[int(v[k])]
            out.append(row)
        return out

    def to_csv(self) -> str:
        rows = self.rows()
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else ["x_m", "y_m", "z_m"],
                           lineterminator="\n")
        w.writeheader()
        for row in rows:  # undefined values stay empty, never a number
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()

    def to_json(self) -> str:
        return json.dumps({"scene": self.scene_name, "summary": self.summary(),
                           "cells": self.rows()}, indent=1)

    def write(self, path: str | Path) -> Path:
        """CSV or JSON by the suffix, written beside the target and renamed into place."""
        p = Path(path)
        text = self.to_json() if p.suffix.lower() == ".json" else self.to_csv()
        tmp = p.with_name(f".{p.name}.part")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(p)
        return p


def single_numbers(params: Any) -> tuple[dict[str, np.ndarray], str]:
    """{name: float[receiver]} of the Annex A.1 single numbers, and which columns they are."""
    bands = [float(b) for b in params.bands_hz]
    cols = [bands.index(b) for b in SINGLE_NUMBER_BANDS_HZ if b in bands]
    how = "mean of the 500 Hz and 1 kHz octaves" if len(cols) == 2 else "broadband"
    if len(cols) != 2:
        cols = [-1]
    out = {}
    for name in SOUND_VALUES:
        if name in params.values:
            v = np.asarray(params.values[name], float)
            out[name] = v[:, cols].mean(axis=1) if v.ndim == 2 else v
    return out, how


def _sti(sound: Any, params: Any) -> tuple[np.ndarray, str]:
    """STI at the receivers of ``params``; octaves from thirds where the field has thirds."""
    from sonolux.analysis.sti import field_sti, speech_settings_of

    sti, why = field_sti(sound, params.receivers, settings=speech_settings_of(sound))
    return (np.array([]), f"STI left out: {why} (set bands in the scene)") if why else (sti, "")


def nearest_cells(points_m: np.ndarray, workplane: Any) -> np.ndarray:
    """int[point]: the work-plane cell nearest each point in plan, -1 when none lies within
    one spacing."""
    from scipy.spatial import cKDTree

    if workplane is None or workplane.positions_m.shape[0] == 0:
        return np.full(points_m.shape[0], -1)
    # A k-d tree: a whole floor's receivers against its work plane would make a receivers ×
    # cells distance matrix of gigabytes.
    d, k = cKDTree(np.asarray(workplane.positions_m)[:, :2]).query(np.asarray(points_m)[:, :2])
    return np.where(d <= workplane.spacing_m, k, -1)


def joint_map(sound: Any = None, params: Any = None, light: Any = None,
              criteria: list[Criterion] | None = None) -> JointMap:
    """The joint map of a sound field (with its ``params``, see
    :func:`sonolux.analysis.params.room_parameters`) and/or a light field with a work plane."""
    workplane = getattr(light, "workplane", None)
    if sound is None and workplane is None:
        raise SonoluxError("nothing to map: the field has no sound and its light has no work "
                           "plane (add a [workplane] to the scene and bake the light)")
    notes: list[str] = []
    values: dict[str, np.ndarray] = {}
    if sound is not None:
        positions = np.asarray(params.positions_m, float)
        grid = None if sound.grid_index is None else np.asarray(sound.grid_index)[params.receivers]
        spacing = sound.grid_spacing_m if grid is not None else None
        band_set = getattr(sound, "band_set", None)
        if band_set is not None and band_set.kind == "third-octave":
            # Annex A.1's single numbers are octave means: octaves summed from the thirds.
            from sonolux.analysis.octaves import octave_field
            from sonolux.analysis.params import room_parameters
            from sonolux.analysis.sti import SpeechSettings

            speech = getattr(params, "speech", None) or {}
            params = room_parameters(
                octave_field(sound), params.receivers, theory=False,
                speech=SpeechSettings(**speech).validate() if speech else None)
            notes.append("sound: octaves summed from the field's third-octaves (energy adds)")
        values, how = single_numbers(params)
        notes.append(f"sound: single numbers are the {how} (ISO 3382-1 A.1) at the receivers' "
                     f"height {np.mean(positions[:, 2]):.2g} m")
        if "sti" not in values and getattr(params, "sti", None) is not None:
            values["sti"] = np.asarray(params.sti, float)
            notes.append("STI: " + params.sti_method)
        elif "sti" not in values:
            sti, why = _sti(sound, params)
            if why:
                notes.append(why)
            else:
                values["sti"] = sti
                from sonolux.analysis.sti import describe, speech_settings_of

                notes.append("STI: " + describe(speech_settings_of(sound)))
        if workplane is not None:
            k = nearest_cells(positions, workplane)
            for name in LIGHT_VALUES:
                src = getattr(workplane, name, None)
                if src is not None:
                    values[name] = np.where(k >= 0, np.asarray(src, float)[np.maximum(k, 0)],
                                            np.nan)
            notes.append(f"light: the nearest work-plane cell at {workplane.height_m:g} m "
                         f"within {workplane.spacing_m:g} m ({int((k < 0).sum())} receivers "
                         "have none)")
        elif light is not None:
            notes.append("light: the scene has no work plane, so no illuminance per cell")
    else:
        positions = np.asarray(workplane.positions_m, float)
        grid = np.asarray(workplane.grid_index)
        spacing = float(workplane.spacing_m)
        for name in LIGHT_VALUES:
            src = getattr(workplane, name, None)
            if src is not None:
                values[name] = np.asarray(src, float)
    chosen: list[Criterion] = []
    for c in criteria or []:
        if c.name in values:
            chosen.append(c)
        else:
            notes.append(f"criterion {c} left out: this field has no {c.name}")
    verdicts = {str(c): c.passes(values[c.name]) for c in chosen}
    name = getattr(sound, "scene_name", None) or getattr(light, "scene_name", "")
    return JointMap(name, positions, grid, spacing, values, chosen, verdicts, workplane, notes)
