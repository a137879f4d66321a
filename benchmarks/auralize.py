"""Auralization benchmark: real-time factors of a 30 s walk-through, and the block renderer's
cost per block, on one thread.

Run with ``.venv/bin/python benchmarks/auralize.py`` (see benchmarks/README.md). The large paper
room (24 x 10 x 8 m, T60 about 2.6 s) is baked once (sound only, 5000 rays with the rain
estimator: a few minutes on 2 cores; ``--rays`` for more) and cached in benchmarks/.cache/
(git-ignored). Its responses are used at full length, every time bin of the field (4.2 s at
48 kHz), so the ray count changes their noise, not the cost measured here.

1. The walk: builtin:speech along a 36 m path at 1.2 m/s (30 s, straight legs and three
   turns), rendered binaural, cube8 and third-order ambisonics with the offline block. The
   responses of the cells on the path are synthesised first and timed apart ("prepare"): a live
   application would synthesise them ahead of the listener. Each walk is rendered 5 times
   (fresh renderers, prepared cells shared) and the median kept. RTF = seconds of audio written
   (walk + tail) / seconds of rendering, with and without the preparation.
2. The peer: scipy.signal.fftconvolve of the same 8 direction responses of one cell with the
   whole 30 s signal (the plain offline way, no walk, no spatialization; median of 3 runs),
   against our static rendering of that cell and against each walk. The ratio is what
   counts: both run here, now, on one thread.
3. Streaming: StreamRenderer at blocks of 64 to 1024 samples; the median and the 99th
   percentile cost of one block against its duration (load = cost / duration; below 1 keeps
   up with a live device), binaural with a still and with a turning head, and cube8.

Results go to benchmarks/results/auralize.json.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # one thread, set before numpy loads BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy import fft as sfft  # noqa: E402
from scipy.signal import fftconvolve  # noqa: E402

import sonolux  # noqa: E402
from sonolux.auralize.convolve import cell_responses  # noqa: E402
from sonolux.auralize.offline import AuralizeSettings, auralize  # noqa: E402
from sonolux.auralize.signals import builtin  # noqa: E402
from sonolux.auralize.stream import StreamRenderer  # noqa: E402
from sonolux.auralize.walk import (  # noqa: E402
    CONTROL_HZ,
    WalkPath,
    WalkSettings,
    auralize_walk,
    cell_schedule,
    sample_path,
)
from sonolux.outputs import follow_umask  # noqa: E402

HERE = Path(__file__).resolve().parent
CACHE = HERE / ".cache" / "paper-large.h5"
WAYPOINTS = [(4.0, 3.0), (20.0, 3.0), (20.0, 7.0), (6.0, 7.0), (6.0, 5.0)]  # 36 m
SPEED = 1.2
LAYOUTS = [("binaural", 1), ("cube8", 1), ("ambisonics", 3)]
STREAM_BLOCKS = (64, 128, 256, 512, 1024)
REPEATS = 5  # renderings of each walk; the median is reported


def log(msg: str) -> None:
    print(f"[auralize {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def the_field(rays: str):
    if not CACHE.exists():
        CACHE.parent.mkdir(parents=True, exist_ok=True)
        log(f"baking paper-large ({rays} rays) into {CACHE} once; later runs reuse it")
        subprocess.run([sys.executable, "-m", "sonolux.cli", "bake", "paper-large", "-o",
                        str(CACHE), "--rays", rays, "--no-light", "-q"], check=True)
    return sonolux.open(CACHE)


def the_path() -> WalkPath:
    xy = np.array(WAYPOINTS)
    t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1)) / SPEED])
    return WalkPath(t, xy, None, "benchmark walk")


def walk_cells(field, path: WalkPath, fade_s: float) -> list[int]:
    xy, _ = sample_path(path, CONTROL_HZ, int(path.duration_s * CONTROL_HZ) + 1, 0.0)
    return [r for _, r in cell_schedule(field, xy, CONTROL_HZ, WalkSettings(), fade_s)]


def bench_walk(field, path, dry, block: int) -> dict:
    settings = AuralizeSettings(block=block)
    cells = walk_cells(field, path, settings.fade_s)
    responses: dict = {}
    t0 = time.perf_counter()
    for r in cells:
        responses[(r, settings.seed)] = cell_responses(field, r, settings.seed)
    synth_s = time.perf_counter() - t0
    log(f"walk: {len(cells)} cells, responses {responses[(cells[0], 0)].shape} float32 "
        f"synthesised in {synth_s:.1f} s ({synth_s / len(cells):.2f} s a cell)")
    out = {"cells": len(cells), "synthesis_s": synth_s, "layouts": {}}
    for layout, order in LAYOUTS:
        s = AuralizeSettings(layout=layout, order=order, block=block)
        prepared = StreamRenderer(field, layout, block, order=order, responses=responses,
                                  cache_cells=len(cells))
        t0 = time.perf_counter()
        prepared.prepare(cells)
        partition_s = time.perf_counter() - t0
        # The walk is rendered REPEATS times, each by a fresh renderer (cold HRIR and folding
        # caches) given the prepared cells; the median run is reported: one run of under a
        # second varies by +-30 % on a shared virtual machine.
        runs = []
        for _ in range(REPEATS):
            renderer = StreamRenderer(field, layout, block, order=order, responses=responses,
                                      cache_cells=len(cells))
            renderer.cells = prepared.cells
            t0, c0 = time.perf_counter(), time.process_time()
            y, info = auralize_walk(field, dry, path, s, renderer=renderer)
            runs.append((time.perf_counter() - t0, time.process_time() - c0))
        render_s, cpu_s = (float(np.median([r[k] for r in runs])) for k in (0, 1))
        audio_s = y.shape[0] / field.sample_rate_hz
        row = {"audio_s": audio_s, "render_s": render_s, "render_cpu_s": cpu_s,
               "render_s_runs": [r[0] for r in runs],
               "partition_s": partition_s, "rtf_render": audio_s / render_s,
               "rtf_render_cpu": audio_s / cpu_s,
               "rtf_with_partition": audio_s / (render_s + partition_s),
               "rtf_with_synthesis": audio_s / (render_s + partition_s + synth_s)}
        out["layouts"][f"{layout}{order if layout == 'ambisonics' else ''}"] = row
        log(f"walk {layout:10s}: {audio_s:.1f} s of audio in {render_s:.2f} s (median of "
            f"{REPEATS}; {min(r[0] for r in runs):.2f} to {max(r[0] for r in runs):.2f} s): "
            f"{row['rtf_render']:.0f}x real time (filters ready; {row['rtf_render_cpu']:.0f}x per CPU "
            f"second); {row['rtf_with_partition']:.0f}x "
            f"with their FFTs ({partition_s:.2f} s); {row['rtf_with_synthesis']:.1f}x with the "
            f"synthesis too")
    return out


def bench_peer(field, dry, block: int) -> dict:
    r = field.cell_at(12.0, 5.0)
    h = cell_responses(field, r, 0)
    # The median of 3 runs: the first one also pays for page faults and FFT planning.
    runs = []
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.process_time()
        ref = fftconvolve(dry[None, :], h, axes=-1)
        runs.append((time.perf_counter() - t0, time.process_time() - c0))
    peer_s, peer_cpu = (float(np.median([r[k] for r in runs])) for k in (0, 1))
    out = {"peer": "scipy.signal.fftconvolve, 8 directions, whole signal",
           "peer_s": peer_s, "peer_cpu_s": peer_cpu, "audio_s": ref.shape[1] / field.sample_rate_hz,
           "ours": {}}
    responses = {(r, 0): h}
    for layout in ("cube8", "binaural"):
        renderer = StreamRenderer(field, layout, block, responses=responses)
        renderer.prepare([r])
        t0, c0 = time.perf_counter(), time.process_time()
        auralize(field, dry, (12.0, 5.0), 0.0, AuralizeSettings(layout=layout, block=block),
                 renderer=renderer)
        ours, ours_cpu = time.perf_counter() - t0, time.process_time() - c0
        out["ours"][layout] = {"seconds": ours, "cpu_s": ours_cpu,
                               "speedup_vs_peer": peer_s / ours,
                               "cpu_speedup_vs_peer": peer_cpu / ours_cpu}
        log(f"static {layout:8s} at the centre: {ours:.2f} s ({ours_cpu:.2f} CPU s); fftconvolve "
            f"of its 8 responses {peer_s:.2f} s ({peer_cpu:.2f} CPU s): ours is "
            f"{peer_s / ours:.1f}x faster ({peer_cpu / ours_cpu:.1f}x in CPU time)")
    return out


def bench_stream(field, seconds: float = 1.5) -> dict:
    out = {}
    fs = field.sample_rate_hz
    r = field.cell_at(12.0, 5.0)
    responses = {(r, 0): cell_responses(field, r, 0)}
    rng = np.random.default_rng(0)
    for block in STREAM_BLOCKS:
        for case, layout, turn in (("binaural still", "binaural", 0.0),
                                   ("binaural turning 90°/s", "binaural", 90.0),
                                   ("cube8 still", "cube8", 0.0)):
            rend = StreamRenderer(field, layout, block, responses=responses)
            rend.set_cell(r)
            n = max(40, int(seconds * fs / block))
            x = rng.standard_normal(block).astype(np.float32)
            costs = []
            heading = 0.0
            for i in range(n + 5):
                heading += turn * block / fs
                t0 = time.perf_counter()
                rend.process(x, heading)
                if i >= 5:  # the first blocks fill caches
                    costs.append(time.perf_counter() - t0)
            dur = block / fs
            c = np.array(costs)
            row = {"block": block, "block_ms": 1e3 * dur, "median_ms": 1e3 * np.median(c),
                   "p99_ms": 1e3 * np.percentile(c, 99), "load_median": np.median(c) / dur,
                   "load_p99": np.percentile(c, 99) / dur, "latency_samples": rend.latency_samples}
            out[f"{case} B={block}"] = row
            log(f"stream {case:22s} B={block:4d} ({1e3 * dur:5.2f} ms): median "
                f"{row['median_ms']:6.2f} ms, p99 {row['p99_ms']:6.2f} ms, load "
                f"{row['load_median']:.2f} (p99 {row['load_p99']:.2f}), latency "
                f"{rend.latency_samples} samples")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rays", default="5000", help="rays of the cached bake (default 5000)")
    ap.add_argument("--block", type=int, default=8192, help="offline block (default 8192)")
    ap.add_argument("--out", default=str(HERE / "results" / "auralize.json"))
    args = ap.parse_args()
    field = the_field(args.rays)
    path = the_path()
    fs = field.sample_rate_hz
    n_resp = int(np.ceil((field.bin_start_s[-1] + field.bin_width_s[-1]) * fs))
    log(f"{field.scene_name}: {field.n_receivers} cells, responses {n_resp / fs:.2f} s "
        f"({n_resp} samples) x {len(field.direction_names)} directions; walk "
        f"{path.duration_s:.1f} s; one thread")
    dry = builtin("builtin:speech", fs, path.duration_s)
    with sfft.set_workers(1):
        results = {"walk": bench_walk(field, path, dry, args.block),
                   "static_vs_peer": bench_peer(field, dry, args.block),
                   "stream": bench_stream(field)}
    # The walk against the peer of the same run: this ratio holds when the machine's speed
    # swings, the absolute real-time factor does not.
    peer_s = results["static_vs_peer"]["peer_s"]
    for name, row in results["walk"]["layouts"].items():
        row["walk_vs_peer"] = peer_s / row["render_s"]
        log(f"walk {name:12s}: {row['walk_vs_peer']:.2f}x the speed of one plain fftconvolve of "
            f"a cell's 8 responses ({row['render_s']:.2f} s against {peer_s:.2f} s)")
    results["settings"] = {"offline_block": args.block, "response_samples": n_resp,
                           "rays": field.settings.get("rays"), "python": platform.python_version(),
                           "numpy": np.__version__, "scipy": scipy.__version__,
                           "machine": platform.machine(), "cpus": os.cpu_count(),
                           "load_average_1min_at_end": os.getloadavg()[0]}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(results, f, indent=2, default=float)
    follow_umask(tmp)  # mkstemp makes it private
    os.replace(tmp, out)
    log(f"results -> {out} (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs: "
        "other work on the machine slows every number here)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
