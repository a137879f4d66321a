"""What `sonolux params` prints: :class:`~sonolux.analysis.params.RoomParameters` as text
tables and as JSON-ready dicts (SI units in JSON, names carry them; NaN becomes null)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sonolux.analysis.decay import COMPENSATIONS
from sonolux.analysis.params import PARAMETERS, RoomParameters

#: Digits shown per unit.
_DIGITS = {"s": 2, "dB": 1, "ms": 0, "": 2}
#: Per-direction table: the parameters shown (broadband).
DIRECTIONAL_SHOWN = ("g_db", "c80_db", "d50", "ts_s", "edt_s", "t30_s")


def _cell(value: float, unit: str, scale: float, width: int = 8) -> str:
    if value is None or not math.isfinite(value):
        return f"{'-':>{width}}"
    return f"{value * scale:{width}.{_DIGITS[unit]}f}"


def _label(name: str) -> str:
    label, unit, _, _ = PARAMETERS[name]
    return f"{label} {unit}".strip()


def _xyz(v) -> str:
    return "(" + ", ".join(f"{x:g}" for x in np.round(v, 3)) + ")"


def _header(p: RoomParameters, first: str) -> str:
    return f"  {first:<18}" + "".join(f"{c:>8}" if c != "broadband" else f"{c:>10}"
                                      for c in p.columns)


def _row(label: str, values, unit: str, scale: float) -> str:
    cells = [_cell(v, unit, scale) for v in values]
    cells[-1] = f"  {cells[-1]}"
    return f"  {label:<18}" + "".join(cells)


def _theory_rows(p: RoomParameters) -> list[str]:
    lines = []
    for label, key in (("Sabine T60 s", "sabine_t60_s"), ("Eyring T60 s", "eyring_t60_s")):
        if key in p.theory:
            vals = [np.inf if v is None else v for v in p.theory[key]] + [np.nan]
            lines.append(_row(label, vals, "s", 1.0))
    return lines


def format_grid(p: RoomParameters, title: str) -> str:
    """Mean, min and max over the receivers, per parameter and column."""
    s = p.summary()
    lines = [f"{title}: {p.receivers.size} receivers; mean, min and max over them "
             "(broadband: the mean of the bands' energies)", _header(p, "parameter")]
    for name, (_, unit, scale, _) in PARAMETERS.items():
        for stat in ("mean", "min", "max"):
            lines.append(_row(f"{_label(name) if stat == 'mean' else '':<12}{stat:>6}",
                              s[name][stat], unit, scale))
    lines += _theory_rows(p)
    if p.sti is not None:
        ok = p.sti[np.isfinite(p.sti)]
        stats = (f"mean {ok.mean():.2f}, min {ok.min():.2f}, max {ok.max():.2f}" if ok.size
                 else "undefined")
        lines.append(f"  {'STI':<18}{stats} ({p.sti_method})")
    return "\n".join(lines + _undefined_rows(p) + _outlier_rows(p) + _notes(p))


def undefined_reasons(p: RoomParameters, name: str, column: int) -> list[tuple[str, int, str]]:
    """Why ``name`` ('edt_s', ...) is undefined in ``column``: [(kind, receivers, example)]
    grouped by the reason's kind (its text before the first ': '), the most frequent first;
    [] for parameters without fits or where every fit passed."""
    key = name.removesuffix("_s")
    if key not in p.reasons:
        return []
    groups: dict[str, list[str]] = {}
    for reason in p.reasons[key][:, column]:
        if reason:
            groups.setdefault(str(reason).split(": ", 1)[0], []).append(str(reason))
    return sorted(((kind, len(v), v[0]) for kind, v in groups.items()), key=lambda x: -x[1])


def describe_undefined(reasons: list[tuple[str, int, str]]) -> str:
    """'3 receiver(s): curved decay (e.g. curved decay: ξ = 12 ‰ ...); ...'."""
    return "; ".join(f"{k} receiver(s): {kind} (e.g. {example})" for kind, k, example in reasons)


def _undefined_rows(p: RoomParameters) -> list[str]:
    lines = []
    for key in p.reasons:
        for c, column in enumerate(p.columns):
            for _kind, k, example in undefined_reasons(p, f"{key}_s", c):
                lines.append(f"  {key.upper()} {column} undefined at {k} receiver(s): {example}"
                             + (" (and similar)" if k > 1 else ""))
    return lines


def _outlier_rows(p: RoomParameters, shown: int = 10) -> list[str]:
    if not p.outliers:
        return []
    lines = [f"  receivers standing out from their neighbours beyond the Monte Carlo scatter "
             f"({len(p.outliers)}):"]
    for o in p.outliers[:shown]:
        label, unit, scale, _ = PARAMETERS[o["parameter"]]
        lines.append(f"    #{o['receiver']} at {_xyz(o['position_m'])} m: {label} {o['column']} "
                     f"{o['value'] * scale:.2f} {unit}, neighbours {o['neighbours_median'] * scale:.2f}"
                     f" (σ {o['monte_carlo_sigma'] * scale:.3f}): {o['cause']}")
    if len(p.outliers) > shown:
        lines.append(f"    ... and {len(p.outliers) - shown} more (--json lists all)")
    return lines


def format_cell(p: RoomParameters, title: str, direction_names: list[str] | None = None) -> str:
    """One receiver's parameters, and per direction (broadband) when computed."""
    k = 0
    lines = [f"{title}: receiver #{p.receivers[k]} at {_xyz(p.positions_m[k])} m",
             _header(p, "parameter")]
    for name, (_, unit, scale, _) in PARAMETERS.items():
        lines.append(_row(_label(name), p.values[name][k], unit, scale))
    lines += _theory_rows(p)
    if p.sti is not None:
        lines.append(f"  {'STI':<18}{_cell(p.sti[k], '', 1.0, 8).strip()} ({p.sti_method})")
    if p.directional is not None:
        names = direction_names or p.direction_names
        lines.append("  per direction, broadband (energy arriving from that direction only):")
        lines.append(f"    {'direction':<16}" + "".join(f"{_label(n):>9}" for n in DIRECTIONAL_SHOWN))
        for d, dname in enumerate(names):
            cells = []
            for n in DIRECTIONAL_SHOWN:
                _, unit, scale, _ = PARAMETERS[n]
                cells.append(_cell(p.directional[n][k, d, -1], unit, scale, 9))
            lines.append(f"    {dname:<16}" + "".join(cells))
    for name in ("edt", "t20", "t30"):
        why = sorted({r for r in p.reasons[name][k] if r})
        if why:
            lines.append(f"  {name.upper()} not fitted in some bands: {'; '.join(why)}")
    return "\n".join(lines + _notes(p))


def _notes(p: RoomParameters) -> list[str]:
    method = COMPENSATIONS.get(p.compensation, p.compensation)
    return [f"  note: {n}" for n in p.notes] + [f"  decay curves: {method}"]


def _json_array(a: np.ndarray) -> Any:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 0:
        return float(a) if math.isfinite(a) else None
    return [_json_array(x) for x in a]


def to_json(p: RoomParameters, *, field_path: str | None = None, scene: str = "") -> dict[str, Any]:
    """A JSON-ready dict: summary over receivers, and every receiver's values."""
    s = p.summary()
    params = {}
    for name, (label, unit, scale, jnd) in PARAMETERS.items():
        entry: dict[str, Any] = {"label": label, "display_unit": unit, "display_scale": scale,
                                 "jnd_display_unit": jnd,
                                 **{k: _json_array(s[name][k]) for k in ("mean", "min", "max")},
                                 "per_receiver": _json_array(p.values[name])}
        if p.directional is not None and name in p.directional:
            entry["per_direction"] = _json_array(p.directional[name])
        params[name] = entry
    out = {"field": field_path, "scene": scene, "bands_hz": p.bands_hz.tolist(),
           "columns": p.columns, "receivers": p.receivers.tolist(),
           "positions_m": p.positions_m.tolist(), "directions": p.direction_names,
           "channels": p.channels or None,
           "parameters": params,
           "fit_failures": {n: [[r for r in row] for row in p.reasons[n].tolist()]
                            for n in p.reasons},
           "compensation": p.compensation, "outliers": p.outliers,
           "theory": p.theory, "notes": p.notes,
           "sti": None if p.sti is None else {
               "per_receiver": _json_array(p.sti), "mean": _json_array(np.nanmean(p.sti)),
               "min": _json_array(np.nanmin(p.sti)), "max": _json_array(np.nanmax(p.sti)),
               "method": p.sti_method, **p.speech},
           "speech": p.speech}
    return out


def format_value(name: str, value: float) -> str:
    """One value of parameter ``name`` in its display unit, e.g. '0.84' (s) or '47' (ms)."""
    _, unit, scale, _ = PARAMETERS[name]
    return _cell(value, unit, scale, 0).strip()


def label_of(name: str) -> str:
    """'T30 s', 'Ts ms', 'D50': the parameter's label with its display unit."""
    return _label(name)
