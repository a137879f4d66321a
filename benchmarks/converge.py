"""Time to converge: the progressive bake of each estimator until every receiver and band knows
T30, EDT and C80 to a quarter of a JND (docs/progressive.md), on paper-medium (its 55-receiver
grid) and on the L-shaped mesh classroom (examples/l-room, four listeners).

Run with ``make bench`` or ``.venv/bin/python benchmarks/converge.py``. Each bake runs on 2
threads with a time cap (``--cap-seconds``, default 300 s); a bake that reaches the cap reports
the error it reached instead. The estimators are measured one after the other in the same run:
the ratio of their times (or of their errors at the cap, converted to time by 1/√n) says which
converges sooner for that scene. ``auto`` is then run as a user would: its pilots
(sonolux.sound.progressive.choose_estimator) pick an estimator and the bake goes on with it; the
benchmark checks that the pick is the estimator measured fastest, and reports the pilots' cost.
Results go to benchmarks/results/converge.json.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from common import machine_and_load, other_cpu_use, write_json

import sonolux
from sonolux.sound import progressive

HERE = Path(__file__).resolve().parent
SCENES = {"paper-medium": "paper-medium", "l-room": str(HERE.parent / "examples/l-room/l-room.toml")}
ESTIMATORS = ("paper", "rain", "nee")


def log(msg: str) -> None:
    print(f"[converge {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def converge(scene, estimator: str, accuracy: float, cap_s: float) -> dict:
    options = sonolux.SoundOptions(estimator=estimator)
    started = time.perf_counter()
    field, errors = progressive.bake(scene, options, progressive.Accuracy(accuracy,
                                                                          max_seconds=cap_s))
    seconds = time.perf_counter() - started
    p = field.settings["progressive"]
    worst = errors.worst_over_target(accuracy)
    # The pilot's measure too (sonolux.sound.progressive.choose_estimator): the 90 % quantile of
    # the entries' projected times, finite where a single undefined leave-out makes the worst inf.
    squares = np.concatenate([((errors.counted(p) / (accuracy * progressive.JND[p][0])) ** 2)
                              .ravel() for p in progressive.PARAMETERS])
    squares = squares[~np.isnan(squares)]
    q90 = float(np.quantile(squares, progressive.PILOT_QUANTILE, method="higher")) \
        if squares.size else 0.0
    # Time it would take to converge, from 1/√n scaling of the worst error (= seconds if done).
    projected = seconds * max(worst, 1.0) ** 2 if worst == worst else float("inf")
    return {"seconds": seconds, "rays": field.settings["rays"], "stopped": p["stopped"],
            "rounds": len(p["rounds"]), "worst_over_target": worst,
            "projected_seconds": projected, "errors": p["errors"],
            "projected_q90_seconds": seconds * max(q90, 1.0) if q90 == q90 else float("inf"),
            "estimator": field.settings["estimator"],
            "estimator_choice": field.settings.get("estimator_choice")}


def _ratio(a: float, b: float) -> float | None:
    """a / b, None where either is not finite (a bake that did not converge nor project)."""
    return a / b if a == a and b == b and a < float("inf") and b < float("inf") and b > 0 else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--accuracy", type=float, default=0.25)
    ap.add_argument("--cap-seconds", type=float, default=300.0)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--estimators", nargs="*", default=list(ESTIMATORS),
                    help="the fixed estimators to measure beside auto")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "converge.json")
    a = ap.parse_args()
    busy_start = other_cpu_use()
    results: dict = {"accuracy_jnd": a.accuracy, "cap_seconds": a.cap_seconds, "scenes": {}}
    for name in a.scenes:
        scene = sonolux.load_scene(SCENES[name])
        scene = replace(scene, settings=replace(scene.settings, threads=2))
        row = {}
        for est in a.estimators:
            log(f"{name}: {est} estimator, until {a.accuracy:g} JND or {a.cap_seconds:g} s")
            row[est] = r = converge(scene, est, a.accuracy, a.cap_seconds)
            log(f"  {r['stopped']} after {r['rays']:,} rays in {r['seconds']:.1f} s "
                f"(worst SE / target {r['worst_over_target']:.2f}; projected "
                f"{r['projected_seconds']:.0f} s to converge; 90 % of entries: "
                f"{r['projected_q90_seconds']:.0f} s)")
        # Ranked by the worst entry's projection (the stopping rule's), then the 90 % quantile's
        # where the worst is infinite for several.
        fastest = min(a.estimators, key=lambda e: (row[e]["projected_seconds"],
                                                   row[e]["projected_q90_seconds"])) \
            if a.estimators else None
        log(f"{name}: auto (pilots, then the chosen estimator)")
        row["auto"] = r = converge(scene, "auto", a.accuracy, a.cap_seconds)
        choice = r["estimator_choice"]
        pilots_s = sum(p.get("seconds", 0.0) for p in choice["pilots"].values())
        log(f"  chose {r['estimator']} after {pilots_s:.1f} s of pilots; {r['stopped']} in "
            f"{r['seconds']:.1f} s (projected {r['projected_seconds']:.0f} s)")
        row.update(fastest=fastest, auto_chose=r["estimator"],
                   auto_is_fastest=r["estimator"] == fastest, pilot_seconds=pilots_s,
                   time_over_fastest={e: _ratio(row[e]["projected_seconds"],
                                                row[fastest]["projected_seconds"])
                                      for e in (*a.estimators, "auto")} if fastest else {})
        log(f"{name}: fastest to converge: {fastest}; auto chose {r['estimator']}; projected "
            "time / fastest: " + ", ".join(f"{e} {v}" for e, v in row["time_over_fastest"].items()))
        results["scenes"][name] = row
    results["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(a.out, results)
    log(f"wrote {a.out}")


if __name__ == "__main__":
    main()
