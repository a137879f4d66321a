"""Web bundle sizes and the browser's synthesis time, for the three paper rooms: the field's
bytes per receiver (full resolution in memory, compact in the file), the bundle of responses
(``sonolux-web/2``: cut 60 dB down each cell's decay, deflated) against the bundle of compact
cells (``sonolux-web/3``, the default: the browser synthesises the responses), bytes per cell
and in all, and the time to synthesise a cell: by the library (the /2 writer's
``cell_responses``, the peer in the same run) and by the viewer's worker code
(``web/src/synth``, run in Node.js's V8 by ``benchmarks/web_synth.ts``).

Run with ``.venv/bin/python benchmarks/web_bundle.py`` (``--rays N`` instead of each room's
automatic count; ``--cells K`` cells timed per room, default 5). The fields are baked once
(sound only, compact storage) and cached in benchmarks/.cache (git-ignored). Sizes do not depend
on the machine; the seconds do (printed with how busy the machine was). Results go to
benchmarks/results/web_bundle.json.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_and_load, other_cpu_use, write_json  # noqa: E402

ROOMS = ("paper-small", "paper-medium", "paper-large")
TARGET = {"cell_bytes": 200e3, "paper-large_total_bytes": 50e6}  # issue 19
VITE_NODE = HERE.parent / "web" / "node_modules" / ".bin" / "vite-node"


def rule_rays(room: str) -> int:
    """The library's automatic ray count of the room (``bake.ray_count``, the rule of
    rays="auto"; the command line's default is the progressive bake, whose count varies)."""
    import sonolux
    from sonolux.sound.bake import ray_count

    return ray_count(sonolux.load_scene(room), sonolux.SoundOptions(rays="auto"))


def field_of(room: str, rays: str) -> Path:
    from sonolux import cli

    cache = HERE / ".cache"
    cache.mkdir(exist_ok=True)
    count = str(rule_rays(room)) if rays == "auto" else rays
    path = cache / f"web-bundle-{room}-{count}.h5"
    if not path.exists():
        code = cli.main(["bake", room, "-o", str(path), "--rays", count, "--no-light", "-q"])
        if code != 0:
            raise SystemExit(f"baking {room} failed ({code})")
    return path


def bundle(field: Path, options, out: Path) -> dict:
    from sonolux.web import export_web

    t0 = time.perf_counter()
    summary = export_web(field, out, options)
    seconds = time.perf_counter() - t0
    index = json.loads((out / "field.json").read_text())
    per_cell = [c["byte_length"] for c in index["cells"]]
    return {"format": index["format"], "total_bytes": summary.responses_bytes,
            "cells": len(per_cell), "mean_cell_bytes": sum(per_cell) / len(per_cell),
            "max_cell_bytes": max(per_cell), "response_length_s": summary.response_length_s,
            "export_seconds": seconds}


def library_ms(field: Path, cells: list[int]) -> list[float]:
    """The library's synthesis of a cell (all directions, full and direct), ms each."""
    from sonolux.fieldfile import open_field
    from sonolux.web.responses import cell_responses

    sound = open_field(field)
    out = []
    for r in cells:
        t0 = time.perf_counter()
        cell_responses(sound, r, 0, None, 60.0)
        out.append(1e3 * (time.perf_counter() - t0))
    return out


def worker_ms(bundle_dir: Path, cells: list[int]) -> list[dict] | None:
    if not VITE_NODE.exists():
        print(f"  (no {VITE_NODE}: run `cd web && npm install` to time the browser's synthesis)")
        return None
    # The first cell twice: its first synthesis includes compiling the code (as a page's
    # first cell does), reported apart; the rest are the steady state.
    res = subprocess.run([str(VITE_NODE), str(HERE / "web_synth.ts"), str(bundle_dir),
                          str(cells[0]), *map(str, cells)], capture_output=True, text=True,
                         cwd=HERE.parent)
    if res.returncode != 0:
        raise SystemExit(f"web_synth.ts failed:\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])["cells"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rays", default="auto",
                   help="rays per source (default: each room's automatic rule, bake.ray_count)")
    p.add_argument("--cells", type=int, default=5, help="cells timed per room (default 5)")
    args = p.parse_args()
    from sonolux.fieldfile import open_field
    from sonolux.web import WebExportOptions

    busy_start = other_cpu_use()
    results = {}
    for room in ROOMS:
        field = field_of(room, args.rays)
        sound = open_field(field)
        n = sound.n_receivers
        cells = sorted({round(k * (n - 1) / max(1, args.cells - 1)) for k in range(args.cells)})
        with tempfile.TemporaryDirectory(dir=HERE / ".cache") as tmp:
            pcm = bundle(field, WebExportOptions(responses="pcm"), Path(tmp) / "pcm")
            compact = bundle(field, WebExportOptions(), Path(tmp) / "compact")
            worker = worker_ms(Path(tmp) / "compact", cells)
        library = library_ms(field, cells)
        dense = sound.energy.dense_bytes / n if hasattr(sound.energy, "dense_bytes") \
            else sound.energy.nbytes / n
        r = {"rays": sound.settings["rays"], "receivers": n,
             "field_full_bytes_per_receiver_in_memory": dense,
             "field_compact_bytes_per_receiver_in_file": field.stat().st_size / n,
             "bundle_responses": pcm, "bundle_compact": compact,
             "synthesis_cells": cells, "library_ms_per_cell": library,
             "worker_first_cell_ms": None if worker is None else worker[0]["ms"],
             "worker_ms_per_cell": None if worker is None else [c["ms"] for c in worker[1:]],
             "response_samples": None if worker is None else [c["samples"] for c in worker[1:]]}
        results[room] = r
        wk = "—" if worker is None else (
            f"median {statistics.median(r['worker_ms_per_cell']):.0f} ms, worst "
            f"{max(r['worker_ms_per_cell']):.0f} ms (first, compiling: {worker[0]['ms']:.0f} ms)")
        print(f"{room} ({sound.settings['rays']:,} rays, {n} cells): field {dense / 1e3:.0f} KB full "
              f"in memory, compact file {field.stat().st_size / n / 1e3:.1f} KB a receiver; bundle /2 "
              f"{pcm['total_bytes'] / 1e6:.1f} MB ({pcm['max_cell_bytes'] / 1e3:.0f} KB largest "
              f"cell) → /3 {compact['total_bytes'] / 1e6:.2f} MB ({compact['mean_cell_bytes'] / 1e3:.1f} "
              f"KB a cell, largest {compact['max_cell_bytes'] / 1e3:.1f} KB), "
              f"{pcm['total_bytes'] / compact['total_bytes']:.1f}× smaller; synthesis of a cell: "
              f"library median {statistics.median(library):.0f} ms, worst {max(library):.0f} ms; "
              f"worker code {wk}; {len(cells)} cells")
    large = results["paper-large"]["bundle_compact"]
    met = large["total_bytes"] <= TARGET["paper-large_total_bytes"] and all(
        r["bundle_compact"]["max_cell_bytes"] <= TARGET["cell_bytes"] for r in results.values())
    print(f"issue 19's target (a cell ≤ 200 KB, paper-large ≤ 50 MB): {'met' if met else 'not met'}")
    write_json(HERE / "results" / "web_bundle.json",
               {"rooms": results, "target": TARGET, "target_met": met,
                "machine": machine_and_load(busy_start, other_cpu_use())})


if __name__ == "__main__":
    main()
