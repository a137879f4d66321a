"""Illuminance and daylight factor on the work plane: what the light tracer's virtual plane
counted, per cell, in lux; with the uniformity lighting standards state (U₀ = E_min / E_mean,
EN 12464-1:2021 §5.3.4), and CSV / JSON export per cell.

A cell's illuminance is K · Y · (flux crossing it downwards) / cell area (see
:mod:`sonolux.light.photometry`), the reading of an upward-facing horizontal illuminance meter
averaged over the cell. Its relative noise is about 1 / √hits. The daylight factor is the
illuminance from the sky alone over the unobstructed horizontal illuminance of that sky, in
per cent (CIE; BS 8206-2); it is given when the scene has a ``[daylight]`` overcast sky and no
other light.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.light.photometry import photometric


@dataclass(frozen=True, eq=False)
class WorkplaneResult:
    """Per cell k: ``positions_m`` float64[k, 3] (centres), ``grid_index`` int64[k, 2],
    ``illuminance_lx`` float64[k], ``hits`` uint64[k]; ``daylight_factor_percent`` float64[k]
    or None."""

    height_m: float
    spacing_m: float
    positions_m: np.ndarray
    grid_index: np.ndarray
    illuminance_lx: np.ndarray
    hits: np.ndarray
    daylight_factor_percent: np.ndarray | None = None

    @property
    def mean_lx(self) -> float:
        return float(self.illuminance_lx.mean()) if self.illuminance_lx.size else float("nan")

    @property
    def min_lx(self) -> float:
        return float(self.illuminance_lx.min()) if self.illuminance_lx.size else float("nan")

    @property
    def uniformity(self) -> float:
        """U₀ = E_min / E_mean (NaN when nothing is lit)."""
        mean = self.mean_lx
        return self.min_lx / mean if mean > 0 else float("nan")

    def summary(self) -> dict[str, Any]:
        out = {"height_m": self.height_m, "spacing_m": self.spacing_m,
               "cells": int(self.illuminance_lx.size), "mean_lx": self.mean_lx,
               "min_lx": self.min_lx,
               "max_lx": float(self.illuminance_lx.max()) if self.illuminance_lx.size else None,
               "uniformity_min_over_mean": self.uniformity}
        if self.daylight_factor_percent is not None and self.daylight_factor_percent.size:
            df = self.daylight_factor_percent
            out.update(mean_daylight_factor_percent=float(df.mean()),
                       min_daylight_factor_percent=float(df.min()))
        return out

    def rows(self) -> list[dict[str, Any]]:
        """One dict a cell: i, j, x_m, y_m, z_m, illuminance_lx, [daylight_factor_percent],
        hits, relative_noise."""
        out = []
        for k in range(self.illuminance_lx.size):
            row: dict[str, Any] = {
                "i": int(self.grid_index[k, 0]), "j": int(self.grid_index[k, 1]),
                "x_m": float(self.positions_m[k, 0]), "y_m": float(self.positions_m[k, 1]),
                "z_m": float(self.positions_m[k, 2]),
                "illuminance_lx": float(self.illuminance_lx[k])}
            if self.daylight_factor_percent is not None:
                row["daylight_factor_percent"] = float(self.daylight_factor_percent[k])
            hits = int(self.hits[k])
            row.update(hits=hits, relative_noise=1 / np.sqrt(hits) if hits else None)
            out.append(row)
        return out

    def to_csv(self) -> str:
        rows = self.rows()
        buf = io.StringIO()
        fields = list(rows[0]) if rows else ["i", "j", "x_m", "y_m", "z_m", "illuminance_lx"]
        w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        return buf.getvalue()

    def to_json(self) -> str:
        return json.dumps({"summary": self.summary(), "cells": self.rows()}, indent=1)

    def write(self, path: str | Path) -> Path:
        """Writes CSV or JSON (by the suffix) beside the target, then renames it into place."""
        p = Path(path)
        text = self.to_json() if p.suffix.lower() == ".json" else self.to_csv()
        tmp = p.with_name(p.name + ".part")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(p)
        return p


def plane_request(workplane: Any) -> dict[str, Any] | None:
    """The core's work plane (a dict: height_m, origin_m, spacing_m, lo, count) covering the
    scene's kept cells, or None when there are none."""
    index = workplane.grid_index
    if index.shape[0] == 0:
        return None
    lo = index.min(axis=0)
    count = index.max(axis=0) - lo + 1
    return {"height_m": float(workplane.height_m), "origin_m": [float(v) for v in workplane.origin_m],
            "spacing_m": float(workplane.spacing_m), "lo": [int(lo[0]), int(lo[1])],
            "count": [int(count[0]), int(count[1])]}


def workplane_result(workplane: Any, request: dict[str, Any], plane_flux_w: np.ndarray,
                     plane_hits: np.ndarray, efficacy_lm_per_w: float,
                     daylight_horizontal_lx: float | None) -> WorkplaneResult:
    """The kept cells' illuminance from the core's flux per rectangle cell (rows along +x)."""
    lo, count = request["lo"], request["count"]
    flat = (workplane.grid_index[:, 1] - lo[1]) * count[0] + (workplane.grid_index[:, 0] - lo[0])
    area = request["spacing_m"] ** 2
    lux = photometric(plane_flux_w[flat] / area, efficacy_lm_per_w)
    df = 100.0 * lux / daylight_horizontal_lx if daylight_horizontal_lx else None
    return WorkplaneResult(float(workplane.height_m), float(workplane.spacing_m),
                           workplane.positions_m, workplane.grid_index, lux,
                           np.asarray(plane_hits)[flat], df)
