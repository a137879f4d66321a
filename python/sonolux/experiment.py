"""The paper's experiment, end to end: the three rooms of Pope and Chalmers (6×2.5×2, 12×5×4 and
24×10×8 m), each baked into a sound field over its grid, with the central cell's reverberation
times beside Sabine and Eyring and the ratio between rooms, the front and right impulse
responses of the central cell side by side (the paper's figure 7) and their WAV files, and an
HTML report of all three (``DIR/report/index.html``).

``sonolux experiment -o DIR`` runs it; ``make demo`` calls that.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.analysis.decay import decay_times
from sonolux.audio import write_wav
from sonolux.fieldfile import save_fields
from sonolux.multisensory import bake_senses
from sonolux.scene import load_scene
from sonolux.scene.summary import summarize
from sonolux.sound.options import SoundOptions

ROOMS = ("paper-small", "paper-medium", "paper-large")


def run(out_dir: str | Path, *, rays: int | str = "auto", estimator: str = "paper",
        log: Callable[[str], None] = print, report: bool = True) -> dict[str, Any]:
    """Bakes the three rooms into ``out_dir`` and returns what it measured; ``report``
    also writes the HTML report (``out_dir/report/index.html``)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {}
    for name in ROOMS:
        scene = load_scene(name)
        theory = summarize(scene)
        started = time.perf_counter()
        # One bake for both senses: the report renders the lit room from the file's /light.
        baked = bake_senses(scene, sound_options=SoundOptions(rays=rays, estimator=estimator),
                            progress=sys.stderr.isatty(), log=lambda m: log(f"  {m}"))
        field = baked.sound
        seconds = time.perf_counter() - started
        path = save_fields(out / f"{name}.h5", sound=field, light=baked.light, bake=baked.report)
        centre = field.cell_at(*scene.sources[0].position_m[:2])
        t30 = decay_times(field.omni_energy(centre), field.bin_start_s, field.bin_width_s)["t30_s"]
        irs = {d: field.impulse_response(centre, d, seed=1) for d in ("front", "right")}
        echograms = {d: _per_millisecond(field.energy[centre, field.direction_index(d)].sum(axis=0),
                                         field.bin_start_s) for d in ("front", "right")}
        for d, ir in irs.items():
            write_wav(out / f"{name}-centre-{d}.wav", ir, field.sample_rate_hz)
        results[name] = {
            "field": str(path), "seconds": seconds, "rays": field.settings["rays"],
            "receivers": field.n_receivers, "bands_hz": field.bands_hz.tolist(),
            "t30_s": np.asarray(t30).tolist(), "sabine_t60_s": theory["sabine_t60_s"],
            "eyring_t60_s": theory["eyring_t60_s"], "irs": irs, "echograms": echograms,
            "sample_rate_hz": field.sample_rate_hz,
            "bytes_per_receiver": field.bytes_per_receiver,
        }
        lit = (f", light {baked.report['light_s']:.1f} s" if baked.light is not None else "")
        log(f"{name}: {field.n_receivers} receivers, {field.settings['rays']:,} rays in "
            f"{baked.report.get('sound_s', seconds):.1f} s{lit} -> {path}")
    log(format_table(results))
    plot_figure7(results, out / "figure7.png")
    log(f"figure 7 (front and right impulse responses of the central cell) -> {out / 'figure7.png'}")
    if report:
        index = write_report(results, out, log=log)
        log(f"report -> {index}\n  open it in any browser: file://{index.resolve()}")
    return results


def write_report(results: dict[str, Any], out: Path, *,
                 log: Callable[[str], None] = print) -> Path:
    """The HTML report of the three rooms (``out/report/index.html``): the T30 table and
    figure 7 first, the impulse responses to listen to, then each room (see
    :mod:`sonolux.report.build`), auralized when ``sonolux.auralize`` is installed."""
    from sonolux.report.build import ReportOptions, build_report

    wavs = [w for n in results for d in ("front", "right")
            if (w := out / f"{n}-centre-{d}.wav").is_file()]
    options = ReportOptions(
        title="The paper's experiment: three rooms of the same shape, 6, 12 and 24 m long",
        texts=[("Reverberation at the central cell", format_table(results))],
        figures=[(out / "figure7.png", "Figure 7: energy arriving at the central cell from the "
                  "front and from the right; the smaller the room, the sooner reflections come "
                  "and die out.")],
        audio=wavs, auralize=True)
    return build_report([Path(r["field"]) for r in results.values()], out / "report", options,
                        log=lambda m: log(f"  {m}"))


def format_table(results: dict[str, Any]) -> str:
    names = list(results)
    bands = results[names[0]]["bands_hz"]
    lines = ["T30 of the central cell (traced) beside Sabine and Eyring T60 (with air), seconds:",
             "  room            " + "".join(f"{b:>8g}" for b in bands)]
    for n in names:
        r = results[n]
        for label, key in (("traced T30", "t30_s"), ("Sabine", "sabine_t60_s"),
                           ("Eyring", "eyring_t60_s")):
            vals = "".join(f"{v:8.2f}" if v is not None else "     n/a" for v in r[key])
            lines.append(f"  {n if label == 'traced T30' else '':<14}{label:<11}"[:27] + vals)
    for a, b in zip(names, names[1:]):
        ratio = np.asarray(results[b]["t30_s"]) / np.asarray(results[a]["t30_s"])
        lines.append(f"  ratio {b.split('-')[1]}/{a.split('-')[1]:<8}"
                     + "".join(f"{v:8.2f}" for v in ratio))
    return "\n".join(lines)


def _per_millisecond(energy: np.ndarray, bin_start_s: np.ndarray) -> np.ndarray:
    """Energy summed into 1 ms bins (the early part is one-sample bins)."""
    ms = np.floor(bin_start_s * 1000 + 1e-9).astype(int)
    return np.bincount(ms, weights=energy.astype(np.float64), minlength=ms.max() + 1)


def plot_figure7(results: dict[str, Any], path: Path) -> None:
    """The central cell's front and right echograms (energy per ms, dB), one row per room,
    as the paper's figure 7: the smaller the room, the sooner reflections come and die out."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 2, figsize=(11, 2.5 * len(results)), sharex=True,
                             sharey=True, squeeze=False)
    for row, (name, r) in zip(axes, results.items()):
        # One reference per room: the strongest millisecond after the direct sound, either side.
        top = max(np.max(r["echograms"][d][2:]) for d in ("front", "right"))
        for ax, d in zip(row, ("front", "right")):
            e = r["echograms"][d]
            db = 10 * np.log10(np.maximum(e / top, 1e-12))
            t = np.arange(e.size)
            ax.fill_between(t, -70, db, step="post", color="#1f4e79", lw=0)
            ax.set_title(f"{name}, {d}", fontsize=9)
            ax.set_xlim(0, 1500)
            ax.set_ylim(-70, 5)
            ax.grid(alpha=0.3, lw=0.5)
        row[0].set_ylabel("dB")
    for ax in axes[-1]:
        ax.set_xlabel("time (ms)")
    fig.suptitle("Energy arriving at the central cell from the front and from the right, per "
                 "millisecond (the paper's figure 7)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
