"""The compact sound field against the full one, and a grid bake's peak memory against its budget.

Run with ``.venv/bin/python benchmarks/compact_field.py`` (``make bench`` runs it).

1. Bytes per receiver, in memory and in the file, of the three paper rooms (8 azimuths, their
   octaves) baked the same way twice: the peer is the full field (``storage="full"``, 1 ms late
   bins: the format-2 layout), the compact field is the default. Both bakes trace the same rays.
2. A grid bake (``--grid-receivers``, default about 4,000 on a 0.5 m grid) with a memory budget
   (``--budget``, default 1.5 GB): its estimate, its tiles and its peak resident memory
   (getrusage, in a child process) next to the budget.

Results go to benchmarks/results/compact_field.json.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import machine_and_load, other_cpu_use, write_json

import sonolux
from sonolux.fieldfile import save_fields
from sonolux.sound.bake import bake
from sonolux.sound.info import info

OUT = Path(__file__).parent / "results" / "compact_field.json"

GRID = """
name = "open-plan floor"
[settings]
sample_rate_hz = 24000
bands_hz = [125, 250, 500, 1000, 2000, 4000]
max_time_s = 1.0
seed = 3
[[geometry]]
type = "shoebox"
size_m = [{x}, {y}, 3.0]
[geometry.materials]
walls = "plaster-smooth"
floor = "carpet-on-concrete"
ceiling = "concrete-painted"
[[sources]]
position_m = [{sx}, {sy}, 1.6]
power_w = 0.01
[receivers]
type = "grid"
spacing_m = 0.5
height_m = 1.2
radius_m = 0.25
"""

CHILD = """
import json, resource, sys
import sonolux
from sonolux.sound.bake import bake
field = bake(sonolux.load_scene(sys.argv[1]), rays=int(sys.argv[2]), memory_bytes=int(sys.argv[3]))
print(json.dumps({"receivers": field.n_receivers, "tiles": field.stats["tiles"],
                  "estimate_bytes": field.stats["memory_estimate_bytes"],
                  "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
                  "seconds": field.stats["seconds"]}))
"""


def room_sizes(name: str, rays: int, tmp: Path) -> dict:
    scene = sonolux.load_scene(name)
    out = {}
    for storage in ("full", "compact"):
        t0 = time.perf_counter()
        field = bake(scene, rays=rays, storage=storage)
        seconds = time.perf_counter() - t0
        save_fields(tmp / f"{storage}.h5", sound=field)
        d = info(field)
        out[storage] = {"memory_bytes_per_receiver": d["bytes_per_receiver"],
                        "file_bytes_per_receiver": d["file_bytes_per_receiver"],
                        "bake_seconds": seconds}
    out["file_ratio_full_to_compact"] = (out["full"]["file_bytes_per_receiver"]
                                         / out["compact"]["file_bytes_per_receiver"])
    out["receivers"] = field.n_receivers
    out["directions_x_bands"] = [field.energy.shape[1], field.energy.shape[2]]
    return out


def grid_bake(receivers: int, budget: int, rays: int, tmp: Path) -> dict:
    y = math.sqrt(receivers * 0.25 * 2.5)
    x = receivers * 0.25 / y
    path = tmp / "grid.toml"
    path.write_text(GRID.format(x=round(x, 1), y=round(y, 1), sx=round(x / 2, 1) + 0.1,
                                sy=round(y / 2, 1) + 0.1))
    done = subprocess.run([sys.executable, "-c", CHILD, str(path), str(rays), str(budget)],
                          capture_output=True, text=True, check=True)
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["budget_bytes"] = budget
    out["peak_over_budget"] = out["peak_rss_bytes"] / budget
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rays", type=int, default=300_000)
    p.add_argument("--grid-receivers", type=int, default=4_000)
    p.add_argument("--budget", type=float, default=1.5e9)
    args = p.parse_args()
    busy = other_cpu_use()
    results: dict = {"rays": args.rays, "rooms": {}}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name in ("paper-small", "paper-medium", "paper-large"):
            r = room_sizes(name, args.rays, tmp)
            results["rooms"][name] = r
            print(f"{name}: {r['receivers']} receivers, file per receiver "
                  f"{r['full']['file_bytes_per_receiver'] / 1e3:,.1f} KB full (peer) -> "
                  f"{r['compact']['file_bytes_per_receiver'] / 1e3:,.1f} KB compact "
                  f"({r['file_ratio_full_to_compact']:.1f}x smaller); in memory "
                  f"{r['full']['memory_bytes_per_receiver'] / 1e3:,.0f} -> "
                  f"{r['compact']['memory_bytes_per_receiver'] / 1e3:,.1f} KB")
        g = grid_bake(args.grid_receivers, int(args.budget), 2000, tmp)
        results["grid"] = g
        print(f"grid: {g['receivers']:,} receivers in {g['tiles']} tiles, estimate "
              f"{g['estimate_bytes'] / 1e9:.2f} GB, peak RSS {g['peak_rss_bytes'] / 1e9:.2f} GB, "
              f"budget {g['budget_bytes'] / 1e9:.2f} GB ({g['peak_over_budget']:.0%} of it)")
    results["machine"] = machine_and_load(busy, other_cpu_use())
    write_json(OUT, results)


if __name__ == "__main__":
    main()
