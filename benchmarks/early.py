"""Hybrid early sound benchmark: EDT and C80 noise of the hybrid bake (image sources + particles)
against pure particles at equal wall time.

Run with ``make bench`` or ``.venv/bin/python benchmarks/early.py``. See benchmarks/README.md.

Room: examples/l-room/l-room.toml (an L-shaped classroom with tables, chairs and a cabinet, 652
triangles, four listeners, one around the corner). The hybrid adds ``[early]`` with
``max_order`` 3 and the automatic transition (the mixing time 20 V/S + 12 ms); the peer is the
same scene baked by particles alone, in the same run.

Equal wall time: the hybrid is baked with --rays rays (default: the bake's own automatic count,
sonolux.sound.bake.auto_rays, 57,640 here: what a user gets); the particles get as many more
rays as the hybrid's extra work (image sources, diffraction, visibility) costs, measured on the
first seed. Each is baked with --seeds seeds; the noise of EDT and C80 is their standard
deviation across seeds, per listener and octave band. The result is the ratio particles / hybrid
(above 1: the hybrid is less noisy at equal time), per listener and its median over listeners per
band, with both sides' numbers and their means (the means must agree within the noise: the
hybrid counts nothing twice). Each ratio of two standard deviations from n seeds has a sampling
spread: its 68 % interval from the F distribution with (n − 1, n − 1) degrees of freedom is
printed (with 6 seeds it is 0.73–1.37 for a true ratio of 1: the old 6-seed table could not
tell 0.70 from 0.50). Results go to benchmarks/results/early.json.

The responses are baked for 2.5 s: EDT needs the decay 20 dB below its −10 dB point inside the
record (sonolux.analysis.decay), which 1.2 s did not give at 125–500 Hz (EDT undefined in some
seeds, so the old table's low-band ratios came from a few seeds).

Where the noise comes from (docs/early-sound.md "Noise at equal wall time"): the share of each
listener's first 80 ms that the image sources hold (deterministic) is reported too. Paired (same
seeds, same rays) the hybrid's particles are exactly as noisy as the particles alone wherever the
image sources hold little of that energy; only the listener near the talker gains.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import tomllib
from common import machine_and_load, other_cpu_use, write_json
from scipy import stats

import sonolux
from sonolux.analysis.decay import c80, decay_times
from sonolux.sound.bake import auto_rays, bake, bake_arrays
from sonolux.sound.options import SoundOptions

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
    ap.add_argument("--rays", type=int, default=0,
                    help="the hybrid's rays a bake (default 0: the bake's automatic count)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--max-time", type=float, default=2.5, help="s of response baked")
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results" / "early.json")
    args = ap.parse_args()
    busy_start = other_cpu_use()
    if args.rays <= 0:
        sc = load(False, 1)
        args.rays, why = auto_rays(sc, SoundOptions(), bake_arrays(sc, SoundOptions()))
        print("hybrid rays:", why)
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
    # Paired, at equal rays (same seeds, so the same rays): the noise per ray, without the
    # sampling spread of two independent sets of seeds.
    q_edt, q_c80, _ = run(False, args.rays, args.seeds, args.max_time)
    bands = [float(b) for b in load(False, 1).settings.bands_hz]
    result = {"room": str(ROOM.name), "rays_hybrid": args.rays, "rays_particles": rays_particles,
              "seeds": args.seeds, "mean_seconds_hybrid": h_s, "mean_seconds_particles": p_s,
              "bands_hz": bands, "image_share_first_80ms": share.tolist(),
              "seconds_one_bake_hybrid": hybrid_s, "seconds_one_bake_particles": particles_s}
    # A ratio of two standard deviations of n values each: sqrt(F(n-1, n-1)), 16th-84th %.
    dof = args.seeds - 1
    spread = np.sqrt(stats.f.ppf([0.16, 0.84], dof, dof))
    result["ratio_68_percent_interval_for_true_ratio_1"] = spread.tolist()
    print(f"a ratio of two standard deviations over {args.seeds} seeds: 68 % of them fall in "
          f"{spread[0]:.2f}–{spread[1]:.2f} × the true ratio")
    for name, h, p, q in (("edt_s", h_edt, p_edt, q_edt), ("c80_db", h_c80, p_c80, q_c80)):
        h, p, q = np.asarray(h), np.asarray(p), np.asarray(q)  # [seed, listener, band]
        paired = np.nanstd(q, axis=0, ddof=1) / np.nanstd(h, axis=0, ddof=1)
        sh, sp = np.nanstd(h, axis=0, ddof=1), np.nanstd(p, axis=0, ddof=1)
        per_listener = sp / sh
        ratio = np.nanmedian(per_listener, axis=0)
        result[name] = {"std_hybrid": sh.tolist(), "std_particles": sp.tolist(),
                        "mean_hybrid": np.nanmean(h, axis=0).tolist(),
                        "mean_particles": np.nanmean(p, axis=0).tolist(),
                        "undefined_hybrid": np.isnan(h).sum(axis=0).tolist(),
                        "undefined_particles": np.isnan(p).sum(axis=0).tolist(),
                        "noise_ratio_particles_over_hybrid": per_listener.tolist(),
                        "noise_ratio_particles_over_hybrid_median": ratio.tolist(),
                        "equal_rays_paired_ratio": paired.tolist()}
        print(f"{name}: noise ratio particles / hybrid (median over listeners) per band "
              + ", ".join(f"{b:g} Hz {r:.2f}" for b, r in zip(bands, ratio)))
        print("  per listener [listener, band]:\n", np.round(per_listener, 2))
        print("  at equal rays, same seeds (noise per ray) [listener, band]:\n", np.round(paired, 2))
        print(f"  std hybrid {np.round(np.nanmedian(sh, axis=0), 4).tolist()}, "
              f"std particles {np.round(np.nanmedian(sp, axis=0), 4).tolist()}")
        undefined = int(np.isnan(h).sum() + np.isnan(p).sum())
        if undefined:
            print(f"  {undefined} values undefined (NaN: see sonolux.analysis.decay's reasons)")
    result["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(args.out, result)
    print(f"results in {args.out}")


if __name__ == "__main__":
    main()
