"""The compact sound field against the full one, and a grid bake's peak memory against its budget.

Run with ``.venv/bin/python benchmarks/compact_field.py`` (``make bench`` runs it).

1. Bytes per receiver, in memory and in the file, of the three paper rooms (8 azimuths, their
   octaves) baked the same way twice: the peer is the full field (``storage="full"``, 1 ms late
   bins: the format-2 layout), the compact field is the default. Both bakes trace the same rays.
   The mesh room (examples/scenes/mesh_room.toml) too, and paper-large with third-octave bands,
   with 3 elevation bands (24 directions), and with both: sizes measured, not computed.
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


def variant(name: str, *, thirds: bool) -> sonolux.Scene:
    """A built-in scene, with third-octave bands instead of its own if asked."""
    if not thirds:
        return sonolux.load_scene(name)
    import tomllib

    from sonolux.scene import builtin

    path = builtin.path(name)
    data = tomllib.loads(path.read_text())
    settings = {k: v for k, v in data.get("settings", {}).items()
                if k not in ("bands", "bands_hz", "band_range_hz")}
    data["settings"] = dict(settings, bands="third-octave", band_range_hz=[100, 10000])
    return sonolux.load_scene(data, base_dir=path.parent)


def room_sizes(name: str, rays: int, tmp: Path, *, thirds: bool = False,
               elevation_bands: int = 1) -> dict:
    """Sizes of the full field (the peer) and the compact one; for the variants with thirds
    or elevations the compact one only, within a 4 GB budget (their full field would need
    6-20 GB of this shared machine), its ratio then taken against the octave room's."""
    scene = variant(name, thirds=thirds)
    plain = not thirds and elevation_bands == 1
    out = {}
    for storage in ("full", "compact") if plain else ("compact",):
        t0 = time.perf_counter()
        field = bake(scene, rays=rays, storage=storage, elevation_bands=elevation_bands,
                     memory_bytes=None if plain else 4_000_000_000)
        seconds = time.perf_counter() - t0
        save_fields(tmp / f"{storage}.h5", sound=field)
        d = info(field)
        out[storage] = {"memory_bytes_per_receiver": d["bytes_per_receiver"],
                        "file_bytes_per_receiver": d["file_bytes_per_receiver"],
                        "bake_seconds": seconds}
    if plain:
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
        # First: the child's peak RSS (getrusage) starts from this process's at the fork, so
        # measured after the big bakes below it would count theirs (2.47 GB of a 1.5 GB
        # budget, seen once; 1.02 GB measured alone).
        g = grid_bake(args.grid_receivers, int(args.budget), 2000, tmp)
        results["grid"] = g
        print(f"grid: {g['receivers']:,} receivers in {g['tiles']} tiles, estimate "
              f"{g['estimate_bytes'] / 1e9:.2f} GB, peak RSS {g['peak_rss_bytes'] / 1e9:.2f} GB, "
              f"budget {g['budget_bytes'] / 1e9:.2f} GB ({g['peak_over_budget']:.0%} of it)")
        mesh_room = str(Path(__file__).resolve().parent.parent / "examples/scenes/mesh_room.toml")
        rooms = [(n, n, {}) for n in ("paper-small", "paper-medium", "paper-large")]
        rooms.append(("mesh room", mesh_room, {}))
        rooms += [("paper-large, thirds", "paper-large", {"thirds": True}),
                  ("paper-large, 3 elevations", "paper-large", {"elevation_bands": 3}),
                  ("paper-large, thirds and 3 elevations", "paper-large",
                   {"thirds": True, "elevation_bands": 3})]
        for label, name, kw in rooms:
            r = room_sizes(name, args.rays, tmp, **kw)
            results["rooms"][label] = r
            c = r["compact"]
            if "full" in r:
                f = r["full"]
                print(f"{label}: {r['receivers']} receivers, {r['directions_x_bands'][0]} "
                      f"directions x {r['directions_x_bands'][1]} bands, file per receiver "
                      f"{f['file_bytes_per_receiver'] / 1e3:,.1f} KB full (peer) -> "
                      f"{c['file_bytes_per_receiver'] / 1e3:,.1f} KB compact "
                      f"({r['file_ratio_full_to_compact']:.1f}x smaller); in memory "
                      f"{f['memory_bytes_per_receiver'] / 1e3:,.0f} -> "
                      f"{c['memory_bytes_per_receiver'] / 1e3:,.1f} KB")
            else:
                base = results["rooms"][name]["compact"]["file_bytes_per_receiver"]
                print(f"{label}: {r['directions_x_bands'][0]} directions x "
                      f"{r['directions_x_bands'][1]} bands, compact file per receiver "
                      f"{c['file_bytes_per_receiver'] / 1e3:,.1f} KB "
                      f"({c['file_bytes_per_receiver'] / base:.2f}x the octave room's); in "
                      f"memory {c['memory_bytes_per_receiver'] / 1e3:,.1f} KB")
    results["machine"] = machine_and_load(busy, other_cpu_use())
    write_json(OUT, results)


if __name__ == "__main__":
    main()
