"""Sound benchmark: sonolux's sound tracer against pyroomacoustics' ray tracer, and time to accuracy.

Run with ``make bench`` or ``.venv/bin/python benchmarks/sound.py``. See benchmarks/README.md.

One run, about 12 minutes on 2 cores (5 with ``--budget skip``), does four things on the three
rooms of the paper (paper-small 6 x 2.5 x 2 m, paper-medium 12 x 5 x 4 m, paper-large 24 x 10 x 8 m: walls and
ceiling absorb 5 % of the energy, the floor 30 %, scattering 0.1 everywhere; the talker at the
centre, 1.5 m high; receivers every metre at 1.5 m, radius 0.25 m):

1. sonolux rays/s and segments/s on 1 and 2 threads over the full receiver grid, with both
   estimators ("paper", the default since this benchmark measured it faster, and "rain"), and
   the memory of one receiver's field. Ray counts are sized from a short calibration bake so
   that each 2-thread bake lasts about --rate-seconds.
2. pyroomacoustics' ray tracer (a benchmark-only dependency, pip-installed into the running
   interpreter when missing) on the same shoebox: ``ShoeBox(max_order=-1, ray_tracing=True)``, the
   same energy absorption and scattering per face, the same receiver radius, a 60 dB energy
   threshold as sonolux's, air absorption off in both. Only ``room.ray_tracing()`` is timed (not
   the RIR synthesis of ``compute_rir()``). It counts rays per source, like sonolux: every ray is
   tested against every microphone. Measured with one receiver and with 12 grid receivers; its
   full-grid rate is extrapolated from those two (cost per ray = a + b x receivers). Its wall
   hits per ray are counted by a numpy replica of libroom's ``simul_ray`` bounce rule.
3. Time to accuracy in paper-medium: a reference T30 (per band, every receiver) from a long
   "paper" bake with another seed, then each estimator traces a growing number of rays (ray
   ranges of one bake, merged) until T30 is within 2 % of the reference at every receiver and
   band at two checks in a row. The faster estimator is printed: that decides the default.
4. The paper's own budget, 48 million rays for paper-large in about 4.8 hours, against
   sonolux's wall time for those 48 M rays on the full grid, traced (``--budget full``, the
   default; ``slope`` estimates it from two long bakes), with the air on (the scene's air, what
   a bake of the scene does) and off (as the peer): sound_budget.py.

Only ratios measured in one run mean anything; absolute rates depend on the machine and on
what else runs on it. Results go to benchmarks/results/sound.json.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from common import other_cpu_use, write_json
from sound_budget import PAPER_RAYS, describe, paper_budget
from sound_peer import ENERGY_THRES, HIST_BIN_S, load_pra, pra_hits_per_ray, pra_room, pra_trace, shoebox_of

import sonolux
from sonolux.analysis.decay import decay_times

HERE = Path(__file__).resolve().parent
ROOMS = ("paper-small", "paper-medium", "paper-large")
ESTIMATORS = ("rain", "paper")
THREAD_COUNTS = (1, 2)
SUBSET = 12  # grid receivers in the peer's multi-receiver case
T30_TOL = 0.02
PROGRESSIVE_RAYS = 100_000_000  # the nominal ray count of the progressive bakes (only ranges run)
GROWTH = 1.25  # each check of the accuracy search traces 25 % more rays than the last
START_RAYS = {"paper": 40_000, "rain": 400}
REF_SEED = 1_000_003  # the reference bake's seed: independent of the searches' rays
PAPER_HOURS = 4.8  # Pope & Chalmers' time for their 48 M rays of paper-large
# Issue 15's targets: one receiver at least 5x pyroomacoustics' rays/s (sonolux on 2 threads, the
# peer on its one), and paper-large's 48 M rays on the full grid within 3 minutes on 2 threads.
TARGET_1RCV_RATIO = 5.0
TARGET_48M_S = 180.0


def log(msg: str) -> None:
    print(f"[sound {time.strftime('%H:%M:%S')}] {msg}", flush=True)


# --------------------------------------------------------------------------- helpers






def _dist_version(name: str) -> str:
    try:
        from importlib.metadata import version
        return version(name)
    except Exception:  # noqa: BLE001
        return "?"


def with_threads(scene, threads: int):
    return replace(scene, settings=replace(scene.settings, threads=threads))


def with_seed(scene, seed: int):
    return replace(scene, settings=replace(scene.settings, seed=seed))


def with_receivers(scene, positions: np.ndarray):
    """The same scene with listed receivers (same radius) instead of the grid."""
    return replace(scene, receivers=replace(
        scene.receivers, kind="points", positions_m=np.asarray(positions, float).reshape(-1, 3),
        grid_index=None, spacing_m=None, origin_m=None))


def bake(scene, rays: int, estimator: str, threads: int = 2, **kw):
    """A sound bake with the air's absorption off (as the peer), unless told otherwise."""
    kw.setdefault("air_absorption", False)
    return sonolux.bake(with_threads(scene, threads), rays=int(rays), estimator=estimator,
                        progress=False, **kw)


def omni(field) -> np.ndarray:
    """float64[receiver, band, time]: energy from all directions."""
    return np.asarray(field.energy).sum(axis=1, dtype=np.float64)  # a compact field: its dense view


def t30(energy: np.ndarray, field) -> np.ndarray:
    return np.asarray(decay_times(energy, field.bin_start_s, field.bin_width_s)["t30_s"], float)


# --------------------------------------------------------------------------- peer


def measure_sonolux(name: str, scene, rate_seconds: float) -> dict:
    n_rec = scene.receivers.count
    log(f"{name}: {n_rec} receivers, V = {scene.volume_m3:g} m³; sonolux, full grid")
    setup = bake(scene, 1, "paper", 2)  # a one-ray bake: the fixed cost of a bake
    res = {"receivers": n_rec, "volume_m3": scene.volume_m3, "setup_s": setup.stats["seconds"],
           "max_time_s": setup.settings["max_time_s"], "bytes_per_receiver": setup.bytes_per_receiver,
           "field_bytes": setup.bytes_per_receiver * n_rec, "estimators": {}}
    log(f"  setup (one-ray bake) {res['setup_s']:.2f} s; field {setup.bytes_per_receiver / 1e6:.2f} MB "
        f"per receiver, {res['field_bytes'] / 1e6:.0f} MB in all (float32; counts are u64 while tracing)")
    for est in ESTIMATORS:
        n_cal = 200 if est == "rain" else 5000
        cal = bake(scene, n_cal, est, 2)
        net = n_cal / max(cal.stats["seconds"] - res["setup_s"], 1e-3)
        # At least 20 calibrations' worth: a bake of a few times the calibration's rays is mostly
        # the fixed cost (paper-large's field), and the slope below would then be noise.
        n = int(min(max(rate_seconds * net, 20 * n_cal), 5_000_000))
        n = int(round(n, -len(str(n)) + 2))  # two significant digits
        r = {"rays": n, "rays_per_s": {}, "segments_per_s": {}, "seconds": {}}
        for th in sorted(THREAD_COUNTS, reverse=True):
            f = bake(scene, n, est, th)
            st = f.stats
            r["rays_per_s"][str(th)] = st["rays_per_second"]
            r["segments_per_s"][str(th)] = st["segments_per_second"]
            r["seconds"][str(th)] = st["seconds"]
            if th == 2:
                r["segments_per_ray"] = st["segments"] / st["rays"]
                r["surface_hits_per_ray"] = st["surface_hits"] / st["rays"]
                r["deposits_per_ray"] = st["deposits"] / st["rays"]
                r["mean_free_path_m"] = st["mean_free_path_m"]
                # rays/s without the bake's fixed cost: the slope between the calibration bake
                # and this one (both 2 threads), which the fixed cost does not enter
                slope = (st["seconds"] - cal.stats["seconds"]) / max(n - n_cal, 1)
                r["net_rays_per_s_2t"] = 1 / slope if n > 2 * n_cal and slope > 0 else st["rays_per_second"]
            log(f"  {est:>5}, {th} thread(s), {n:,} rays: {st['seconds']:.2f} s, "
                f"{st['rays_per_second']:,.0f} rays/s, {st['segments_per_second'] / 1e6:.2f} M segments/s, "
                f"{st['deposits'] / st['rays']:,.0f} deposits/ray")
        r["thread_speedup"] = r["rays_per_s"]["2"] / r["rays_per_s"]["1"]
        res["estimators"][est] = r
    # The case a user bakes: the scene's air (ISO 9613-1) absorbing, paper estimator, 2 threads.
    p = res["estimators"]["paper"]
    cal = bake(scene, 5000, "paper", 2, air_absorption=True)
    f = bake(scene, p["rays"], "paper", 2, air_absorption=True)
    slope = (f.stats["seconds"] - cal.stats["seconds"]) / max(p["rays"] - 5000, 1)
    # the slope only when the bake is mostly tracing (else its rate, fixed cost included)
    tracing = slope > 0 and f.stats["seconds"] > 2 * cal.stats["seconds"]
    net = 1 / slope if tracing else f.stats["rays_per_second"]
    res["paper_air_on"] = {"rays": p["rays"], "rays_per_s_2t": f.stats["rays_per_second"],
                           "net_rays_per_s_2t": net}
    log(f"  paper, air on (the scene's), 2 threads, {p['rays']:,} rays: {f.stats['seconds']:.2f} s, "
        f"{f.stats['rays_per_second']:,.0f} rays/s")
    return res


# --------------------------------------------------------------------------- 2: the peer


def pick_receivers(scene) -> tuple[np.ndarray, np.ndarray]:
    """One grid receiver (the nearest at >= 1.5 m from the source) and SUBSET grid receivers
    spread over the grid, none holding the source (pyroomacoustics fails there)."""
    pos = np.asarray(scene.receivers.positions_m, float)
    src = np.asarray(scene.sources[0].position_m, float)
    d = np.linalg.norm(pos - src, axis=1)
    one = pos[np.argmin(np.where(d >= 1.5, d, np.inf))]
    ok = pos[d > 2 * scene.receivers.radius_m]
    subset = ok[np.unique(np.linspace(0, len(ok) - 1, min(SUBSET, len(ok))).round().astype(int))]
    return one[None, :], subset


def measure_peer(pra, name: str, scene, sono: dict, peer_seconds: float, rate_seconds: float) -> dict:
    box = shoebox_of(scene)
    radius = scene.receivers.radius_m
    tmax = sono["max_time_s"]
    c = scene.settings.speed_of_sound_m_s
    one, subset = pick_receivers(scene)
    n_full = sono["receivers"]
    res = {"faces": box["faces"], "time_thres_s": tmax, "one_receiver_m": one[0].tolist(),
           "subset_m": subset.tolist()}
    log(f"{name}: pyroomacoustics ({len(subset)}-receiver subset and one receiver at "
        f"({', '.join(f'{v:g}' for v in one[0])}) m), time_thres {tmax:.2f} s")
    cal_n = 2000
    dt = pra_trace(pra_room(pra, box, one, cal_n, tmax, radius))
    n = int(min(max(peer_seconds * cal_n / dt, 5000), 300_000))
    n = int(round(n, -len(str(n)) + 2))
    res["rays"] = n

    room = pra_room(pra, box, one, n, tmax, radius)
    dt1 = pra_trace(room)
    res["pra_rays_per_s_1rcv"] = n / dt1
    hist = np.asarray(room.rt_histograms[0][0][0], float)  # (1 direction, bins) -> bins
    w = room.rt_args["hist_bin_size"]
    res["pra_t30_1rcv_s"] = float(decay_times(hist.reshape(-1), np.arange(hist.size) * w,
                                              np.full(hist.size, w))["t30_s"])
    room = pra_room(pra, box, subset, n, tmax, radius)
    dts = pra_trace(room)
    res["pra_rays_per_s_subset"] = n / dts
    # cost per ray = a + b * receivers, from the two runs; extrapolated to the full grid
    b = max((dts - dt1) / n / (len(subset) - 1), 0.0)
    a = max(dt1 / n - b, 1e-12)
    res["pra_cost_model_s_per_ray"] = {"a": a, "b_per_receiver": b}
    res["pra_rays_per_s_full_extrapolated"] = 1.0 / (a + b * n_full)
    res["pra_hits_per_ray_replica"] = pra_hits_per_ray(box, tmax, c)
    res["pra_wall_hits_per_s_1rcv"] = res["pra_rays_per_s_1rcv"] * res["pra_hits_per_ray_replica"]
    log(f"  pyroomacoustics, 1 thread, {n:,} rays: 1 receiver {res['pra_rays_per_s_1rcv']:,.0f} rays/s, "
        f"{len(subset)} receivers {res['pra_rays_per_s_subset']:,.0f} rays/s, full grid "
        f"({n_full}) ~{res['pra_rays_per_s_full_extrapolated']:,.0f} rays/s (extrapolated); "
        f"~{res['pra_hits_per_ray_replica']:.0f} wall hits/ray (replica) = "
        f"{res['pra_wall_hits_per_s_1rcv'] / 1e6:.2f} M hits/s")

    # sonolux on the very same receivers and ray counts
    s_one, s_sub = with_receivers(scene, one), with_receivers(scene, subset)
    res["sonolux"] = {}
    for est in ESTIMATORS:
        r = {"rays_per_s_1rcv": {}}
        for th in sorted(THREAD_COUNTS, reverse=True):
            f = bake(s_one, n, est, th)
            r["rays_per_s_1rcv"][str(th)] = f.stats["rays_per_second"]
            if th == 2:
                r["t30_1rcv_s"] = float(np.nanmean(t30(omni(f), f)))
        net_full = sono["estimators"][est]["net_rays_per_s_2t"]
        n_sub = n if est == "paper" else int(
            min(n, max(1000, rate_seconds * net_full * n_full / len(subset))))
        f = bake(s_sub, n_sub, est, 2)
        r["subset_rays"] = n_sub
        r["rays_per_s_subset_2t"] = f.stats["rays_per_second"]
        full2 = sono["estimators"][est]["rays_per_s"]["2"]
        r["ratio_1rcv_2t"] = r["rays_per_s_1rcv"]["2"] / res["pra_rays_per_s_1rcv"]
        r["ratio_1rcv_1t"] = r["rays_per_s_1rcv"]["1"] / res["pra_rays_per_s_1rcv"]
        r["ratio_subset_2t"] = r["rays_per_s_subset_2t"] / res["pra_rays_per_s_subset"]
        r["ratio_full_2t"] = full2 / res["pra_rays_per_s_full_extrapolated"]
        log(f"  sonolux {est:>5}: 1 receiver {r['rays_per_s_1rcv']['2']:,.0f} rays/s (2T), "
            f"{r['rays_per_s_1rcv']['1']:,.0f} (1T); {len(subset)} receivers ({n_sub:,} rays) "
            f"{r['rays_per_s_subset_2t']:,.0f} (2T); ratios to pyroomacoustics: 1 rcv "
            f"{r['ratio_1rcv_2t']:.2f} (2T) {r['ratio_1rcv_1t']:.2f} (1T), "
            f"subset {r['ratio_subset_2t']:.2f}, full grid {r['ratio_full_2t']:.2f}")
        res["sonolux"][est] = r
    log(f"  T30 at the one receiver (sanity, mean of bands): pyroomacoustics {res['pra_t30_1rcv_s']:.3f} s, "
        + ", ".join(f"sonolux {e} {res['sonolux'][e]['t30_1rcv_s']:.3f} s" for e in ESTIMATORS))
    return res


# --------------------------------------------------------------------------- 3: time to accuracy


def accuracy(name: str, scene, paper_net_rate: float, ref_seconds: float, caps: dict) -> dict:
    """Time for each estimator until T30 is within T30_TOL of a reference at every receiver and
    band, at two checks in a row. Air absorption as the scene says (on)."""
    n_ref = int(round(ref_seconds * paper_net_rate, -4))
    log(f"{name}: accuracy reference, estimator paper, {n_ref:,} rays, seed {REF_SEED}, 2 threads")
    ref_field = bake(with_seed(scene, REF_SEED), n_ref, "paper", 2, air_absorption=True)
    ref = t30(omni(ref_field), ref_field)
    res = {"room": name, "receivers": scene.receivers.count, "bands_hz": list(scene.settings.bands_hz),
           "tolerance": T30_TOL, "reference": {"estimator": "paper", "rays": n_ref, "seed": REF_SEED,
                                               "seconds": ref_field.stats["seconds"],
                                               "t30_mean_by_band_s": np.nanmean(ref, axis=0).tolist(),
                                               "nan": int(np.isnan(ref).sum())},
           "estimators": {}}
    log(f"  reference: {ref_field.stats['seconds']:.1f} s; T30 by band (mean of receivers) "
        + " ".join(f"{v:.2f}" for v in np.nanmean(ref, axis=0)) + " s")
    for est in ESTIMATORS:
        res["estimators"][est] = search(scene, est, ref, caps[est])
    return res


def search(scene, est: str, ref: np.ndarray, cap_s: float) -> dict:
    """Ray ranges of one bake of PROGRESSIVE_RAYS rays, traced in growing chunks. Chunk 0 is
    ray 0 alone: its time is the bake's fixed cost (and, for rain, it holds the exact direct
    sound, which the later ranges leave out). After N rays the estimate is chunk 0 + the later
    chunks scaled to N - 1 rays' worth, and its time that of one bake of N rays: the chunks'
    seconds less the fixed cost of every chunk but one."""
    R = PROGRESSIVE_RAYS
    f0 = bake(scene, R, est, 2, air_absorption=True, ray_range=(0, 1))
    e0, setup = omni(f0), f0.stats["seconds"]
    acc = np.zeros_like(e0)
    done, spent, t_equiv, checks, passed_at = 1, setup, setup, [], None
    target = START_RAYS[est]
    log(f"  {est}: growing from {target:,} rays by x{GROWTH} (fixed cost {setup:.2f} s per chunk)")
    while True:
        f = bake(scene, R, est, 2, air_absorption=True, ray_range=(done, target))
        acc += omni(f)
        dt = f.stats["seconds"]
        spent += dt
        t_equiv += max(dt - setup, 0.0)
        done = target
        t = t30(e0 + acc * (R / (done - 1)), f0)
        err = np.abs(t / ref - 1)
        worst = float(np.nanmax(np.where(np.isnan(err), np.inf, err)))
        ok = worst <= T30_TOL
        checks.append({"rays": done, "seconds": t_equiv, "max_rel_err": worst,
                       "max_finite_rel_err": float(np.nanmax(err)) if np.isfinite(err).any() else math.inf,
                       "nan": int(np.isnan(err).sum()),
                       "median_rel_err": float(np.nanmedian(err)),
                       "within": float(np.mean(err <= T30_TOL))})
        log(f"    {done:>10,} rays {t_equiv:6.1f} s: T30 max err {worst * 100:5.2f} %, median "
            f"{np.nanmedian(err) * 100:.2f} %, {np.mean(err <= T30_TOL) * 100:5.1f} % within"
            + (f", {int(np.isnan(err).sum())} NaN" if np.isnan(err).any() else ""))
        if ok and passed_at is None:
            passed_at = len(checks) - 1
        elif not ok:
            passed_at = None
        if passed_at is not None and len(checks) - 1 > passed_at:
            break  # two checks in a row within tolerance
        target = int(math.ceil(done * GROWTH))
        rate = (done - 1) / max(t_equiv - setup, 1e-9)
        if spent + setup + (target - done) / rate > cap_s:
            break  # the next chunk would end past the cap
    net_rate = (done - 1) / max(t_equiv - setup, 1e-9)
    out = {"checks": checks, "cap_s": cap_s, "spent_s": spent, "net_rays_per_s": net_rate,
           "fixed_cost_s": setup}
    if passed_at is not None:  # confirmed: the next check passed too (not when the cap came first)
        c = checks[passed_at]
        confirmed = len(checks) - 1 > passed_at
        out.update(reached=True, confirmed=confirmed, rays=c["rays"], seconds=c["seconds"])
        log(f"  {est}: T30 within {T30_TOL:.0%} everywhere after {c['rays']:,} rays, {c['seconds']:.1f} s"
            + ("" if confirmed else " (not confirmed by a second check: the cap came first)"))
    else:
        last = checks[-1]
        # the largest finite error (a T30 that cannot be fitted yet is NaN) scaled as 1/sqrt(N)
        finite = last["max_finite_rel_err"]
        need = (max(last["rays"] * (finite / T30_TOL) ** 2, last["rays"]) if math.isfinite(finite)
                else math.inf)
        out.update(reached=False, rays=None, seconds=None, lower_bound_s=last["seconds"],
                   extrapolated_rays=need, extrapolated_s=setup + need / net_rate)
        log(f"  {est}: NOT within {T30_TOL:.0%} everywhere by {last['rays']:,} rays "
            f"({last['seconds']:.1f} s, cap {cap_s:.0f} s); its largest finite error "
            f"{finite * 100:.1f} % ~ 1/sqrt(N) extrapolates to ~{need:,.0f} rays, "
            f"~{out['extrapolated_s']:,.0f} s")
    return out


# --------------------------------------------------------------------------- report


def fmt_rate(v: float | None) -> str:
    if v is None:
        return "-"
    return f"{v / 1e6:.2f}M" if v >= 1e6 else (f"{v / 1e3:.1f}k" if v >= 1e3 else f"{v:.0f}")


def print_tables(rooms: dict, peer: dict | None) -> None:
    print()
    hdr = (f"{'room':<13}{'rcv':>4} {'est':<6}{'rays':>9} | {'1T rays/s':>9} {'2T rays/s':>9} {'x2T':>5} "
           f"{'2T seg/s':>8} {'hits/ray':>8} {'dep/ray':>8} | {'MB/rcv':>6}")
    print("sonolux, full receiver grid (air absorption off)")
    print(hdr)
    print("-" * len(hdr))
    for name, r in rooms.items():
        for est, e in r["estimators"].items():
            print(f"{name:<13}{r['receivers']:>4} {est:<6}{e['rays']:>9,} | "
                  f"{fmt_rate(e['rays_per_s']['1']):>9} {fmt_rate(e['rays_per_s']['2']):>9} "
                  f"{e['thread_speedup']:>5.2f} "
                  f"{fmt_rate(e['segments_per_s']['2']):>8} {e['surface_hits_per_ray']:>8.1f} "
                  f"{e['deposits_per_ray']:>8,.0f} | {r['bytes_per_receiver'] / 1e6:>6.2f}")
    if not peer:
        return
    print()
    print("against pyroomacoustics (1 thread; rays/s; ratio = sonolux / pyroomacoustics, "
          "> 1: sonolux faster)")
    hdr = (f"{'room':<13}{'est':<6}{'rays':>8} | {'1 rcv: sono 2T':>14} {'pra':>7} {'ratio':>6} "
           f"{'1T ratio':>8} | {SUBSET} rcv: {'sono 2T':>7} {'pra':>7} {'ratio':>6} | "
           f"{'grid: sono 2T':>13} {'pra*':>7} {'ratio':>6} | pra hits/ray")
    print(hdr)
    print("-" * len(hdr))
    for name, p in peer.items():
        for est, s in p["sonolux"].items():
            full = rooms[name]["estimators"][est]["rays_per_s"]["2"]
            print(f"{name:<13}{est:<6}{p['rays']:>8,} | {fmt_rate(s['rays_per_s_1rcv']['2']):>14} "
                  f"{fmt_rate(p['pra_rays_per_s_1rcv']):>7} {s['ratio_1rcv_2t']:>6.2f} "
                  f"{s['ratio_1rcv_1t']:>8.2f} | {'':>8}{fmt_rate(s['rays_per_s_subset_2t']):>7} "
                  f"{fmt_rate(p['pra_rays_per_s_subset']):>7} {s['ratio_subset_2t']:>6.2f} | "
                  f"{fmt_rate(full):>13} {fmt_rate(p['pra_rays_per_s_full_extrapolated']):>7} "
                  f"{s['ratio_full_2t']:>6.2f} | "
                  f"{p['pra_hits_per_ray_replica']:.0f}")
    print("pra* = pyroomacoustics on the full grid, extrapolated from its 1- and "
          f"{SUBSET}-receiver runs (cost per ray = a + b x receivers); it was not run on the full grid.")
    ratios = {(name, est): s["ratio_1rcv_2t"] for name, p in peer.items() for est, s in p["sonolux"].items()}
    print(f"target (issue 15): one receiver, sonolux 2T >= {TARGET_1RCV_RATIO:g}x pyroomacoustics 1T: "
          + ", ".join(f"{n} {e} {v:.2f}x" for (n, e), v in ratios.items())
          + (": met" if min(ratios.get((n, "paper"), 0.0) for n in peer) >= TARGET_1RCV_RATIO
             else ": NOT met (paper estimator)"))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate-seconds", type=float, default=2.5,
                    help="target length of each 2-thread rate bake (2.5 s)")
    ap.add_argument("--peer-seconds", type=float, default=1.0,
                    help="target length of the peer's one-receiver run (1 s)")
    ap.add_argument("--ref-seconds", type=float, default=80.0,
                    help="length of the accuracy reference bake (80 s)")
    ap.add_argument("--cap-paper", type=float, default=70.0, help="accuracy search cap, paper (70 s)")
    ap.add_argument("--cap-rain", type=float, default=30.0, help="accuracy search cap, rain (30 s)")
    ap.add_argument("--accuracy-room", default="paper-medium", choices=ROOMS)
    ap.add_argument("--budget", choices=("full", "slope", "skip"), default="full",
                    help="48 M rays of paper-large, air on and off: traced (full, the default, "
                         "about 7 minutes idle), from the line through two long bakes (slope), or not")
    ap.add_argument("--no-install", action="store_true", help="never pip-install the peer")
    ap.add_argument("--no-peer", action="store_true", help="skip pyroomacoustics")
    ap.add_argument("--no-accuracy", action="store_true", help="skip the time-to-accuracy part")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "sound.json")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    busy_start = other_cpu_use()

    pra, peer_note = (None, "skipped (--no-peer)") if args.no_peer else load_pra(not args.no_install)
    log(f"peer pyroomacoustics: {peer_note}"
        + (f" (version {_dist_version('pyroomacoustics')})" if pra else ""))
    if pra is None and not args.no_peer:
        log(f"WARNING: no peer, only sonolux's own numbers ({peer_note})")

    scenes = {name: sonolux.load_scene(name) for name in ROOMS}
    rooms = {name: measure_sonolux(name, s, args.rate_seconds) for name, s in scenes.items()}
    peer = ({name: measure_peer(pra, name, s, rooms[name], args.peer_seconds, args.rate_seconds)
             for name, s in scenes.items()} if pra else None)

    acc = None
    if not args.no_accuracy:
        a = args.accuracy_room
        acc = accuracy(a, scenes[a], rooms[a]["estimators"]["paper"]["net_rays_per_s_2t"],
                       args.ref_seconds, {"paper": args.cap_paper, "rain": args.cap_rain})
        largest = max(c["rays"] for c in acc["estimators"]["paper"]["checks"])
        acc["reference"]["rays_over_largest_paper_tested"] = acc["reference"]["rays"] / largest

    # the paper's budget: 48 M rays in paper-large (part 4, sound_budget.py), and the estimate
    # from part 1's rates beside it (what this benchmark printed before it traced them)
    large = rooms["paper-large"]
    budget = {"paper_rays": PAPER_RAYS, "paper_hours": PAPER_HOURS, "from_rate": {}}
    for est, e in large["estimators"].items():
        t = large["setup_s"] + PAPER_RAYS / e["net_rays_per_s_2t"]
        budget["from_rate"][est] = {"seconds_48M_2t": t, "speedup": PAPER_HOURS * 3600 / t}
    t = large["setup_s"] + PAPER_RAYS / large["paper_air_on"]["net_rays_per_s_2t"]
    budget["from_rate"]["paper_air_on"] = {"seconds_48M_2t": t}
    if args.budget != "skip":
        budget["measured"] = paper_budget(scenes["paper-large"], args.budget, TARGET_48M_S)

    print_tables(rooms, peer)
    print()
    for est, b in budget["from_rate"].items():
        t = b["seconds_48M_2t"]
        print(f"48 M rays in paper-large, {est.replace('_', ' ')}, estimated from part 1's "
              f"2-thread rate: ~{t / 60:,.1f} min")
    if "measured" in budget:
        print("\n".join(describe(budget["measured"], PAPER_HOURS)))
    if acc:
        ref = acc["reference"]
        print(f"time to T30 within {T30_TOL:.0%} of the reference ({acc['room']}, all "
              f"{acc['receivers']} receivers x {len(acc['bands_hz'])} bands, air on; reference: "
              f"paper estimator, {ref['rays']:,} rays = "
              f"{ref['rays_over_largest_paper_tested']:.1f}x the largest paper count tested):")
        for est, r in acc["estimators"].items():
            last = r["checks"][-1]
            print(f"  {est:>5}: " + (f"{r['seconds']:.1f} s ({r['rays']:,} rays)" if r["reached"] else
                                     f"not reached in {r['lower_bound_s']:.1f} s ({last['rays']:,} rays, "
                                     f"largest finite error {last['max_finite_rel_err'] * 100:.1f} %); "
                                     f"extrapolated ~{r['extrapolated_s']:,.0f} s"))
        times = {e: (r["seconds"] if r["reached"] else math.inf) for e, r in acc["estimators"].items()}
        if all(math.isinf(v) for v in times.values()):
            winner = min(acc["estimators"], key=lambda e: acc["estimators"][e]["extrapolated_s"])
            line = "neither reached 2 % within its cap; by extrapolation: " + winner
        else:
            winner = min(times, key=times.get)
            loser = [e for e in times if e != winner][0]
            lr = acc["estimators"][loser]
            other = (f"{lr['seconds']:.1f} s" if lr["reached"] else
                     f"> {lr['lower_bound_s']:.1f} s, ~{lr['extrapolated_s']:,.0f} s extrapolated")
            line = f"{winner} ({times[winner]:.1f} s vs {other})"
        acc["faster"] = winner
        print(f"faster to 2% T30: {line}")
    busy_end = other_cpu_use()
    if max(busy_start, busy_end) > 0.15:
        print(f"WARNING: other processes kept {busy_start:.0%} of the CPUs busy at the start, "
              f"{busy_end:.0%} at the end: the rates are noisy, run again on an idle machine.")
    elapsed = time.perf_counter() - t_start
    data = {
        "benchmark": "sound",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "sonolux_version": getattr(sonolux, "__version__", "?"),
        "peer": ({"name": "pyroomacoustics", "version": _dist_version("pyroomacoustics"), "note": peer_note,
                  "counts_rays": "per source (every ray is tested against every microphone)",
                  "timed": "room.ray_tracing() only, 1 thread"} if pra else None),
        "machine": {"platform": platform.platform(), "python": platform.python_version(),
                    "cpus": os.cpu_count(), "other_cpu_use_start_end": [busy_start, busy_end]},
        "settings": {"rate_seconds": args.rate_seconds, "budget": args.budget,
                     "peer_seconds": args.peer_seconds,
                     "ref_seconds": args.ref_seconds,
                     "caps_s": {"paper": args.cap_paper, "rain": args.cap_rain},
                     "threads": list(THREAD_COUNTS), "subset": SUBSET, "energy_thres": ENERGY_THRES,
                     "hist_bin_s": HIST_BIN_S, "t30_tolerance": T30_TOL, "growth": GROWTH,
                     "air_absorption": "off for rates and the peer, on for paper_air_on and time "
                                       "to accuracy"},
        "elapsed_s": elapsed,
        "rooms": rooms,
        "peer_results": peer,
        "accuracy": acc,
        "paper_budget": budget,
    }
    write_json(args.out, data)
    log(f"wrote {args.out} ({elapsed:.0f} s in all)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
