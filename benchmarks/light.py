"""Light benchmark: sonolux's particle tracer against Mitsuba 3's particle tracer (`ptracer`).

Run with ``make bench`` or ``.venv/bin/python benchmarks/light.py``. See benchmarks/README.md.

Scenes: the paper's three rooms (6 × 2.5 × 2 m, × 2, × 4), walls and ceiling reflecting 98 %,
the floor 30 %, the strip light (half the length, a fiftieth of the width... as in
``paper-*.toml``: 3 × 0.12 m scaled, 60 W × scale²) made flush with the ceiling, a surface
light (``tests/reference/mitsuba_light.py``): both renderers get the very same triangles, and
Mitsuba's lights are shapes that block, which the built-in scenes' free-floating rectangle is not.
Both renderers: one-sided diffuse surfaces, one-sided cosine emitter, unbounded depth with
Russian roulette.

Measured per room, in one run:
  rate    particles (light paths) per second on 1 and 2 threads: sonolux ``bake_light``
          (``settings.threads``); Mitsuba's ``ptracer`` (``scalar_rgb``, or ``--variant``)
          rendering the floor's camera (``drjit.set_thread_count``). Median of --repeats.
  1 %     the time each needs until the per-surface mean irradiance is within 1 % of the
          converged value (RMS over runs, worst surface): --batches independent runs (seeds) of
          n particles give each surface's relative spread σ; n₁ = n (σ / 0.01)² and the time
          is n₁ / rate (2 threads). sonolux's one bake measures every surface at once (its
          time is the worst surface's); Mitsuba measures one surface a render, with a
          perspective camera that looks straight at the surface from the middle of the opposite
          one, its frustum the surface's rectangle (so pixels cover equal areas and the
          irradiance is π × mean radiance / ρ; the ceiling's lamp pixels are left out), so its
          time is the sum over surfaces (the worst single surface is printed too).
  agree   the two renderers' means per surface (all runs pooled) differ by this much: the
          comparison is meaningless unless they agree within their noise.
Results go to benchmarks/results/light.json.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # tests.reference.mitsuba_light: the rooms, Mitsuba's scene

from common import other_cpu_use, write_json  # noqa: E402

import sonolux  # noqa: E402
from sonolux.light.bake import bake_light  # noqa: E402
from tests.reference.mitsuba_light import box_room, load_mitsuba, mitsuba_scene  # noqa: E402

ROOMS = (("paper-small", 1), ("paper-medium", 2), ("paper-large", 4))
FACES = ("floor", "ceiling", "west", "east", "south", "north")
TARGET = 0.01
THREADS = (1, 2)
PIXEL_M = 0.01  # × scale: the lamp's edges fall on pixel edges (1.5, 1.19 and 1.31 m)


def log(msg: str) -> None:
    print(f"[light {time.strftime('%H:%M:%S')}] {msg}", flush=True)




def paper_room(directory: str, name: str, scale: float) -> sonolux.Scene:
    white = (0.98, 0.98, 0.98)
    rho = {g: white for g in ("ceiling", "lamp", "west", "east", "south", "north")}
    rho["floor"] = (0.3, 0.3, 0.3)
    return box_room(directory, size_m=(6 * scale, 2.5 * scale, 2 * scale),
                    lamp_m=(3 * scale, 0.12 * scale), reflectance=rho,
                    lamp_power_w=60 * scale**2, name=name)


def with_settings(scene: sonolux.Scene, **kw: Any) -> sonolux.Scene:
    return replace(scene, settings=replace(scene.settings, **kw))


# --------------------------------------------------------------------------- sonolux


def sonolux_rate(scene: sonolux.Scene, particles: int, threads: int, repeats: int) -> float:
    s = with_settings(scene, threads=threads)
    bake_light(s, particles=20_000)  # warm-up
    rates = []
    for _ in range(repeats):
        t = time.perf_counter()
        bake_light(s, particles=particles)
        rates.append(particles / (time.perf_counter() - t))
    return statistics.median(rates)


def sonolux_runs(scene: sonolux.Scene, particles: int, runs: int,
                 first_seed: int) -> tuple[np.ndarray, float]:
    """(mean irradiance float64[runs, faces] (RGB mean), seconds of all runs), 2 threads.
    The rooms are scaled copies: each needs its own seeds, or their runs would be the same
    random paths, scaled."""
    out, t = [], time.perf_counter()
    for k in range(runs):
        e = bake_light(with_settings(scene, seed=first_seed + k, threads=2),
                       particles=particles).mean_irradiance_w_m2()
        out.append([float(np.mean(e[f])) for f in FACES])
    return np.array(out), time.perf_counter() - t


# --------------------------------------------------------------------------- Mitsuba


def face_camera(mi: Any, size_m: np.ndarray, face: str, pixel_m: float) -> tuple[dict, dict]:
    """A perspective camera at the middle of the opposite face, looking straight at ``face``,
    its frustum exactly the face: (sensor dict, layout: width, height, extent a × b, axes)."""
    L, W, H = size_m
    d = 1e-4 * float(size_m.max())
    c = size_m / 2
    axis = {"floor": 2, "ceiling": 2, "west": 0, "east": 0, "south": 1, "north": 1}[face]
    low = face in ("floor", "west", "south")
    origin, target = c.copy(), c.copy()
    origin[axis] = size_m[axis] - d if low else d
    target[axis] = 0.0 if low else size_m[axis]
    up = (0, 1, 0) if axis == 2 else (0, 0, 1)
    a, b = {0: (W, H), 1: (L, H), 2: (L, W)}[axis]
    w, h = round(a / pixel_m), round(b / pixel_m)
    fov = 2 * np.degrees(np.arctan(a / 2 / (size_m[axis] - d)))
    sensor = {"type": "perspective", "fov": float(fov), "fov_axis": "x", "near_clip": d / 10,
              "to_world": mi.ScalarTransform4f().look_at(origin=origin.tolist(),
                                                         target=target.tolist(), up=list(up)),
              "film": {"type": "hdrfilm", "width": w, "height": h, "rfilter": {"type": "box"},
                       "pixel_format": "rgb"}}
    return sensor, {"w": w, "h": h, "a": a, "b": b}


def lamp_mask(layout: dict, size_m: np.ndarray, lamp_m: tuple[float, float]) -> np.ndarray:
    """bool[h, w]: ceiling pixels on the lamp (centred, so image flips do not matter)."""
    xs = (np.arange(layout["w"]) + 0.5) / layout["w"] * layout["a"]
    ys = (np.arange(layout["h"]) + 0.5) / layout["h"] * layout["b"]
    return ((np.abs(xs - size_m[0] / 2) < lamp_m[0] / 2)[None, :]
            & (np.abs(ys - size_m[1] / 2) < lamp_m[1] / 2)[:, None])


def mitsuba_face_irradiance(img: np.ndarray, face: str, rho: float, mask: np.ndarray | None) -> float:
    rgb = np.asarray(img, float)
    mean = rgb[~mask].mean(axis=0) if mask is not None else rgb.reshape(-1, 3).mean(axis=0)
    return float(np.pi * mean.mean() / rho)


class MitsubaRoom:
    def __init__(self, mi: Any, scene: sonolux.Scene, directory: str, scale: float) -> None:
        import drjit

        self.mi, self.dr = mi, drjit
        self.size = np.ptp(scene.vertices_m, axis=0)
        cams, self.layout = [], {}
        for f in FACES:
            cam, self.layout[f] = face_camera(mi, self.size, f, PIXEL_M * scale)
            cams.append(cam)
        self.mask = lamp_mask(self.layout["ceiling"], self.size, (3 * scale, 0.12 * scale))
        self.rho = {f: 0.3 if f == "floor" else 0.98 for f in FACES}
        self.scene, _ = mitsuba_scene(mi, scene, directory, meters=False,
                                      integrator={"type": "ptracer", "max_depth": -1},
                                      sensors=cams)

    def paths(self, face: str, spp: int) -> int:
        return spp * self.layout[face]["w"] * self.layout[face]["h"]

    def render(self, face: str, spp: int, seed: int) -> tuple[float, float]:
        """(mean irradiance of the face, seconds)."""
        k = FACES.index(face)
        t = time.perf_counter()
        img = self.mi.render(self.scene, sensor=k, spp=spp, seed=seed)
        seconds = time.perf_counter() - t
        mask = self.mask if face == "ceiling" else None
        return mitsuba_face_irradiance(np.asarray(img), face, self.rho[face], mask), seconds

    def rate(self, threads: int, repeats: int) -> float:
        self.dr.set_thread_count(threads)
        self.render("floor", 1, 0)  # warm-up
        rates = []
        for r in range(repeats):
            _, s = self.render("floor", 1, 100 + r)
            rates.append(self.paths("floor", 1) / s)
        self.dr.set_thread_count(max(THREADS))
        return statistics.median(rates)


def quiet_progress(mi: Any) -> None:
    """Mitsuba's warnings and errors on stderr, without its progress bars."""
    class Quiet(mi.Appender):
        def append(self, level: Any, text: str) -> None:
            if level >= mi.LogLevel.Warn:
                print(text, file=sys.stderr)

        def log_progress(self, *args: Any) -> None:
            pass

    mi.logger().clear_appenders()
    mi.logger().add_appender(Quiet())


# --------------------------------------------------------------------------- the run


def to_target(values: np.ndarray, n: float, rate: float) -> dict[str, float]:
    """From independent runs of n particles each: relative spread, particles and seconds to
    a 1 % RMS error."""
    sigma = float(np.std(values, ddof=1) / np.mean(values))
    n1 = n * (sigma / TARGET) ** 2
    return {"relative_sigma": sigma, "particles_to_1pct": n1, "seconds_to_1pct": n1 / rate}


def run_room(mi: Any, name: str, scale: float, args: argparse.Namespace) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        scene = paper_room(tmp, name, scale)
        log(f"{name}: sonolux rate on {THREADS} threads")
        s_rate = {str(t): sonolux_rate(scene, args.rate_particles, t, args.repeats) for t in THREADS}
        log(f"{name}: sonolux, {args.runs} runs of {args.particles:,} particles")
        s_vals, s_sec = sonolux_runs(scene, args.particles, args.runs, 1000 * (1 + int(scale)))
        s_run_rate = args.runs * args.particles / s_sec
        per_face = {f: to_target(s_vals[:, i], args.particles, s_run_rate) for i, f in enumerate(FACES)}
        worst = max(per_face, key=lambda f: per_face[f]["relative_sigma"])
        out: dict[str, Any] = {
            "scale": scale, "size_m": np.ptp(scene.vertices_m, axis=0).tolist(),
            "sonolux": {"particles_per_s": s_rate, "runs_particles_per_s": s_run_rate,
                        "faces": per_face, "worst_face": worst,
                        "seconds_to_1pct": per_face[worst]["seconds_to_1pct"],
                        "mean_irradiance": dict(zip(FACES, s_vals.mean(axis=0).tolist()))}}
        if mi is None:
            return out
        room = MitsubaRoom(mi, scene, tmp, scale)
        log(f"{name}: Mitsuba ptracer rate on {THREADS} threads")
        m_rate = {str(t): room.rate(t, args.repeats) for t in THREADS}
        faces: dict[str, Any] = {}
        for f in FACES:
            log(f"{name}: Mitsuba, {args.mitsuba_runs} renders of the {f} "
                f"({room.paths(f, 1):,} paths each)")
            seeds = range(100_000 * int(scale), 100_000 * int(scale) + args.mitsuba_runs)
            vals, secs = zip(*(room.render(f, 1, seed) for seed in seeds))
            rate = room.paths(f, 1) * len(secs) / sum(secs)
            faces[f] = {**to_target(np.array(vals), room.paths(f, 1), rate), "paths_per_s": rate,
                        "mean_irradiance": float(np.mean(vals))}
        total = sum(v["seconds_to_1pct"] for v in faces.values())
        agree = {}
        for i, f in enumerate(FACES):
            ours, theirs = s_vals[:, i].mean(), faces[f]["mean_irradiance"]
            se = np.hypot(per_face[f]["relative_sigma"] / np.sqrt(args.runs),
                          faces[f]["relative_sigma"] / np.sqrt(args.mitsuba_runs))
            agree[f] = {"relative_difference": float(ours / theirs - 1), "standard_error": float(se)}
        out["mitsuba"] = {"particles_per_s": m_rate, "faces": faces, "seconds_to_1pct": total,
                          "worst_face_seconds_to_1pct": max(v["seconds_to_1pct"] for v in faces.values())}
        out["agreement"] = agree
        out["ratio"] = {"particles_per_s": {t: s_rate[t] / m_rate[t] for t in s_rate},
                        "time_to_1pct": total / out["sonolux"]["seconds_to_1pct"]}
        return out


def print_table(results: dict[str, Any]) -> None:
    print()
    hdr = (f"{'room':<13}" + "".join(f" | {t}T sonolux  Mitsuba  ratio" for t in THREADS)
           + " | to 1 %: sonolux  Mitsuba (worst face)   ratio | agree (max |diff| / σ)")
    print(hdr)
    print("-" * len(hdr))
    for name, r in results.items():
        s, m = r["sonolux"], r.get("mitsuba")
        line = f"{name:<13}"
        for t in map(str, THREADS):
            sv = s["particles_per_s"][t] / 1e3
            if m:
                line += (f" | {sv:>8.0f}k {m['particles_per_s'][t] / 1e3:>7.0f}k "
                         f"{r['ratio']['particles_per_s'][t]:>6.2f}")
            else:
                line += f" | {sv:>8.0f}k {'-':>8} {'-':>6}"
        line += f" | {s['seconds_to_1pct']:>13.2f} s"
        if m:
            worst = max(r["agreement"].values(), key=lambda a: abs(a["relative_difference"]))
            worst_face = m["worst_face_seconds_to_1pct"]
            line += (f" {m['seconds_to_1pct']:>6.2f} s ({worst_face:.2f} s) "
                     f"{r['ratio']['time_to_1pct']:>6.1f} | {worst['relative_difference']:+.2%} / "
                     f"{abs(worst['relative_difference']) / worst['standard_error']:.1f}")
        print(line)
    print()
    print("rates in particles (light paths) per second; ratio = sonolux / Mitsuba (> 1: sonolux "
          "faster). 'to 1 %': seconds on 2 threads until the per-surface mean irradiance is within "
          "1 % (RMS) of the converged value; its ratio = Mitsuba's time / sonolux's (> 1: sonolux "
          "sooner). Mitsuba renders one surface at a time; the worst single surface is in "
          "brackets.")




def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rooms", nargs="+", default=[r for r, _ in ROOMS], choices=[r for r, _ in ROOMS])
    ap.add_argument("--rate-particles", type=int, default=1_000_000, help="sonolux rate runs")
    ap.add_argument("--repeats", type=int, default=3, help="rate runs, median taken (3)")
    ap.add_argument("--particles", type=int, default=100_000, help="particles per sonolux run")
    ap.add_argument("--runs", type=int, default=16, help="independent sonolux runs (16)")
    ap.add_argument("--mitsuba-runs", type=int, default=8, help="renders per surface (8)")
    ap.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant (scalar_rgb)")
    ap.add_argument("--no-install", action="store_true", help="never pip-install mitsuba")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "light.json")
    args = ap.parse_args(argv)
    started, busy_start = time.perf_counter(), other_cpu_use()
    mi, why = load_mitsuba(install=not args.no_install, variant=args.variant)
    if mi is None:
        log(f"WARNING: no peer, only sonolux's own numbers ({why})")
    else:
        quiet_progress(mi)
        log(f"peer: Mitsuba {mi.__version__} {args.variant} ptracer")
    results = {name: run_room(mi, name, scale, args) for name, scale in ROOMS if name in args.rooms}
    print_table(results)
    busy_end = other_cpu_use()
    if max(busy_start, busy_end) > 0.15:
        print(f"WARNING: other processes kept {busy_start:.0%} of the CPUs busy at the start, "
              f"{busy_end:.0%} at the end: the rates are noisy, run again on an idle machine.")
    elapsed = time.perf_counter() - started
    write_json(args.out, {
        "benchmark": "light", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "sonolux_version": sonolux.__version__,
        "peer": {"name": "mitsuba", "version": mi.__version__, "variant": args.variant,
                 "integrator": "ptracer"} if mi else None,
        "machine": {"platform": platform.platform(), "python": platform.python_version(),
                    "cpus": os.cpu_count(), "other_cpu_use_start_end": [busy_start, busy_end]},
        "settings": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "elapsed_s": elapsed, "rooms": results})
    log(f"wrote {args.out} ({elapsed:.0f} s in all)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
