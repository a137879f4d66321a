"""Regenerates docs/validation.md from measured numbers: each physics check of the sound tracer
and its analysis, what it compares against, the tolerance and the measured result.

Run with ``make validation`` or ``.venv/bin/python benchmarks/validation.py`` (about 2 minutes
on 2 cores). Nothing in the page is typed by hand: every number is measured by this script in
the run that writes it. Exit status 1 when a check fails (the page is written all the same).
The references are independent of sonolux: closed forms, the numpy image-source model in
tests/reference/image_source.py, ISO 9613-1's table, and pyrato (pyfar) when it is installed.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # tests.reference: the independent models

import numpy as np  # noqa: E402

import sonolux  # noqa: E402
from sonolux.acoustics.theory import air_attenuation_db_per_m, eyring_t60  # noqa: E402
from sonolux.analysis.decay import decay_times  # noqa: E402
from sonolux.analysis.params import room_parameters  # noqa: E402
from sonolux.sound.bake import bake  # noqa: E402
from sonolux.sound.info import info  # noqa: E402

WALLS = ("floor", "ceiling", "west", "east", "south", "north")
BALANCES: list[float] = []  # energy balance errors of every bake of the run


def box_scene(size, alpha, scattering, receivers, radius, source):
    """A shoebox with one material per wall ({wall: absorption}) and listed receivers."""
    materials = {f"m-{w}": {"absorption": a, "scattering": scattering} for w, a in alpha.items()}
    return sonolux.load_scene({
        "name": "validation-box", "settings": {"bands_hz": [1000], "seed": 7},
        "materials": materials,
        "geometry": [{"type": "shoebox", "size_m": list(size),
                      "materials": {w: f"m-{w}" for w in alpha}}],
        "sources": [{"position_m": list(source)}],
        "receivers": {"type": "points", "positions_m": [list(r) for r in receivers],
                      "radius_m": radius}})


def traced(scene, **options):
    field = bake(scene, **options)
    BALANCES.append(max(abs(v) for v in info(field)["energy_balance_relative_error"]))
    return field


def result(name, against, tolerance, measured, ok, details):
    return {"name": name, "against": against, "tolerance": tolerance, "measured": measured,
            "ok": bool(ok), "details": details}


# --- the checks ------------------------------------------------------------------------------


def sphere_mean_inverse_square(d, a):
    """Mean of 1/ρ² over a ball of radius a whose centre is d > a from the source: a receiver
    sphere records the fluence averaged over its volume. Integrating over shells around the
    source: (π/d)(2ad + (a² - d²) ln((d+a)/(d-a))) / (4π a³/3), which tends to 1/d²."""
    return (math.pi / d) * (2 * a * d + (a * a - d * d) * np.log((d + a) / (d - a))) / (
        4 * math.pi * a**3 / 3)


def check_direct_sound():
    # All walls absorb everything: a receiver hears the direct sound only.
    d = np.array([1.0, 2.0, 4.0])
    src = (4.0, 10.0, 5.0)
    rcv = [(src[0] + x, src[1], src[2]) for x in d]
    scene = box_scene((20.0, 20.0, 10.0), dict.fromkeys(WALLS, 1.0), 0.0, rcv, 0.25, src)
    expected = sphere_mean_inverse_square(d, 0.25) / (4 * math.pi)
    rain = traced(scene, rays=20_000, air_absorption=False, estimator="rain")
    got_rain = np.array([rain.omni_energy(k)[0].sum() for k in range(3)])
    paper = traced(scene, rays=400_000, air_absorption=False, estimator="paper")
    got_paper = np.array([paper.omni_energy(k)[0].sum() for k in range(3)])
    # Paper estimator: a sphere catches a share r²/(4d²) of the rays: binomial noise.
    hits = 400_000 * 0.25**2 / (4 * d * d)
    sigma = 1 / np.sqrt(hits)
    rel_rain = np.abs(got_rain / expected - 1)
    z_paper = np.abs(got_paper / expected - 1) / sigma
    rows = [f"| {x:g} m | {e:.6g} | {a:.6g} ({100 * (a / e - 1):+.4f} %) | {b:.6g} "
            f"({100 * (b / e - 1):+.2f} %, {z:.1f} σ) |"
            for x, e, a, b, z in zip(d, expected, got_rain, got_paper, z_paper)]
    details = ("Receivers (r = 0.25 m) 1, 2 and 4 m from a 1 W source in a 20 × 20 × 10 m box "
               "whose walls absorb everything, air off, 1 kHz. A receiver records the fluence "
               "averaged over its sphere: W/(4πρ²) averaged over the ball, 1.3 % above W/(4πd²) "
               "at 1 m (closed form in the script). Energy per receiver (J/m²):\n\n"
               "| distance | W/(4πρ²) over the sphere | rain estimator (20 k rays) | paper "
               "estimator (400 k rays) |\n"
               "|---|---|---|---|\n" + "\n".join(rows))
    return result("Direct sound", "W / (4π d²) averaged over the receiver sphere",
                  "rain: 1e-4 relative; paper: 4 σ of its binomial noise",
                  f"rain {rel_rain.max():.1e}; paper {z_paper.max():.1f} σ",
                  rel_rain.max() < 1e-4 and z_paper.max() < 4, details)


def diffuse_box():
    size, alpha = (6.0, 5.0, 4.0), 0.1
    scene = box_scene(size, dict.fromkeys(WALLS, alpha), 1.0,
                      [(2.0, 2.0, 1.5), (4.5, 3.5, 2.5)], 0.5, (1.7, 1.3, 1.4))
    return scene, traced(scene, rays=20_000, air_absorption=False, estimator="rain"), size, alpha


def check_free_path_and_eyring(box):
    scene, field, size, alpha = box
    v, s = np.prod(size), 2 * (size[0] * size[1] + size[1] * size[2] + size[2] * size[0])
    mfp, theory = field.stats["mean_free_path_m"], 4 * v / s
    c = scene.settings.speed_of_sound_m_s
    eyring = eyring_t60(v, s, alpha, 0.0, c)
    gamma2 = field.stats["free_path_relative_variance"]
    kuttruff = eyring / (1 + gamma2 / 2 * np.log(1 - alpha))
    t30 = [decay_times(field.omni_energy(k)[0], field.bin_start_s, field.bin_width_s)["t30_s"]
           for k in range(2)]
    dev_e = max(abs(t / eyring - 1) for t in t30)
    dev_k = max(abs(t / kuttruff - 1) for t in t30)
    free = result("Mean free path", "4V/S", "1 %", f"{mfp:.4f} m vs {theory:.4f} m "
                  f"({100 * (mfp / theory - 1):+.2f} %)", abs(mfp / theory - 1) < 0.01,
                  f"6 × 5 × 4 m box, Lambert walls (scattering 1), α = 0.1, "
                  f"{field.stats['segments']:,} segments of 20,000 rays.")
    details = (f"Same bake, two receivers (r = 0.5 m), 1 kHz, air off. Eyring T60 {eyring:.4f} s; "
               f"Kuttruff's correction with the bake's own free-path variance γ² = {gamma2:.3f} "
               f"(Room Acoustics, 5th ed., eq. 5.50): {kuttruff:.4f} s. Traced T30: "
               + ", ".join(f"{t:.4f} s" for t in t30) + ".")
    diffuse = result("Diffuse decay", "Eyring; Kuttruff (γ²)", "3 %; 1.5 %",
                     f"{100 * dev_e:.2f} %; {100 * dev_k:.2f} %", dev_e < 0.03 and dev_k < 0.015,
                     details)
    return free, diffuse


def check_image_sources():
    from tests.reference.image_source import Shoebox, energy_histogram, image_sources

    alpha = {"floor": 0.3, "ceiling": 0.1, "west": 0.05, "east": 0.15, "south": 0.08,
             "north": 0.2}
    size, src, rcv = (5.0, 4.0, 3.0), (1.7, 1.3, 1.4), (3.6, 2.9, 1.6)
    scene = box_scene(size, alpha, 0.0, [rcv], 0.2, src)
    field = traced(scene, rays=600_000, air_absorption=False, max_time_s=0.6)
    room = Shoebox(size, absorption=alpha, c_m_s=scene.settings.speed_of_sound_m_s)
    images = image_sources(room, src, rcv, max_time_s=0.6)
    edges = np.append(field.bin_start_s, field.bin_start_s[-1] + field.bin_width_s[-1])
    a, b = field.omni_energy(0)[0], energy_histogram(images, edges)
    edc_a = 10 * np.log10(np.cumsum(a[::-1])[::-1] / a.sum())
    edc_b = 10 * np.log10(np.cumsum(b[::-1])[::-1] / b.sum())
    upto = edc_b > -30
    dev = float(np.max(np.abs(edc_a[upto] - edc_b[upto])))
    ratio = a.sum() / b.sum()
    return result("Specular shoebox", "image sources (tests/reference/image_source.py)",
                  "decay curve 1 dB to -30 dB; total 3 %",
                  f"{dev:.2f} dB; total {100 * (ratio - 1):+.2f} %",
                  dev < 1.0 and abs(ratio - 1) < 0.03,
                  f"5 × 4 × 3 m box, specular walls with six absorptions, 600,000 rays, "
                  f"{images.delay_s.size:,} image sources to 0.6 s, receiver r = 0.2 m.")


def check_paper_rooms():
    t30 = {}
    for name in ("paper-small", "paper-medium", "paper-large"):
        scene = sonolux.load_scene(name)
        receivers = replace(scene.receivers, positions_m=np.array([scene.sources[0].position_m]),
                            radius_m=0.5)
        field = traced(replace(scene, receivers=receivers), rays=150_000, air_absorption=False,
                       estimator="rain")
        t30[name] = decay_times(field.omni_energy(0).sum(axis=0), field.bin_start_s,
                                field.bin_width_s)["t30_s"]
    names = list(t30)
    ratios = [t30[b] / t30[a] for a, b in zip(names, names[1:])]
    return result("Paper rooms scale", "doubling every length doubles T (ray acoustics, no air)",
                  "ratio 2.00 ± 0.05", ", ".join(f"{r:.3f}" for r in ratios),
                  all(abs(r - 2) < 0.05 for r in ratios),
                  "T30 at the central cell (r = 0.5 m, 150,000 rays, broadband): "
                  + ", ".join(f"{n} {t:.3f} s" for n, t in t30.items())
                  + ". The source and receiver stay 1.5 m high in every room: the only break of "
                    "the scaling.")


def check_iso_9613():
    from tests.acoustics.test_theory import ISO_9613_1_TABLE_1, exact_midband_hz

    devs = [abs(air_attenuation_db_per_m(exact_midband_hz(f), t, h, 101.325) * 1000 / a - 1)
            for t, h, f, a in ISO_9613_1_TABLE_1]
    return result("Air absorption", "ISO 9613-1 Table 1 (10 points)", "1 % (3 printed digits)",
                  f"max {100 * max(devs):.2f} %", max(devs) < 0.01,
                  "Points from -20 to 30 °C, 15 to 100 % RH, 50 Hz to 10 kHz at 101.325 kPa.")


def check_decay_exact():
    from tests.analysis.fields import decaying_grid
    from tests.analysis.test_decay import TWO_SLOPES, analytic_times, decay_histogram, nonuniform_axis

    field, _, _ = decaying_grid((0.6, 1.3, 2.0))
    p = room_parameters(field, theory=False)
    dev = max(float(np.max(np.abs(p.values[n] / np.array([[0.6], [1.3], [2.0]]) - 1)))
              for n in ("edt_s", "t20_s", "t30_s"))
    start, width = nonuniform_axis(5.0)
    two = decay_times(decay_histogram(start, width, TWO_SLOPES), start, width)
    ref = analytic_times(TWO_SLOPES)
    dev2 = max(abs(two["edt_s"] / ref["edt"] - 1), abs(two["t30_s"] / ref["t30"] - 1))
    return result("Decay analysis", "exponential decays (exact T); a two-slope decay (dense "
                  "regression of its closed-form curve)", "0.5 %",
                  f"{100 * dev:.3f} %; {100 * dev2:.3f} %", dev < 0.005 and dev2 < 0.005,
                  "EDT, T20, T30 of T60 = 0.6, 1.3 and 2.0 s on the tracer's non-uniform time "
                  f"axis; two slopes: EDT {two['edt_s']:.4f} s (reference {ref['edt']:.4f}), "
                  f"T30 {two['t30_s']:.4f} s (reference {ref['t30']:.4f}).")


def check_pyrato():
    try:
        import pyfar as pf
        import pyrato as ra
    except ImportError:
        return result("Parameters vs pyrato", "pyrato (pyfar)", "-", "skipped: pip install "
                      "pyrato", True, "pyrato is not installed in this environment.")
    from tests.analysis.test_params import _ours, _pyrato

    field = traced(sonolux.load_scene("paper-medium"), estimator="paper", rays=40_000)
    fs = field.sample_rate_hz
    n = int(round((field.settings["max_time_s"] + 0.5) * fs))
    r = field.cell_at(2.0, 0.5)
    ir = field.impulse_response(r, seed=3)
    x = np.zeros(n)
    x[: ir.size] = ir
    x += np.random.default_rng(5).standard_normal(n) * math.sqrt(
        0.1 * np.mean(ir[-int(0.1 * fs):] ** 2))
    ours = _ours(x[None], fs, field.positions_m[r], field.source_positions_m[0])
    theirs = _pyrato(pf, ra, pf.Signal(x, fs))
    rel = {k: abs(ours[k][0] / theirs[k][0] - 1) for k in ("edt_s", "t20_s", "t30_s")}
    absd = {k: abs(ours[k][0] - theirs[k][0]) for k in ("c50_db", "c80_db", "d50", "ts_s")}
    ok = rel["t20_s"] < 1e-3 and rel["t30_s"] < 1e-3 and rel["edt_s"] < 0.02 and \
        absd["c80_db"] < 0.02 and absd["c50_db"] < 0.02 and absd["d50"] < 1e-3 and \
        absd["ts_s"] < 2e-4
    return result("Parameters vs pyrato", "pyrato on the same impulse response",
                  "T20/T30 0.1 %, EDT 2 %, C50/C80 0.02 dB, D50 0.001, Ts 0.2 ms",
                  f"T20 {100 * rel['t20_s']:.3f} %, T30 {100 * rel['t30_s']:.3f} %, EDT "
                  f"{100 * rel['edt_s']:.2f} %, C80 {absd['c80_db']:.3f} dB, D50 "
                  f"{absd['d50']:.4f}, Ts {1000 * absd['ts_s']:.3f} ms", ok,
                  "The pressure IR of the paper-medium cell at (2, 0.5) m (field.impulse_response) "
                  "with a noise floor; pyrato (Chu + Lundeby) on the samples, sonolux on their "
                  "energy histogram. " + ", ".join(
                      f"{k}: {ours[k][0]:.4f} vs {theirs[k][0]:.4f}" for k in theirs) + ". "
                  "Per octave band (tests/analysis/test_params.py): T20/T30 within 0.1 %.")


def check_estimators():
    scene = sonolux.load_scene("paper-small")
    fields = {e: traced(scene, estimator=e, rays=r) for e, r in (("rain", 6000),
                                                               ("paper", 60_000))}
    p = {e: room_parameters(f, theory=False) for e, f in fields.items()}
    away = np.linalg.norm(fields["rain"].positions_m - scene.sources[0].position_m, axis=1) > 0.3
    mean = {e: {k: float(np.mean(q.values[k][away, -1])) for k in ("t30_s", "g_db", "c80_db")}
            for e, q in p.items()}
    dt = abs(mean["rain"]["t30_s"] / mean["paper"]["t30_s"] - 1)
    dg = abs(mean["rain"]["g_db"] - mean["paper"]["g_db"])
    dc = abs(mean["rain"]["c80_db"] - mean["paper"]["c80_db"])
    worst = np.max(np.abs(p["rain"].values["t30_s"][away, -1]
                          / p["paper"].values["t30_s"][away, -1] - 1))
    return result("Estimators agree", "rain vs paper estimator, paper-small grid",
                  "grid means: T30 3 %, G 0.5 dB, C80 0.5 dB",
                  f"T30 {100 * dt:.1f} %, G {dg:.2f} dB, C80 {dc:.2f} dB",
                  dt < 0.03 and dg < 0.5 and dc < 0.5,
                  f"Broadband, mean over {away.sum()} receivers (the source's own cell left out), "
                  "6,000 rays (rain) and 60,000 rays (paper), about the same time. T30 "
                  f"{mean['rain']['t30_s']:.3f} s vs {mean['paper']['t30_s']:.3f} s, G "
                  f"{mean['rain']['g_db']:.2f} vs {mean['paper']['g_db']:.2f} dB, C80 "
                  f"{mean['rain']['c80_db']:.2f} vs {mean['paper']['c80_db']:.2f} dB. Single "
                  f"receivers differ by up to {100 * worst:.1f} % in T30 at these ray counts: "
                  "Monte Carlo noise, which the mean averages out.")


# --- the page --------------------------------------------------------------------------------


def page(results, seconds):
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, text=True,
                            capture_output=True).stdout.strip() or "unknown"
    dirty = subprocess.run(["git", "status", "--porcelain"], cwd=REPO, text=True,
                           capture_output=True).stdout.strip()
    lines = ["# Validation", "",
             "<!-- Written by benchmarks/validation.py: do not edit, run `make validation`. -->",
             "", "Every number on this page was measured by `benchmarks/validation.py` in the run "
             "that wrote it: the sound tracer and its analysis against closed forms and "
             "independent models. Most checks are also tests with the same tolerances "
             "(tests/sound/test_physics.py, tests/analysis/, tests/acoustics/; pyrato's in "
             "`make test-all`); the direct sound against the sphere mean and the agreement of "
             "the two estimators are checked here only. The light's checks are in "
             "docs/light.md.", "",
             f"Run: {time.strftime('%Y-%m-%d %H:%M', time.localtime())}, sonolux "
             f"{sonolux.__version__}, commit {commit}{' (with local changes)' if dirty else ''}, "
             f"{platform.machine()}, {os.cpu_count()} cores, {seconds:.0f} s.", "",
             "| check | compared against | tolerance | measured | result |", "|---|---|---|---|---|"]
    lines += [f"| {r['name']} | {r['against']} | {r['tolerance']} | {r['measured']} | "
              f"{'pass' if r['ok'] else '**FAIL**'} |" for r in results]
    for r in results:
        lines += ["", f"## {r['name']}", "", r["details"]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--output", default=str(REPO / "docs" / "validation.md"))
    args = parser.parse_args(argv)
    started = time.perf_counter()
    results = []
    box = None
    for check in (check_direct_sound, "box", check_image_sources, check_paper_rooms,
                  check_estimators, check_iso_9613, check_decay_exact, check_pyrato):
        t = time.perf_counter()
        if check == "box":
            box = diffuse_box()
            new = list(check_free_path_and_eyring(box))
        else:
            new = [check()]
        for r in new:
            print(f"{r['name']:<22} {'pass' if r['ok'] else 'FAIL'}  {r['measured']}  "
                  f"({time.perf_counter() - t:.1f} s)", flush=True)
        results += new
    worst = max(BALANCES)
    results.append(result("Energy balance", "emitted = absorbed + air + escaped + remaining",
                          "1e-9 relative", f"{worst:.1e} (worst of {len(BALANCES)} bakes)",
                          worst < 1e-9, "Every bake of this run, every band."))
    print(f"{'Energy balance':<22} {'pass' if worst < 1e-9 else 'FAIL'}  {worst:.1e}")
    seconds = time.perf_counter() - started
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", dir=out.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(page(results, seconds))
    from sonolux.outputs import follow_umask

    follow_umask(tmp)  # mkstemp makes it private
    os.replace(tmp, out)
    failed = [r["name"] for r in results if not r["ok"]]
    print(f"{len(results) - len(failed)}/{len(results)} checks pass in {seconds:.0f} s -> {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
