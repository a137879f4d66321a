"""Time to converge: the progressive bake of each estimator until every receiver and band knows
T30, EDT and C80 to a quarter of a JND (docs/progressive.md), on paper-medium (its 55-receiver
grid) and on the L-shaped mesh classroom (examples/l-room, four listeners).

Run with ``make bench`` or ``.venv/bin/python benchmarks/converge.py``. Each bake runs on 2
threads with a time cap (``--cap-seconds``, default 60 s, so that the whole benchmark takes
about 10 minutes on an idle machine). A bake that reaches the cap reports the error it reached
and its **projected** time to converge from the standard error's 1/√n slope (seconds × (worst
SE / target)²), marked ``"projected": true``. ``auto`` is run as a user would: its pilots
(sonolux.sound.progressive.choose) pick an estimator by counted work, the chosen pilot is the
first round, and the cap counts the pilots too.

What it shows, per scene:
- the time to converge (measured or projected) of paper, rain, nee and auto, and auto's choice;
- that the counted-work projection (the core's segments + shadow rays + deposits + draws, one
  unit each, × (SE / target)²: what auto ranks by, the same on any machine) ranks the
  estimators as the measured times do, for the full bakes and for auto's pilots;
- the measured cost of each kind of work (ns a unit, least squares over the bakes of the scene),
  which says how fair the one-unit-each model is.
Results go to benchmarks/results/converge.json.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from common import machine_and_load, other_cpu_use, write_json

import sonolux
from sonolux.sound import progressive

HERE = Path(__file__).resolve().parent
SCENES = {"paper-medium": "paper-medium", "l-room": str(HERE.parent / "examples/l-room/l-room.toml")}
ESTIMATORS = ("paper", "rain", "nee")
#: auto's time cap, in caps of the fixed estimators (its pilots count).
AUTO_CAP = 1.5


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
    q90 = progressive.projection(errors, accuracy)
    stats = field.stats
    work = progressive.counted_work(stats)
    choice = field.settings.get("estimator_choice")
    # Time spent on pilots that were not kept (auto): it does not shrink with more rays.
    overhead = 0.0
    if choice:
        kept = choice["pilots"][choice["chosen"]].get("seconds", 0.0)
        overhead = choice["pilot_seconds"] - kept
    grow = max(worst, 1.0) ** 2 if math.isfinite(worst) else math.inf
    return {"seconds": seconds, "rays": field.settings["rays"], "stopped": p["stopped"],
            "converged": p["stopped"] == "converged", "projected": p["stopped"] != "converged",
            "rounds": len(p["rounds"]), "worst_over_target": worst,
            # Time to converge: measured, or from the 1/√n slope of the worst entry's SE.
            "seconds_to_converge": overhead + (seconds - overhead) * grow,
            "seconds_to_converge_q90": overhead + (seconds - overhead) * max(q90, 1.0),
            "work": work, "work_to_converge": work * grow,
            "work_to_converge_q90": work * max(q90, 1.0),
            "counts": {k: int(stats.get(k, 0)) for k in progressive.WORK},
            "errors": p["errors"], "estimator": field.settings["estimator"],
            "estimator_choice": choice}


def unit_costs(rows: list[tuple[dict, float]]) -> dict[str, float | None]:
    """ns a unit of each kind of work, from (counts, seconds) of several bakes: non-negative
    least squares (scipy.optimize.nnls); None for a kind that none of the bakes did."""
    from scipy.optimize import nnls

    kinds = [k for k in progressive.WORK if any(c[k] for c, _ in rows)]
    if not kinds:
        return {}
    a = np.array([[c[k] for k in kinds] for c, _ in rows], float)
    b = np.array([s for _, s in rows], float)
    scale = a.max(axis=0)
    x, _ = nnls(a / scale, b)
    out: dict[str, float | None] = {k: None for k in progressive.WORK}
    out.update({k: float(v / s * 1e9) for k, v, s in zip(kinds, x, scale)})
    return out


def ranking(values: dict[str, Any]) -> list[str]:
    return sorted(values, key=lambda k: (values[k], k))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--accuracy", type=float, default=0.25)
    ap.add_argument("--cap-seconds", type=float, default=60.0)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--estimators", nargs="*", default=list(ESTIMATORS),
                    help="the fixed estimators to measure beside auto")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "converge.json")
    a = ap.parse_args()
    busy_start = other_cpu_use()
    results: dict = {"accuracy_jnd": a.accuracy, "cap_seconds": a.cap_seconds,
                     "work_units": list(progressive.WORK), "scenes": {}}
    for name in a.scenes:
        scene = sonolux.load_scene(SCENES[name])
        scene = replace(scene, settings=replace(scene.settings, threads=2))
        row: dict = {}
        for est in (*a.estimators, "auto"):
            # auto's cap counts its pilots: it gets AUTO_CAP × the others' (its rays after the
            # pilots are the pinned estimator's: docs/progressive.md).
            cap = a.cap_seconds * (AUTO_CAP if est == "auto" else 1.0)
            log(f"{name}: {est}, until {a.accuracy:g} JND or {cap:g} s")
            row[est] = r = converge(scene, est, a.accuracy, cap)
            how = "converged in" if r["converged"] else "PROJECTED (cap reached)"
            log(f"  {r['estimator']}: {r['rays']:,} rays, {r['seconds']:.1f} s, worst SE/target "
                f"{r['worst_over_target']:.2f}; {how} {r['seconds_to_converge']:.0f} s "
                f"(90 % of entries: {r['seconds_to_converge_q90']:.0f} s); work "
                f"{r['work']:,} units")
        fixed = list(a.estimators)
        # Ranked by the worst entry's projection (the stopping rule's), then by the 90 % entry's
        # where the worst is infinite for several.
        by_time = {e: (row[e]["seconds_to_converge"], row[e]["seconds_to_converge_q90"])
                   for e in fixed}
        by_work = {e: (row[e]["work_to_converge"], row[e]["work_to_converge_q90"])
                   for e in fixed}
        choice = row["auto"]["estimator_choice"]
        pilots = {e: p for e, p in choice["pilots"].items() if "work" in p}
        samples = [(row[e]["counts"], row[e]["seconds"]) for e in fixed]
        samples += [(p["stats"], p["seconds"]) for p in pilots.values()]
        fastest = ranking(by_time)[0] if fixed else None
        row["summary"] = s = {
            "fastest_measured": fastest, "auto_chose": choice["chosen"],
            "auto_is_fastest": choice["chosen"] == fastest,
            "ranking_by_time": ranking(by_time), "ranking_by_work": ranking(by_work),
            "work_ranks_as_time": ranking(by_time) == ranking(by_work),
            "pilot_ranking_by_work": ranking({e: p["projected_work"] for e, p in pilots.items()}),
            "pilot_ranking_by_time": ranking({e: p["projected_seconds"]
                                              for e, p in pilots.items()}),
            "pilot_rays": {e: p["rays"] for e, p in pilots.items()},
            "pilot_seconds": choice["pilot_seconds"],
            "pilot_overhead_seconds": choice["pilot_seconds"]
            - pilots.get(choice["chosen"], {}).get("seconds", 0.0),
            "ns_per_unit": unit_costs(samples),
            "time_over_fastest": {e: row[e]["seconds_to_converge"] / by_time[fastest][0]
                                  for e in (*fixed, "auto")} if fastest else {}}
        log(f"{name}: fastest {fastest}; auto chose {s['auto_chose']}; by time "
            f"{s['ranking_by_time']}, by counted work {s['ranking_by_work']}; pilots by work "
            f"{s['pilot_ranking_by_work']}, by time {s['pilot_ranking_by_time']}; pilot rays "
            f"{s['pilot_rays']}, overhead {s['pilot_overhead_seconds']:.1f} s; ns a unit "
            + ", ".join(f"{k} {v:.0f}" for k, v in s["ns_per_unit"].items() if v is not None))
        results["scenes"][name] = row
    results["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(a.out, results)
    log(f"wrote {a.out}")


if __name__ == "__main__":
    main()
