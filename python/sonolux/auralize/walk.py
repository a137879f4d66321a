"""Walk-throughs: a path and a dry signal make one output file, and a plan-view picture.

A path is a list of keys (time s, x m, y m, heading degrees), from

- CSV with a header naming the columns ``time, x, y, heading`` (``t`` for time; time and heading
  may be left out), one key a line; or
- JSON: a list of objects ``{"time": .., "x": .., "y": .., "heading": ..}``, or an object
  ``{"points": [...]}`` of the same, or ``{"waypoints": [[x, y], ...], "speed_m_s": 1.2}``.

Without times the listener walks at ``speed_m_s`` (1.2 m/s unless given) from key to key;
without headings they face where they walk. Positions are interpolated linearly between keys
(so a path through the grid never cuts a corner outside it); headings along the shortest turn,
then smoothed by a moving average over ``heading_smoothing_s`` so the head turns smoothly.
Before the first key and after the last the listener stands still.

Cells. The listener hears the nearest receiver's cell. A new cell is taken when it is nearer
than the current one by ``hysteresis_m`` (no flutter along a boundary) and not before the last
cross-fade has ended; the fade is centred on the crossing. A path that leaves the field (farther
than half a cell's diagonal from every receiver) is an error naming the time and position,
unless ``outside="clamp"``: then the nearest cell is used.
"""

from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sonolux.auralize.offline import AuralizeSettings, response_samples, run_blocks
from sonolux.errors import SonoluxError
from sonolux.outputs import write_atomically

CONTROL_HZ = 1000.0  # rate at which the cell is looked up along the path


@dataclass
class WalkPath:
    """times_s float[key] increasing, xy_m float[key, 2], heading_deg float[key] or None."""

    times_s: np.ndarray
    xy_m: np.ndarray
    heading_deg: np.ndarray | None
    source: str = "<path>"

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])


@dataclass
class WalkSettings:
    speed_m_s: float = 1.2
    heading_smoothing_s: float = 0.25
    hysteresis_m: float = 0.05
    outside: str = "error"

    def validate(self) -> WalkSettings:
        if not 0.05 <= self.speed_m_s <= 50:
            raise SonoluxError(f"speed_m_s = {self.speed_m_s} is not allowed: 0.05 to 50 m/s")
        if not 0 <= self.heading_smoothing_s <= 5:
            raise SonoluxError(f"heading_smoothing_s = {self.heading_smoothing_s} is not "
                               "allowed: 0 to 5 s")
        if not 0 <= self.hysteresis_m <= 1:
            raise SonoluxError(f"hysteresis_m = {self.hysteresis_m} is not allowed: 0 to 1 m")
        if self.outside not in ("error", "clamp"):
            raise SonoluxError(f"outside = {self.outside!r} is not allowed: 'error' or 'clamp'")
        return self


# --- reading paths ---------------------------------------------------------------------------
def load_path(file: str | Path, speed_m_s: float = 1.2) -> WalkPath:
    path = Path(file)
    if not path.exists():
        raise SonoluxError(f"{path}: no such path file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SonoluxError(f"{path}: not a UTF-8 text file (byte {exc.start}); a path is CSV "
                           "(time,x,y,heading) or JSON") from None
    if path.suffix.lower() == ".json" or text.lstrip().startswith(("[", "{")):
        return _from_json(text, str(path), speed_m_s)
    return _from_csv(text, str(path), speed_m_s)


def _number(value, where: str, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SonoluxError(f"{where}: {name} = {value!r} is not a number") from None
    if not np.isfinite(v):
        raise SonoluxError(f"{where}: {name} = {value!r} is not a finite number")
    return v


def _from_csv(text: str, src: str, speed: float) -> WalkPath:
    rows = [r for r in csv.reader(text.splitlines()) if r and not r[0].lstrip().startswith("#")]
    if not rows:
        raise SonoluxError(f"{src}: the path is empty")
    header = [h.strip().lower() for h in rows[0]]
    header = ["time" if h in ("t", "time_s") else h for h in header]
    for need in ("x", "y"):
        if need not in header:
            raise SonoluxError(f"{src}:1: the header {rows[0]} has no column {need!r} "
                               "(expected time, x, y, heading)")
    keys = []
    for line, row in enumerate(rows[1:], start=2):
        rec = dict(zip(header, row))
        missing = [k for k in ("x", "y") if rec.get(k, "").strip() == ""]
        if missing:
            raise SonoluxError(f"{src}:{line}: the row has no {missing[0]!r} "
                               f"({len(row)} values for the {len(header)} columns)")
        keys.append({k: _number(rec.get(k), f"{src}:{line}", k) for k in header
                     if k in ("time", "x", "y", "heading") and rec.get(k, "").strip() != ""})
    return _keys(keys, src, speed)


def _from_json(text: str, src: str, speed: float) -> WalkPath:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SonoluxError(f"{src}:{exc.lineno}: not valid JSON ({exc.msg})") from None
    if isinstance(doc, dict) and "waypoints" in doc:
        speed = _number(doc.get("speed_m_s", speed), src, "speed_m_s")
        pts = doc["waypoints"]
        if not isinstance(pts, list) or not all(isinstance(p, list) and len(p) == 2
                                                for p in pts):
            raise SonoluxError(f"{src}: waypoints must be a list of [x, y] pairs")
        keys = [{"x": _number(p[0], f"{src}: waypoints[{i}]", "x"),
                 "y": _number(p[1], f"{src}: waypoints[{i}]", "y")} for i, p in enumerate(pts)]
        return _keys(keys, src, speed)
    pts = doc.get("points") if isinstance(doc, dict) else doc
    if not isinstance(pts, list) or not all(isinstance(p, dict) for p in pts):
        raise SonoluxError(f"{src}: expected a list of points {{time, x, y, heading}}, "
                           "{\"points\": [...]} or {\"waypoints\": [[x, y], ...]}")
    keys = []
    for i, p in enumerate(pts):
        p = {("time" if k == "t" else k): v for k, v in p.items()}
        for need in ("x", "y"):
            if need not in p:
                raise SonoluxError(f"{src}: points[{i}] has no {need!r}")
        keys.append({k: _number(p[k], f"{src}: points[{i}]", k)
                     for k in ("time", "x", "y", "heading") if k in p})
    return _keys(keys, src, speed)


def _keys(keys: list[dict], src: str, speed: float) -> WalkPath:
    if len(keys) < 1:
        raise SonoluxError(f"{src}: the path has no points")
    xy = np.array([[k["x"], k["y"]] for k in keys], float)
    timed = ["time" in k for k in keys]
    if any(timed) and not all(timed):
        raise SonoluxError(f"{src}: give a time for every point or for none")
    if all(timed):
        t = np.array([k["time"] for k in keys], float)
        if np.any(np.diff(t) <= 0) or t[0] < 0:
            raise SonoluxError(f"{src}: times must start at ≥ 0 s and increase from point to point")
    else:
        step = np.linalg.norm(np.diff(xy, axis=0), axis=1)
        t = np.concatenate([[0.0], np.cumsum(step) / speed])
        if np.any(np.diff(t) <= 0):
            raise SonoluxError(f"{src}: two waypoints in a row are the same point")
    headed = ["heading" in k for k in keys]
    if any(headed) and not all(headed):
        raise SonoluxError(f"{src}: give a heading for every point or for none")
    heading = np.array([k["heading"] for k in keys], float) if all(headed) else None
    return WalkPath(t, xy, heading, src)


# --- along the path --------------------------------------------------------------------------
def sample_path(path: WalkPath, rate_hz: float, n: int, smoothing_s: float = 0.25):
    """(xy float[n, 2], heading_deg float[n] unwrapped) at ``rate_hz`` from t = 0."""
    t = np.arange(n) / rate_hz
    xy = np.column_stack([np.interp(t, path.times_s, path.xy_m[:, i]) for i in range(2)])
    if path.heading_deg is not None:
        heading = np.interp(t, path.times_s, np.degrees(np.unwrap(np.radians(path.heading_deg))))
    else:
        # Face where the walk goes: the direction of each leg, held while standing.
        legs = np.diff(path.xy_m, axis=0)
        leg_heading = np.degrees(np.unwrap(np.arctan2(legs[:, 1], legs[:, 0]))) \
            if legs.size else np.zeros(1)
        k = np.clip(np.searchsorted(path.times_s, t, side="right") - 1, 0, leg_heading.size - 1)
        heading = leg_heading[k]
    m = int(round(smoothing_s * rate_hz))
    if m > 1:
        for _ in range(2):  # twice: a triangular window, so the turn rate is continuous too
            heading = _moving_average(heading, m)
    return xy, heading


def _moving_average(x: np.ndarray, m: int) -> np.ndarray:
    """Centred moving average over m samples, the ends held (O(n), by cumulative sums)."""
    half = m // 2
    padded = np.concatenate([np.full(half + 1, x[0]), x, np.full(m - half, x[-1])])
    c = np.cumsum(padded)
    return (c[m:m + x.size] - c[:x.size]) / m


def cell_schedule(field, xy: np.ndarray, rate_hz: float, settings: WalkSettings,
                  min_gap_s: float) -> list[tuple[float, int]]:
    """[(time s, receiver)]: the cell at t = 0, then each change of cell along the path."""
    from scipy.spatial import cKDTree

    pos = field.positions_m[:, :2]
    dist, nearest = cKDTree(pos).query(xy)
    reach = (field.grid_spacing_m or 2 * field.radius_m) * (np.sqrt(2) / 2 + 1e-9)
    out = np.flatnonzero(dist > reach)
    if out.size and settings.outside == "error":
        i = out[0]
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        raise SonoluxError(f"the path leaves the sound field at t = {i / rate_hz:.2f} s, "
                           f"({xy[i, 0]:.2f}, {xy[i, 1]:.2f}) m: the receivers span x "
                           f"{lo[0]:g}..{hi[0]:g}, y {lo[1]:g}..{hi[1]:g} m (cells reach "
                           f"{reach:.2f} m beyond); use outside='clamp' (--outside clamp) to "
                           "stay in the nearest cell")
    current = int(nearest[0])
    events = [(0.0, current)]
    last = -np.inf
    # Only the samples where another cell is nearest can start a change; they are found again
    # after each change (a few dozen vector passes instead of a Python step per sample).
    candidates = np.flatnonzero(nearest != current)
    k = 0
    while k < candidates.size:
        i = int(candidates[k])
        k += 1
        n = int(nearest[i])
        if i / rate_hz - last < min_gap_s:
            continue
        x, y = xy[i]
        d_new = np.hypot(x - pos[n, 0], y - pos[n, 1])
        if d_new + settings.hysteresis_m < np.hypot(x - pos[current, 0], y - pos[current, 1]):
            current, last = n, i / rate_hz
            events.append((last, n))
            candidates = i + 1 + np.flatnonzero(nearest[i + 1:] != current)
            k = 0
    return events


def auralize_walk(field, dry: np.ndarray, path: WalkPath,
                  settings: AuralizeSettings | None = None,
                  walk: WalkSettings | None = None, renderer=None) -> tuple[np.ndarray, dict]:
    """The dry signal float[samples] heard along the path: float32[samples, channel] (the
    longer of the walk and the signal, plus the tail) and a dict of what was done, with
    ``xy`` and ``heading_deg`` at the control rate and the cell ``events``. ``renderer``: a
    fresh :class:`~sonolux.auralize.stream.StreamRenderer` to use (e.g. with cells prepared
    ahead); by default one is made from the settings."""
    s = (settings or AuralizeSettings()).validate()
    w = (walk or WalkSettings()).validate()
    t0 = time.perf_counter()
    fs = field.sample_rate_hz
    n_walk = int(np.ceil(path.duration_s * fs)) + 1
    tail = response_samples(field) if s.tail_s is None else int(s.tail_s * fs)
    n_out = max(n_walk, np.asarray(dry).size) + tail
    # The cells, looked up at the control rate; the heading for every sample.
    n_ctl = int(np.ceil(n_out / fs * CONTROL_HZ)) + 2
    xy_ctl, heading_ctl = sample_path(path, CONTROL_HZ, n_ctl, w.heading_smoothing_s)
    events = cell_schedule(field, xy_ctl, CONTROL_HZ, w, min_gap_s=s.fade_s)
    heading = np.interp(np.arange(n_out) / fs, np.arange(n_ctl) / CONTROL_HZ, heading_ctl)
    renderer = renderer or s.renderer(field)
    renderer.set_cell(events[0][1])
    half = renderer.fade // 2
    changes = [(max(0, int(round(t * fs)) - half), r) for t, r in events[1:]]
    out = run_blocks(renderer, np.asarray(dry, float), n_out, heading, changes)
    seconds = time.perf_counter() - t0
    return out, {"receivers": [r for _, r in events], "events": events,
                 "channels": renderer.channel_names, "layout": renderer.spatializer.name,
                 "latency_samples": renderer.latency_samples, "seconds": seconds,
                 "prepare_seconds": renderer.cells.prepare_s, "duration_s": n_out / fs,
                 "xy": xy_ctl, "heading_deg": heading_ctl}


def plot_walk(field, path: WalkPath, info: dict, png: str | Path) -> Path:
    """A plan view of the path over the receiver grid: cells visited shaded, headings as
    arrows every second, sources as stars. Written to a temporary file, then renamed."""

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    pos = field.positions_m
    h = field.grid_spacing_m or 2 * field.radius_m
    fig, ax = plt.subplots(figsize=(9, 9 * (np.ptp(pos[:, 1]) + 2 * h) / (np.ptp(pos[:, 0]) + 2 * h)
                                    + 1.0))
    visited = set(info["receivers"])
    for r, (x, y) in enumerate(pos[:, :2]):
        ax.add_patch(Rectangle((x - h / 2, y - h / 2), h, h, fill=r in visited,
                               facecolor="#cfe3f5", edgecolor="#bbbbbb", lw=0.5))
    ax.plot(pos[:, 0], pos[:, 1], ".", color="#777777", ms=3, label="receivers")
    src = field.source_positions_m
    ax.plot(src[:, 0], src[:, 1], "*", color="#d62728", ms=14, label="sources")
    xy = info["xy"]
    n = min(len(xy), int(path.duration_s * CONTROL_HZ) + 1)
    ax.plot(xy[:n, 0], xy[:n, 1], "-", color="#1f77b4", lw=2, label="path")
    ax.plot(*path.xy_m[0], "o", color="#2ca02c", ms=9, label="start")
    ax.plot(*path.xy_m[-1], "s", color="#9467bd", ms=9, label="end")
    step = int(CONTROL_HZ)
    for i in range(0, n, step):
        a = np.radians(info["heading_deg"][min(i, len(info["heading_deg"]) - 1)])
        ax.annotate("", xy=(xy[i, 0] + 0.5 * h * np.cos(a), xy[i, 1] + 0.5 * h * np.sin(a)),
                    xytext=(xy[i, 0], xy[i, 1]),
                    arrowprops={"arrowstyle": "->", "color": "#ff7f0e", "lw": 1.5})
        ax.text(xy[i, 0], xy[i, 1], f" {i / CONTROL_HZ:.0f}s", fontsize=7, color="#444444")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"walk through {field.scene_name or 'the field'}: {len(info['events'])} cells, "
                 f"{path.duration_s:.1f} s (arrows: heading, every second)")
    ax.legend(loc="upper right", fontsize=8)
    png = Path(png)
    try:
        write_atomically(png, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight",
                                                      format="png"))
    finally:
        plt.close(fig)
    return png
