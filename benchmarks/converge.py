"""Time to converge: the progressive bake of each estimator until every receiver and band knows
T30, EDT and C80 to a quarter of a JND (docs/progressive.md), on paper-medium (its 55-receiver
grid) and on the L-shaped mesh classroom (examples/l-room, four listeners).

Run with ``make bench`` or ``.venv/bin/python benchmarks/converge.py``. Every bake runs on 2
threads. Per scene, ``auto`` runs first, as a user would run it (its pilots,
sonolux.sound.progressive.choose, pick an estimator by counted work; the chosen pilot is the
first round; its time counts the pilots), with a cap long enough to converge
(``--auto-cap-seconds``, default 420 s: the L-room takes about 3 minutes on an idle machine).
Then each fixed estimator runs with a short cap (``--cap-seconds``, default 45 s): one that does
not converge within it reports the error it reached and its **projected** time to converge from
the standard error's 1/√n slope (seconds × (worst SE / target)²), marked ``"projected": true``.
The estimator auto chose also gets its time **measured inside auto's run** (auto's time less
the losers' pilots: the same rays, the same bits as the pinned bake). ``nee`` with at least as
many draws as the scene has receivers is the rain estimator bit for bit and is not run twice.
About 8–11 minutes on an idle machine for seed 1 alone; the further seeds and the
level-of-detail row (on by default; ``--seeds 1 --no-lod`` for the short run) add about 15.

What it shows, per scene:
- the time to converge (measured or projected, said in each line and in the table at the end) of
  paper, rain, nee and auto, and auto's choice;
- that the counted-work projection (the core's segments + shadow rays + deposits + draws, one
  unit each, × (SE / target)²: what auto ranks by, the same on any machine) ranks the
  estimators as the measured times do, for the full bakes and for auto's pilots;
- the measured cost of each kind of work (ns a unit, least squares over the bakes of the scene),
  which says how fair the one-unit-each model is.
- with ``--seeds 1 2 3``: auto's bake again on each further seed (rays, rounds, CPU time to
  converge): where a progressive bake stops is a random variable of the seed (each entry's SE
  estimate has 7 degrees of freedom), so one seed is one draw (docs/progressive.md);
- with ``--lod``: the level-of-detail row: the furnished room (examples/furniture, hybrid,
  ``level_of_detail = true``), the paper estimator, ``level_of_detail_rays = "level"`` (the
  default) against ``"octave"``, CPU time to converge to ``--lod-accuracy`` JND (default 0.5)
  per seed of ``--lod-seeds``; one that reaches ``--lod-cap-seconds`` reports its CPU time
  projected from the worst SE's 1/√n slope (CPU × (worst SE / target)²).
CPU time is the process's (time.process_time: every tracer thread), wall time beside it.
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
FURNISHED = HERE.parent / "examples/furniture/furnished_room.toml"
ESTIMATORS = ("paper", "rain", "nee")


def log(msg: str) -> None:
    print(f"[converge {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def converge(scene, estimator: str, accuracy: float, cap_s: float) -> dict:
    options = sonolux.SoundOptions(estimator=estimator)
    started, cpu = time.perf_counter(), time.process_time()
    field, errors = progressive.bake(scene, options, progressive.Accuracy(accuracy,
                                                                          max_seconds=cap_s))
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
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
    # Entries still undefined by noise at the cap (the rule waits for them) have no SE to
    # project from: the projection is then that of the defined entries, a lower bound.
    undefined = sum(int((errors.waiting(name) & ~errors.at_limit(name)).sum())
                    for name in progressive.PARAMETERS)
    defined = [errors.counted(name, waiting=np.nan) / (accuracy * progressive.JND[name][0])
               for name in progressive.PARAMETERS]
    worst_defined = max((float(np.nanmax(d)) for d in defined if np.isfinite(d).any()),
                        default=math.inf)
    grow = max(worst_defined, 1.0) ** 2 if math.isfinite(worst_defined) else math.inf
    return {"seconds": seconds, "cpu_seconds": cpu, "cpu_seconds_to_converge": cpu * grow,
            "rays": field.settings["rays"], "stopped": p["stopped"],
            "converged": p["stopped"] == "converged", "projected": p["stopped"] != "converged",
            "rounds": len(p["rounds"]), "worst_over_target": worst,
            "worst_defined_over_target": worst_defined, "undefined_by_noise": undefined,
            # Time to converge: measured, or from the 1/√n slope of the worst entry's SE.
            "seconds_to_converge": overhead + (seconds - overhead) * grow,
            "seconds_to_converge_q90": overhead + (seconds - overhead) * max(q90, 1.0),
            "work": work, "work_to_converge": work * grow,
            "work_to_converge_q90": work * max(q90, 1.0),
            "counts": {k: int(stats.get(k, 0)) for k in progressive.WORK},
            "errors": p["errors"], "estimator": field.settings["estimator"],
            "estimator_choice": choice, "overhead_seconds": overhead}


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


def inside_auto(auto: dict) -> dict:
    """The chosen estimator's time to converge measured inside auto's run: auto's rounds are the
    pinned bake's (same rays, same bits), so its time less the losers' pilots is that bake's."""
    out = dict(auto, seconds=auto["seconds"] - auto["overhead_seconds"], inside_auto=True,
               estimator_choice=None, overhead_seconds=0.0)
    out["seconds_to_converge"] = auto["seconds_to_converge"] - auto["overhead_seconds"]
    out["seconds_to_converge_q90"] = auto["seconds_to_converge_q90"] - auto["overhead_seconds"]
    return out


def best(row: dict, e: str) -> dict:
    """The estimator's run, or its bake inside auto's run if that one is the better measure
    (converged where the own run was projected, else the shorter)."""
    own, inside = row[e], row.get(f"{e}_inside_auto")
    if inside is None:
        return own
    if inside["converged"] != own["converged"]:
        return inside if inside["converged"] else own
    return min(own, inside, key=lambda r: r["seconds_to_converge"])


def how(r: dict) -> str:
    return ("measured" if r["converged"] else "PROJECTED" + (
        f" (≥: {r['undefined_by_noise']} undefined)" if r.get("undefined_by_noise") else "")) \
        + (" inside auto" if r.get("inside_auto") else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--accuracy", type=float, default=0.25)
    ap.add_argument("--cap-seconds", type=float, default=45.0,
                    help="the fixed estimators' cap (projected beyond it)")
    ap.add_argument("--auto-cap-seconds", type=float, default=420.0,
                    help="auto's cap, its pilots included: long enough to converge")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--estimators", nargs="*", default=list(ESTIMATORS),
                    help="the fixed estimators to measure beside auto")
    ap.add_argument("--seeds", nargs="*", type=int, default=[1, 2, 3],
                    help="auto's bake again on each seed after the first (rays, CPU to converge)")
    ap.add_argument("--lod", action=argparse.BooleanOptionalAction, default=True,
                    help='the level-of-detail row: furnished room, "level" vs "octave"')
    ap.add_argument("--lod-accuracy", type=float, default=0.5)
    ap.add_argument("--lod-cap-seconds", type=float, default=200.0)
    ap.add_argument("--lod-seeds", nargs="*", type=int, default=[1, 2])
    ap.add_argument("--out", type=Path, default=HERE / "results" / "converge.json")
    a = ap.parse_args()
    busy_start = other_cpu_use()
    results: dict = {"accuracy_jnd": a.accuracy, "cap_seconds": a.cap_seconds,
                     "auto_cap_seconds": a.auto_cap_seconds,
                     "work_units": list(progressive.WORK), "scenes": {}}
    for name in a.scenes:
        scene = sonolux.load_scene(SCENES[name])
        scene = replace(scene, settings=replace(scene.settings, threads=2, seed=a.seeds[0]))
        row: dict = {}
        for est in ("auto", *a.estimators):
            if est == "nee" and scene.receivers.count <= sonolux.SoundOptions().nee_receivers \
                    and "rain" in row:
                row[est] = dict(row["rain"], same_as="rain")
                log(f"{name}: nee draws among {scene.receivers.count} receivers at most "
                    f"{sonolux.SoundOptions().nee_receivers} a reflection: the rain estimator, "
                    "bit for bit (not run twice)")
                continue
            cap = a.auto_cap_seconds if est == "auto" else a.cap_seconds
            log(f"{name}: {est}, until {a.accuracy:g} JND or {cap:g} s")
            row[est] = r = converge(scene, est, a.accuracy, cap)
            verb = "converged in" if r["converged"] else "cap reached, PROJECTED" + (
                f" (at least: {r['undefined_by_noise']} entries still undefined by noise)"
                if r["undefined_by_noise"] else "")
            log(f"  {r['estimator']}: {r['rays']:,} rays, {r['seconds']:.1f} s, worst SE/target "
                f"{r['worst_over_target']:.2f}; {verb} {r['seconds_to_converge']:.0f} s "
                f"(90 % of entries: {r['seconds_to_converge_q90']:.0f} s); work "
                f"{r['work']:,} units")
        choice = row["auto"]["estimator_choice"]
        if choice["chosen"] in a.estimators:
            row[f"{choice['chosen']}_inside_auto"] = inside_auto(row["auto"])
        fixed = list(a.estimators)
        # Ranked by the worst entry's projection (the stopping rule's), then by the 90 % entry's
        # where the worst is infinite for several.
        by_time = {e: (best(row, e)["seconds_to_converge"], best(row, e)["seconds_to_converge_q90"])
                   for e in fixed}
        by_work = {e: (row[e]["work_to_converge"], row[e]["work_to_converge_q90"])
                   for e in fixed}
        pilots = {e: p for e, p in choice["pilots"].items() if "work" in p}
        samples = [(row[e]["counts"], row[e]["seconds"]) for e in fixed
                   if "same_as" not in row[e]]
        samples += [(p["stats"], p["seconds"]) for p in pilots.values()]
        fastest = ranking(by_time)[0] if fixed else None
        auto_s = row["auto"]["seconds_to_converge"]
        row["summary"] = s = {
            "fastest_measured": fastest, "auto_chose": choice["chosen"],
            "auto_is_fastest": choice["chosen"] == fastest,
            "auto_converged": row["auto"]["converged"],
            "auto_faster_than_the_others": all(auto_s < by_time[e][0] for e in fixed
                                               if e != choice["chosen"]),
            "ranking_by_time": ranking(by_time), "ranking_by_work": ranking(by_work),
            "work_ranks_as_time": ranking(by_time) == ranking(by_work),
            "pilot_ranking_by_work": ranking({e: p["projected_work"] for e, p in pilots.items()}),
            "pilot_ranking_by_time": ranking({e: p["projected_seconds"]
                                              for e, p in pilots.items()}),
            "pilot_rays": {e: p["rays"] for e, p in pilots.items()},
            "pilot_seconds": choice["pilot_seconds"],
            "pilot_overhead_seconds": row["auto"]["overhead_seconds"],
            "ns_per_unit": unit_costs(samples),
            "time_over_fastest": {e: best(row, e)["seconds_to_converge"] / by_time[fastest][0]
                                  for e in fixed} | {"auto": auto_s / by_time[fastest][0]}
            if fastest else {}}
        log(f"{name}: fastest {fastest}; auto chose {s['auto_chose']} and "
            + ("converged" if s["auto_converged"] else "did NOT converge within its cap")
            + f"; by time {s['ranking_by_time']}, by counted work {s['ranking_by_work']}; pilots "
            f"by work {s['pilot_ranking_by_work']}, by time {s['pilot_ranking_by_time']}; pilot "
            f"rays {s['pilot_rays']}, overhead {s['pilot_overhead_seconds']:.1f} s; ns a unit "
            + ", ".join(f"{k} {v:.0f}" for k, v in s["ns_per_unit"].items() if v is not None))
        row["seeds"] = [seed_row(a.seeds[0], row["auto"])] + [
            seed_row(seed, converge(replace(scene, settings=replace(scene.settings, seed=seed)),
                                    "auto", a.accuracy, a.auto_cap_seconds))
            for seed in a.seeds[1:]]
        for r in row["seeds"]:
            log(f"{name}: seed {r['seed']}: auto → {r['estimator']}, {r['rays']:,} rays in "
                f"{r['rounds']} rounds, {r['cpu_seconds']:.1f} s CPU ({r['seconds']:.1f} s wall), "
                + ("converged" if r["converged"] else "NOT converged"))
        results["scenes"][name] = row
    if a.lod:
        results["level_of_detail"] = level_of_detail(a.lod_accuracy, a.lod_cap_seconds,
                                                     a.lod_seeds)
    results["machine"] = machine_and_load(busy_start, other_cpu_use())
    write_json(a.out, results)
    print_table(results)
    log(f"wrote {a.out}")


def seed_row(seed: int, r: dict) -> dict:
    """What the seeds table keeps of a converge() result."""
    return {"seed": seed, **{k: r[k] for k in ("estimator", "rays", "rounds", "converged",
                                              "cpu_seconds", "seconds", "worst_over_target")}}


def level_of_detail(accuracy: float, cap_s: float, seeds: list[int]) -> dict:
    """The furnished room's progressive bake (paper), ``level_of_detail_rays`` "level" against
    "octave", per seed: rays, CPU time, converged or CPU projected from the worst SE."""
    base = sonolux.load_scene(str(FURNISHED))
    rows = []
    for seed in seeds:
        for mode in ("level", "octave"):
            scene = replace(base, early=replace(base.early, level_of_detail_rays=mode),
                            settings=replace(base.settings, threads=2, seed=seed))
            log(f"furnished room, level of detail by {mode!r}, seed {seed}: until "
                f"{accuracy:g} JND or {cap_s:g} s")
            r = converge(scene, "paper", accuracy, cap_s)
            rows.append({"seed": seed, "mode": mode, **{k: r[k] for k in (
                "rays", "rounds", "converged", "cpu_seconds", "cpu_seconds_to_converge",
                "seconds", "worst_over_target")}})
            log(f"  {r['rays']:,} rays, {r['cpu_seconds']:.1f} s CPU, worst SE/target "
                f"{r['worst_over_target']:.2f}: " + (
                    "converged" if r["converged"] else
                    f"NOT converged, projected {r['cpu_seconds_to_converge']:.0f} s CPU"))
    return {"scene": "examples/furniture/furnished_room.toml", "estimator": "paper",
            "accuracy_jnd": accuracy, "cap_seconds": cap_s, "rows": rows}


def print_table(results: dict) -> None:
    """Time to converge per scene and estimator, each number said measured or projected."""
    print(f"\ntime to converge to {results['accuracy_jnd']:g} JND (2 threads); fixed estimators "
          f"capped at {results['cap_seconds']:g} s, auto at {results['auto_cap_seconds']:g} s; "
          "PROJECTED = from the 1/√n slope of the worst entry's SE at the cap")
    for name, row in results["scenes"].items():
        print(f"{name}:")
        for key, r in row.items():
            if key in ("summary", "seeds"):  # (the seeds are the table below)
                continue
            label = key.replace("_inside_auto", " (inside auto)")
            if r.get("same_as"):
                print(f"  {label:22s} = {r['same_as']} (the same bake)")
                continue
            print(f"  {label:22s} {r['seconds_to_converge']:9.0f} s  {how(r):36s} "
                  f"{r['rays']:>12,} rays in {r['seconds']:6.1f} s, worst SE/target "
                  f"{r['worst_over_target']:.2f}")
        s = row["summary"]
        print(f"  auto chose {s['auto_chose']}; fastest {s['fastest_measured']}; auto faster "
              f"than the others: {s['auto_faster_than_the_others']}")
        for r in row.get("seeds", []):
            print(f"  seed {r['seed']:<3d} auto → {r['estimator']:6s} {r['rays']:>12,} rays, "
                  f"{r['rounds']} rounds, {r['cpu_seconds']:7.1f} s CPU, "
                  + ("converged" if r["converged"] else "NOT converged"))
    lod = results.get("level_of_detail")
    if lod:
        print(f"furnished room, level of detail, paper to {lod['accuracy_jnd']:g} JND "
              f"(cap {lod['cap_seconds']:g} s): CPU time to converge")
        for r in lod["rows"]:
            print(f"  seed {r['seed']:<3d} {r['mode']:7s} {r['rays']:>10,} rays "
                  f"{r['cpu_seconds']:7.1f} s CPU  " + (
                      "converged" if r["converged"] else
                      f"NOT converged (worst {r['worst_over_target']:.2f}×): projected "
                      f"{r['cpu_seconds_to_converge']:.0f} s CPU"))


if __name__ == "__main__":
    main()
