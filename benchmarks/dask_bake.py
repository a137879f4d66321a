"""Distributed and checkpointed bakes against the plain in-process bake: what spreading costs.

Run with ``.venv/bin/python benchmarks/dask_bake.py`` (``make bench`` runs it). The scene is
paper-large (24 x 10 x 8 m, 207 receivers, a field of 79 million bins: 634 MB of counts), sound
only, at its automatic ray count (``--rays`` to change it). Three bakes of the same rays, each
checked to have the same bits:

1. the peer: the plain in-process bake (``sonolux.sound.bake.bake``, every core);
2. the same bake as ``sonolux bake`` runs it by default: in ranges, checkpointed at most every
   60 s (the first range is 1/16 of the bake, the next ones about 60 s each);
3. the same bake in ray ranges with a checkpoint written after every range (``--range-rays``,
   default 1/8 of the rays): the worst case of what checkpoints cost;
4. ``--dask local``: a LocalCluster of one worker process per core, one engine thread each,
   2 tasks per worker (the default); the cluster's start is timed apart.

Each is repeated ``--repeat`` times (default 2) and the fastest kept; the overhead is the ratio
to the peer, both times printed. Results go to benchmarks/results/dask_bake.json.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import sonolux
from sonolux.distributed import connect
from sonolux.range_bake import bake_ranges
from sonolux.sound.bake import bake as bake_whole
from sonolux.sound.ranges import SoundRanges

RESULTS = Path(__file__).resolve().parent / "results" / "dask_bake.json"


def fastest(repeat: int, run):
    best, out = float("inf"), None
    for _ in range(repeat):
        started = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - started)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=None, help="rays (default: auto)")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--range-rays", type=int, default=None)
    args = parser.parse_args()

    scene = sonolux.load_scene("paper-large")
    work = SoundRanges(scene, sonolux.SoundOptions(rays=args.rays or "auto"))
    rays = work.total
    range_rays = args.range_rays or -(-rays // 8)
    print(f"paper-large, sound only, {rays:,} rays, {scene.receivers.count} receivers, "
          f"{os.cpu_count()} cores")

    peer_s, peer = fastest(args.repeat, lambda: bake_whole(scene, rays=rays))
    print(f"in-process bake (peer):            {peer_s:7.2f} s")

    def by_default():
        with tempfile.TemporaryDirectory() as tmp:
            return bake_ranges(work, checkpoint=Path(tmp) / "f.h5.checkpoint")
    default_s, (default_field, default_report) = fastest(args.repeat, by_default)
    assert np.array_equal(default_field.energy, peer.energy), "default bake: other bits"
    print(f"default (checkpoint every 60 s):   {default_s:7.2f} s = {default_s / peer_s:.2f} x "
          f"the peer ({len(default_report['ranges'])} ranges, "
          f"{default_report['checkpoint_writes']} writes)")

    def checkpointed():
        with tempfile.TemporaryDirectory() as tmp:
            return bake_ranges(work, checkpoint=Path(tmp) / "f.h5.checkpoint",
                               checkpoint_every_s=0, range_rays=range_rays)
    ck_s, (ck_field, ck_report) = fastest(args.repeat, checkpointed)
    assert np.array_equal(ck_field.energy, peer.energy), "checkpointed bake: other bits"
    write_s = ck_report["checkpoint_write_s"] / max(1, ck_report["checkpoint_writes"])
    print(f"in ranges of {range_rays:,}, checkpoint each: {ck_s:7.2f} s = {ck_s / peer_s:.2f} x "
          f"the peer ({ck_report['checkpoint_writes']} writes, {write_s:.2f} s each)")

    started = time.perf_counter()
    with connect("local", args.workers) as client:
        start_s = time.perf_counter() - started
        dask_s, dask_field = fastest(args.repeat, lambda: sonolux.bake(scene, rays=rays,
                                                                       client=client))
    assert np.array_equal(dask_field.energy, peer.energy), "Dask bake: other bits"
    print(f"--dask local, {args.workers} workers:         {dask_s:7.2f} s = "
          f"{dask_s / peer_s:.2f} x the peer (cluster start {start_s:.2f} s more)")

    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({
        "scene": "paper-large", "rays": rays, "receivers": scene.receivers.count,
        "field_bins": int(peer.energy.size), "cores": os.cpu_count(), "machine": platform.node(),
        "repeat": args.repeat, "in_process_s": peer_s,
        "default_checkpointing": {"seconds": default_s, "ratio": default_s / peer_s,
                                  "ranges": len(default_report["ranges"]),
                                  "writes": default_report["checkpoint_writes"]},
        "checkpointed": {"seconds": ck_s, "ratio": ck_s / peer_s, "range_rays": range_rays,
                         "writes": ck_report["checkpoint_writes"], "write_s_each": write_s},
        "dask_local": {"seconds": dask_s, "ratio": dask_s / peer_s, "workers": args.workers,
                       "cluster_start_s": start_s},
        "same_bits": True}, indent=2) + "\n")
    print(f"-> {RESULTS}")


if __name__ == "__main__":
    main()
