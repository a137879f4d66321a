"""How much of EDT's noise an early method could remove at best: pure particle bakes over seeds,
and EDT's standard deviation when each seed's energy before onset + T is replaced by the mean
over the seeds (a noise-free first T ms: better than any image source or early connection can
give). Per window T, the median over listeners per band. docs/early-noise.md, "What bounds EDT's
noise".

Run with ``.venv/bin/python benchmarks/early_bound.py [--scene l-room|shoebox]``. Not part of
``make bench`` (it measures where the noise is, not a speed); one run takes about as long as
``--seeds`` particle bakes.
"""

from __future__ import annotations

import argparse

import numpy as np
from early import SCENES, load

from sonolux.analysis.decay import decay_times
from sonolux.sound.bake import auto_rays, bake, bake_arrays
from sonolux.sound.options import SoundOptions

#: The noise-free windows after the direct sound (s): none, the L-room's transition, and later.
WINDOWS_S = (0.0, 0.06, 0.1, 0.2, 0.4)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="l-room", help=f"one of {', '.join(SCENES)}")
    ap.add_argument("--rays", type=int, default=0, help="rays a bake (0: the automatic count)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--max-time", type=float, default=2.5, help="s of response (default 2.5)")
    ap.add_argument("--listeners", type=int, default=8,
                    help="at most this many listeners, evenly picked (default 8)")
    args = ap.parse_args()
    if args.scene not in SCENES:
        ap.error(f"--scene: {args.scene!r}; allowed: {', '.join(SCENES)}")
    if args.rays < 0:
        ap.error(f"--rays: {args.rays}; allowed: 0 (automatic) or a positive count")
    if args.seeds < 3:
        ap.error(f"--seeds: {args.seeds}; allowed: 3 or more")
    if not (args.max_time > 0 and np.isfinite(args.max_time)):
        ap.error(f"--max-time: {args.max_time} s; allowed: a length above 0 s")
    if args.listeners < 1:
        ap.error(f"--listeners: {args.listeners}; allowed: 1 or more")
    room = SCENES[args.scene]
    if args.rays == 0:
        sc = load(room, False, 1)
        args.rays, _ = auto_rays(sc, SoundOptions(), bake_arrays(sc, SoundOptions()))
    fields = [bake(load(room, False, seed), rays=args.rays, max_time_s=args.max_time)
              for seed in range(1, args.seeds + 1)]
    sc = load(room, False, 1)
    c = sc.settings.speed_of_sound_m_s
    src = np.asarray(sc.sources[0].position_m)
    first = fields[0]
    n = first.energy.shape[0]
    picked = np.unique(np.linspace(0, n - 1, min(n, args.listeners)).round().astype(int))
    print(f"{args.scene}: {args.seeds} seeds × {args.rays} rays, listeners {picked.tolist()}; "
          f"bands {sc.settings.bands_hz}")
    for window in WINDOWS_S:
        rows = []
        for r in picked:
            onset = float(np.linalg.norm(first.positions_m[r] - src)) / c
            energy = np.array([f.omni_energy(r) for f in fields])  # [seed, band, time]
            early = first.bin_start_s < onset + window
            energy[:, :, early] = energy.mean(axis=0)[:, early]
            edt = np.array([decay_times(e, first.bin_start_s, first.bin_width_s,
                                        onset_s=onset)["edt_s"] for e in energy])
            rows.append(np.nanstd(edt, axis=0, ddof=1))
        print(f"first {window * 1e3:4.0f} ms noise-free: EDT std (s), median over listeners "
              + " ".join(f"{v:.4f}" for v in np.nanmedian(rows, axis=0)))


if __name__ == "__main__":
    main()
