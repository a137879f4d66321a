"""Hybrid early sound benchmark: EDT and C80 noise of the hybrid bake (image sources + particles)
against pure particles at equal wall time.

Run with ``make bench`` or ``.venv/bin/python benchmarks/early.py``. See benchmarks/README.md.

Scenes (``--scene``; ``make bench`` runs both): ``l-room`` (the default),
examples/l-room/l-room.toml, an L-shaped classroom with tables, chairs and a cabinet, 652
triangles, four listeners, one around the corner; ``shoebox``, examples/scenes/shoebox.toml, a
7 × 5 × 2.8 m meeting room with library materials, a presenter's cone source and a 35-point
listener grid at ear height (examples/ holds no other shoebox scene; the early tests' 5 × 4 × 3 m
box is built in code with two bands and no scattering, a fixture, not a room). Each scene is
baked as it is written. The hybrid adds ``[early]`` with ``max_order`` 3 and the automatic
transition (the mixing time 20 V/S + 12 ms); the peer is the same scene baked by particles
alone, in the same run.

Equal wall time: the hybrid is baked with --rays rays (default: the bake's own automatic count,
sonolux.sound.bake.auto_rays: what a user gets); the particles get as many more rays as the
hybrid's extra work (image sources, diffraction, visibility) costs: the ratio of the median wall
times of the hybrid's bakes and of the particles' bakes at the same rays, baked in turn seed by
seed (so a change of the machine's load falls on both; one bake each, as before, once gave the
particles the longer time on a loaded machine). Each is baked with --seeds seeds; the noise of
EDT and C80 is their standard deviation across seeds, per listener and octave band. The result
is the ratio particles / hybrid (above 1: the hybrid is less noisy at equal time), per listener
and its median over listeners per band, with both sides' numbers and their means (the means must
agree within the noise: the hybrid counts nothing twice). Each ratio of two standard deviations
from n seeds has a sampling spread: its 68 % interval from the F distribution with
(n − 1, n − 1) degrees of freedom is printed (with 6 seeds it is 0.73–1.37 for a true ratio of
1: the old 6-seed table could not tell 0.70 from 0.50). Results go to
benchmarks/results/early.json (the L-room) and early-shoebox.json.

The responses are baked for at least 2.5 s: EDT needs the decay 20 dB below its −10 dB point
inside the record (sonolux.analysis.decay), which 1.2 s did not give in the L-room at 125–500 Hz
(EDT undefined in some seeds, so the old table's low-band ratios came from a few seeds). A room
whose slowest band decays longer gets 0.6 × that band's Eyring T60 (an exponential decay leaves
−30 dB of its energy after T60 / 2; 0.6 leaves −36 dB, room for a decay slower than Eyring's):
the shoebox's 125 Hz band (Eyring 8.0 s) needs 4.8 s; ``--max-time`` sets it.

Where the noise comes from (docs/early-noise.md): the share of each
listener's first 80 ms that the image sources hold (deterministic) is reported too, and the
ratios' medians are printed for the listeners grouped by that share (below 20 %, 20-50 %, 50 %
and above: fixed bounds, the same for every scene). Paired (same seeds, same rays) the hybrid's
particles are exactly as noisy as the particles alone wherever the image sources hold little of
that energy; in the L-room only the listener near the talker gains.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import tomllib
from common import machine_and_load, other_cpu_use, write_json
from scipy import stats

import sonolux
from sonolux.analysis.decay import c80, decay_times
from sonolux.scene.summary import theory
from sonolux.sound.bake import auto_rays, bake, bake_arrays
from sonolux.sound.options import SoundOptions

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
#: --scene: name -> scene file, baked as written (plus ``[early]`` for the hybrid).
SCENES = {"l-room": EXAMPLES / "l-room" / "l-room.toml",
          "shoebox": EXAMPLES / "scenes" / "shoebox.toml"}
#: Listener groups by the image sources' share of the first 80 ms (mean over bands).
SHARE_GROUPS = ((0.0, 0.2), (0.2, 0.5), (0.5, 1.01))


def load(room: Path, early: bool, seed: int, connections: bool = False):
    data = tomllib.loads(room.read_text())
    for g in data["geometry"]:
        if "file" in g:
            g["file"] = str(room.parent / g["file"])
    data.setdefault("settings", {})["seed"] = seed
    if early:
        data["early"] = {"max_order": 3, "diffuse_connections": connections}
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


class Runs:
    """EDT, C80 ([seed][listener, band]) and wall times (s) of one kind of bake over seeds."""

    def __init__(self):
        self.edt, self.c80, self.seconds = [], [], []

    def bake(self, room: Path, early: bool, rays: int, seed: int, max_time_s: float,
             connections: bool = False):
        sc = load(room, early, seed, connections)
        started = time.perf_counter()
        field = bake(sc, rays=rays, max_time_s=max_time_s)
        self.seconds.append(time.perf_counter() - started)
        a, b = measures(field, sc)
        self.edt.append(a)
        self.c80.append(b)
        return field, sc


def by_share(share: np.ndarray, ratios: dict[str, np.ndarray], bands: list[float]) -> list:
    """The ratios' medians per band over the listeners in each of SHARE_GROUPS (grouped by the
    image sources' share of the first 80 ms, mean over bands); printed and returned."""
    mean_share = share.mean(axis=1)
    out = []
    for lo, hi in SHARE_GROUPS:
        members = np.flatnonzero((mean_share >= lo) & (mean_share < hi))
        row = {"share_from": lo, "share_to": min(hi, 1.0), "listeners": members.tolist()}
        if members.size:
            for key, r in ratios.items():
                row[key] = np.nanmedian(r[members], axis=0).tolist()
            print(f"  listeners with {lo:.0%}-{min(hi, 1.0):.0%} image share ({members.size}): "
                  + "; ".join(f"{key} " + " ".join(f"{v:.2f}" for v in row[key])
                              for key in ratios) + f" (bands {', '.join(f'{b:g}' for b in bands)} Hz)")
        out.append(row)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="l-room",
                    help=f"which scene (default l-room; one of {', '.join(SCENES)})")
    ap.add_argument("--rays", type=int, default=0,
                    help="the hybrid's rays a bake (default 0: the bake's automatic count)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--max-time", type=float, default=0.0,
                    help="s of response baked (default 0: the longer of 2.5 s and 0.6 × the "
                    "slowest band's Eyring T60)")
    ap.add_argument("--out", type=Path, default=None,
                    help="results file (default results/early.json, early-<scene>.json for others)")
    args = ap.parse_args()
    if args.scene not in SCENES:
        ap.error(f"--scene: {args.scene!r} is not a scene of this benchmark; "
                 f"allowed: {', '.join(SCENES)}")
    if args.rays < 0:
        ap.error(f"--rays: {args.rays}; allowed: 0 (automatic) or a positive count")
    if args.seeds < 3:
        ap.error(f"--seeds: {args.seeds} gives no usable spread; allowed: 3 or more")
    if not args.max_time >= 0:
        ap.error(f"--max-time: {args.max_time} s; allowed: 0 (automatic) or a length above 0 s")
    room = SCENES[args.scene]
    if args.out is None:
        name = "early.json" if args.scene == "l-room" else f"early-{args.scene}.json"
        args.out = Path(__file__).parent / "results" / name
    print(f"scene {args.scene}: {room}")
    if args.max_time == 0:
        eyring = [t for t in theory(load(room, False, 1))["eyring_t60_s"] if t is not None]
        args.max_time = round(max([2.5] + [0.6 * t for t in eyring]), 1)
        print(f"responses {args.max_time} s long (0.6 × the slowest band's Eyring T60 "
              f"{max(eyring, default=0):.2f} s, at least 2.5 s)")
    busy_start = other_cpu_use()
    if args.rays <= 0:
        sc = load(room, False, 1)
        args.rays, why = auto_rays(sc, SoundOptions(), bake_arrays(sc, SoundOptions()))
        print("hybrid rays:", why)
    # The hybrid and the particles at the hybrid's rays, seed by seed in turn (paired: same
    # seeds, so the same rays: the noise per ray, without the spread of two sets of seeds);
    # their median wall times give the particles' rays for equal time.
    # The hybrid as the scene bakes it (early diffuse connections off by default), and with
    # them too (same seeds): what they change.
    hybrid, paired, connected = Runs(), Runs(), Runs()
    for seed in range(1, args.seeds + 1):
        field, sc = hybrid.bake(room, True, args.rays, seed, args.max_time)
        if seed == 1:
            share = image_share(field, sc)
            print("share of the first 80 ms held by the image sources [listener, band]:\n",
                  np.round(share, 3))
        paired.bake(room, False, args.rays, seed, args.max_time)
        connected.bake(room, True, args.rays, seed, args.max_time, connections=True)
    hybrid_s, particles_s = np.median(hybrid.seconds), np.median(paired.seconds)
    connected_s = float(np.median(connected.seconds))
    print(f"median bake of {args.rays} rays: hybrid with early diffuse connections "
          f"{connected_s:.2f} s")
    rays_particles = int(round(args.rays * hybrid_s / particles_s))
    print(f"median bake of {args.rays} rays: hybrid {hybrid_s:.2f} s, particles "
          f"{particles_s:.2f} s; particles get {rays_particles} rays for equal time")
    if hybrid_s < particles_s:
        print("WARNING: the hybrid's bakes took less time than the particles' at the same rays: "
              "the machine's load changed during the run; the equal-time ratios are biased")
    equal_time = Runs()
    for seed in range(1, args.seeds + 1):
        equal_time.bake(room, False, rays_particles, seed, args.max_time)
    h_edt, h_c80, h_s = hybrid.edt, hybrid.c80, float(np.mean(hybrid.seconds))
    p_edt, p_c80, p_s = equal_time.edt, equal_time.c80, float(np.mean(equal_time.seconds))
    q_edt, q_c80 = paired.edt, paired.c80
    bands = [float(b) for b in load(room, False, 1).settings.bands_hz]
    result = {"scene": args.scene, "room": room.name, "rays_hybrid": args.rays,
              "rays_particles": rays_particles,
              "seeds": args.seeds, "mean_seconds_hybrid": h_s, "mean_seconds_particles": p_s,
              "bands_hz": bands, "image_share_first_80ms": share.tolist(),
              "median_seconds_hybrid": float(hybrid_s),
              "median_seconds_particles_at_hybrid_rays": float(particles_s),
              "median_seconds_hybrid_with_connections": connected_s,
              "max_time_s": args.max_time}
    # A ratio of two standard deviations of n values each: sqrt(F(n-1, n-1)), 16th-84th %.
    dof = args.seeds - 1
    spread = np.sqrt(stats.f.ppf([0.16, 0.84], dof, dof))
    result["ratio_68_percent_interval_for_true_ratio_1"] = spread.tolist()
    print(f"a ratio of two standard deviations over {args.seeds} seeds: 68 % of them fall in "
          f"{spread[0]:.2f}–{spread[1]:.2f} × the true ratio")
    grouped = {}
    # An EDT undefined in every seed (NaN) is counted and printed below, not warned about.
    for text in ("All-NaN slice", "Mean of empty slice", "Degrees of freedom"):
        warnings.filterwarnings("ignore", message=text, category=RuntimeWarning)
    for name, h, p, q, u in (("edt_s", h_edt, p_edt, q_edt, connected.edt),
                             ("c80_db", h_c80, p_c80, q_c80, connected.c80)):
        h, p, q, u = np.asarray(h), np.asarray(p), np.asarray(q), np.asarray(u)
        paired = np.nanstd(q, axis=0, ddof=1) / np.nanstd(h, axis=0, ddof=1)
        # [seed, listener, band]; the connections' own effect per ray (same seeds): the
        # noise without them over the noise with them.
        connections = np.nanstd(h, axis=0, ddof=1) / np.nanstd(u, axis=0, ddof=1)
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
                        "equal_rays_paired_ratio": paired.tolist(),
                        "mean_hybrid_with_connections": np.nanmean(u, axis=0).tolist(),
                        "connections_paired_ratio": connections.tolist()}
        print(f"{name}: noise ratio particles / hybrid (median over listeners) per band "
              + ", ".join(f"{b:g} Hz {r:.2f}" for b, r in zip(bands, ratio)))
        print("  per listener [listener, band]:\n", np.round(per_listener, 2))
        print("  at equal rays, same seeds (noise per ray) [listener, band]:\n", np.round(paired, 2))
        print(f"  std hybrid {np.round(np.nanmedian(sh, axis=0), 4).tolist()}, "
              f"std particles {np.round(np.nanmedian(sp, axis=0), 4).tolist()}")
        undefined = int(np.isnan(h).sum() + np.isnan(p).sum())
        if undefined:
            print(f"  {undefined} values undefined (NaN: see sonolux.analysis.decay's reasons)")
        print("  hybrid without / with early diffuse connections, same seeds and rays [listener, "
              "band]:\n", np.round(connections, 2))
        grouped[name] = by_share(share, {"equal time": per_listener, "paired": paired,
                                         "connections paired": connections}, bands)
    result["by_image_share"] = grouped
    result["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(args.out, result)
    print(f"results in {args.out}")


if __name__ == "__main__":
    main()
