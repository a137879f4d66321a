"""Hybrid early sound benchmark: EDT and C80 noise of the hybrid bake (image sources + particles)
against pure particles at equal wall time.

Run with ``make bench`` or ``.venv/bin/python benchmarks/early.py``. See benchmarks/README.md.

Room: examples/l-room/l-room.toml (an L-shaped classroom with tables, chairs and a cabinet, 652
triangles, four listeners, one around the corner). The hybrid adds ``[early]`` with
``max_order`` 3 and the automatic transition (the mixing time 20 V/S + 12 ms); the peer is the
same scene baked by particles alone, in the same run.

Equal wall time: the hybrid is baked with --rays rays; the particles get as many more rays as
the hybrid's extra work (image sources, visibility) costs, measured on the first seed. Each is
baked with --seeds seeds; the noise of EDT and C80 is their standard deviation across seeds, per
listener and octave band. The result is the ratio particles / hybrid (above 1: the hybrid is
less noisy at equal time), its median over listeners per band, with both sides' numbers and
their means (the means must agree within the noise: the hybrid counts nothing twice). Results go
to benchmarks/results/early.json.

Where the noise comes from (docs/early-sound.md): the share of each listener's first 80 ms that
the image sources hold (deterministic) is reported too; EDT's −10 dB point lies far later in this
room, where both bakes hold the same particles.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import tomllib
from common import machine_and_load, other_cpu_use, write_json

import sonolux
from sonolux.analysis.decay import c80, decay_times
from sonolux.sound.bake import bake

ROOM = Path(__file__).resolve().parent.parent / "examples" / "l-room" / "l-room.toml"


def load(early: bool, seed: int):
    data = tomllib.loads(ROOM.read_text())
    for g in data["geometry"]:
        if "file" in g:
            g["file"] = str(ROOM.parent / g["file"])
    data.setdefault("settings", {})["seed"] = seed
    if early:
        data["early"] = {"max_order": 3}
    return sonolux.load_scene(data)


def measures(field, scene) -> tuple[np.ndarray, np.ndarray]:
    """EDT (s) and C80 (dB), [listener, band]."""
    c = scene.settings.speed_of_sound_m_s
    src = np.asarray(scene.sources[0].position_m)
    edt, clar = [], []
    for r in range(field.energy.shape[0]):
        e = field.omni_energy(r)
        onset = float(np.linalg.norm(field.positions_m[r] - src)) / c
        edt.append(decay_times(e, field.bin_start_s, field.bin_width_s, onset_s=onset)["edt_s"])
        clar.append(c80(e, field.bin_start_s, field.bin_width_s, onset_s=onset))
    return np.asarray(edt, float), np.asarray(clar, float)


def image_share(field, scene) -> np.ndarray:
    """Share of each listener's first 80 ms (after the direct sound's time) held by the early
    arrivals, [listener, band]."""
    c = scene.settings.speed_of_sound_m_s
    src = np.asarray(scene.sources[0].position_m)
    out = []
    for r in range(field.energy.shape[0]):
        onset = float(np.linalg.norm(field.positions_m[r] - src)) / c
        total = field.omni_energy(r)[:, field.bin_start_s < onset + 0.08].sum(axis=1)
        keep = (field.early["receiver"] == r) & (field.early["time_s"] < onset + 0.08)
        out.append(field.early["energy"][keep].sum(axis=0) / total)
    return np.asarray(out)


def run(early: bool, rays: int, seeds: int, max_time_s: float) -> tuple[list, list, float]:
    edts, c80s, seconds = [], [], []
    for seed in range(seeds):
        sc = load(early, seed + 1)
        started = time.perf_counter()
        field = bake(sc, rays=rays, max_time_s=max_time_s)
        seconds.append(time.perf_counter() - started)
        a, b = measures(field, sc)
        edts.append(a)
        c80s.append(b)
    return edts, c80s, float(np.mean(seconds))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rays", type=int, default=40_000, help="the hybrid's rays a bake")
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--max-time", type=float, default=1.2, help="s of response baked")
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "early.json")
    args = ap.parse_args()
    busy_start = other_cpu_use()
    # Wall time of one bake each at the hybrid's ray count, then the particles' equal-time rays.
    t0 = time.perf_counter()
    first = bake(load(True, 1), rays=args.rays, max_time_s=args.max_time)
    hybrid_s = time.perf_counter() - t0
    share = image_share(first, load(True, 1))
    print("share of the first 80 ms held by the image sources [listener, band]:\n",
          np.round(share, 3))
    t0 = time.perf_counter()
    bake(load(False, 1), rays=args.rays, max_time_s=args.max_time)
    particles_s = time.perf_counter() - t0
    rays_particles = int(round(args.rays * hybrid_s / particles_s))
    print(f"one bake of {args.rays} rays: hybrid {hybrid_s:.2f} s, particles {particles_s:.2f} s; "
          f"particles get {rays_particles} rays for equal time")
    h_edt, h_c80, h_s = run(True, args.rays, args.seeds, args.max_time)
    p_edt, p_c80, p_s = run(False, rays_particles, args.seeds, args.max_time)
    bands = [float(b) for b in load(False, 1).settings.bands_hz]
    result = {"room": str(ROOM.name), "rays_hybrid": args.rays, "rays_particles": rays_particles,
              "seeds": args.seeds, "mean_seconds_hybrid": h_s, "mean_seconds_particles": p_s,
              "bands_hz": bands, "image_share_first_80ms": share.tolist()}
    for name, h, p in (("edt_s", h_edt, p_edt), ("c80_db", h_c80, p_c80)):
        h, p = np.asarray(h), np.asarray(p)  # [seed, listener, band]
        sh, sp = np.nanstd(h, axis=0, ddof=1), np.nanstd(p, axis=0, ddof=1)
        ratio = np.nanmedian(sp / sh, axis=0)
        result[name] = {"std_hybrid": sh.tolist(), "std_particles": sp.tolist(),
                        "mean_hybrid": np.nanmean(h, axis=0).tolist(),
                        "mean_particles": np.nanmean(p, axis=0).tolist(),
                        "noise_ratio_particles_over_hybrid_median": ratio.tolist()}
        print(f"{name}: noise ratio particles / hybrid (median over listeners) per band "
              + ", ".join(f"{b:g} Hz {r:.2f}" for b, r in zip(bands, ratio)))
        print(f"  std hybrid {np.round(np.nanmedian(sh, axis=0), 4).tolist()}, "
              f"std particles {np.round(np.nanmedian(sp, axis=0), 4).tolist()}")
    result["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(args.out, result)
    print(f"results in {args.out}")


if __name__ == "__main__":
    main()
