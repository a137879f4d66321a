"""Web bundle sizes: bytes per cell and in all, for the paper's medium and large rooms, the way
main wrote them (the field's whole time axis, uncompressed) next to the default now (cut where
the cell's decay has fallen 60 dB, each cell deflated), and the field's own bytes per receiver.

Run with ``.venv/bin/python benchmarks/web_bundle.py`` (``--rays N`` instead of each room's
automatic count). The fields are baked once (sound only) and cached in benchmarks/.cache
(git-ignored). Sizes do not depend on the machine; the seconds do (they are printed with how
busy the machine was). Results go to benchmarks/results/web_bundle.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_and_load, other_cpu_use, write_json  # noqa: E402

ROOMS = ("paper-medium", "paper-large")
TARGET = {"cell_bytes": 200e3, "paper-large_total_bytes": 50e6}  # issue 19


def field_of(room: str, rays: str) -> Path:
    from sonolux import cli

    cache = HERE / ".cache"
    cache.mkdir(exist_ok=True)
    path = cache / f"web-bundle-{room}-{rays}.h5"
    if not path.exists():
        code = cli.main(["bake", room, "-o", str(path), "--rays", rays, "--no-light", "-q"])
        if code != 0:
            raise SystemExit(f"baking {room} failed ({code})")
    return path


def sizes(field: Path, options) -> dict:
    from sonolux.web import export_web

    with tempfile.TemporaryDirectory(dir=HERE / ".cache") as tmp:
        t0 = time.perf_counter()
        summary = export_web(field, Path(tmp) / "bundle", options)
        seconds = time.perf_counter() - t0
        index = json.loads((Path(tmp) / "bundle" / "field.json").read_text())
    per_cell = [c["byte_length"] for c in index["cells"]]
    return {"total_bytes": summary.responses_bytes, "cells": len(per_cell),
            "mean_cell_bytes": sum(per_cell) / len(per_cell), "max_cell_bytes": max(per_cell),
            "response_length_s": summary.response_length_s, "seconds": seconds}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rays", default="auto", help="rays per source (default: each room's auto)")
    args = p.parse_args()
    from sonolux.fieldfile import open_field
    from sonolux.web import WebExportOptions

    busy_start = other_cpu_use()
    results = {}
    for room in ROOMS:
        field = field_of(room, args.rays)
        sound = open_field(field)
        main_way = sizes(field, WebExportOptions(tail_db=None, compress=False))
        now = sizes(field, WebExportOptions())
        results[room] = {"rays": sound.settings["rays"], "field_bytes_per_receiver":
                         sound.bytes_per_receiver, "main": main_way, "default": now}
        print(f"{room} ({sound.settings['rays']:,} rays, field {sound.bytes_per_receiver / 1e6:.2f} MB "
              f"a receiver): main {main_way['total_bytes'] / 1e6:.1f} MB, "
              f"{main_way['mean_cell_bytes'] / 1e3:.0f} KB a cell; now "
              f"{now['total_bytes'] / 1e6:.1f} MB, {now['mean_cell_bytes'] / 1e3:.0f} KB a cell "
              f"(largest {now['max_cell_bytes'] / 1e3:.0f} KB), "
              f"{main_way['total_bytes'] / now['total_bytes']:.1f}× smaller")
    large = results["paper-large"]["default"]
    met = large["total_bytes"] <= TARGET["paper-large_total_bytes"] and all(
        r["default"]["max_cell_bytes"] <= TARGET["cell_bytes"] for r in results.values())
    print(f"issue 19's target (a cell ≤ 200 KB, paper-large ≤ 50 MB): {'met' if met else 'not met'}")
    write_json(HERE / "results" / "web_bundle.json",
               {"rooms": results, "target": TARGET, "target_met": met,
                "machine": machine_and_load(busy_start, other_cpu_use())})


if __name__ == "__main__":
    main()
