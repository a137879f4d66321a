"""What level of detail changes in a furnished room: bakes furnished_room.toml with and without
``[early] level_of_detail``, prints T30, EDT and C80 per band (mean over the receivers) and
draws both decay curves of one receiver with sonolux's plotting module.

    python examples/furniture/demo.py [--rays N] [--out DIR]

Writes furniture.obj beside this file if it is missing (rooms.py), and lod_on.png,
lod_off.png and lod_table.md into DIR (default: this folder).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import sonolux
from sonolux.analysis.params import room_parameters
from sonolux.plotting.responses import plot_decay_curves
from sonolux.sound.bake import bake

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from rooms import furniture, write_obj  # noqa: E402


def table(params_on, params_off, bands) -> str:
    rows = ["| parameter | " + " | ".join(f"{b:g} Hz" for b in bands) + " |",
            "|---|" + "---|" * len(bands)]
    for key, name, unit in (("t30_s", "T30", "s"), ("edt_s", "EDT", "s"), ("c80_db", "C80", "dB")):
        for label, p in (("with", params_on), ("without", params_off)):
            v = np.nanmean(p.values[key], axis=0)[:len(bands)]
            rows.append(f"| {name} {label} LoD ({unit}) | " + " | ".join(f"{x:.2f}" for x in v) + " |")
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rays", type=int, default=20_000)
    ap.add_argument("--out", type=Path, default=HERE)
    # A 6 s record: the plaster room decays in up to 4 s at low frequencies.
    a = ap.parse_args()
    if not (HERE / "furniture.obj").exists():
        write_obj(HERE / "furniture.obj", furniture())
    scene = sonolux.load_scene(HERE / "furnished_room.toml")
    assert scene.early is not None
    off = replace(scene, early=replace(scene.early, level_of_detail=False))
    a.out.mkdir(parents=True, exist_ok=True)
    fields = {}
    for name, sc in (("on", scene), ("off", off)):
        fields[name] = bake(sc, rays=a.rays, max_time_s=6.0, log=print)
        plot_decay_curves(fields[name], 0, a.out / f"lod_{name}.png")
    p_on, p_off = (room_parameters(fields[k], theory=False, sti=False) for k in ("on", "off"))
    text = table(p_on, p_off, list(scene.settings.bands_hz))
    (a.out / "lod_table.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
