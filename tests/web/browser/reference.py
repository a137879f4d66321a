"""The library's responses of one cell of a sonolux-web/3 bundle, and the impulses it used, as
JSON on stdout, for tests/web/browser/synthesis.test.ts (which gives the same impulses to the
browser's worker and compares the responses).

    python reference.py FIELD.h5 CELL [SEED]

The cell is written as `sonolux.web` writes it with the default options (seed 0 unless given),
so it is the bundle's cell; each direction's response is
:func:`sonolux.web.compact_cells.cell_response` (pressure_ir of the decoded histogram), and its
impulses are drawn as :func:`sonolux.sound.synthesis.weighted_sequences` draws them.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from sonolux.fieldfile import open_field
from sonolux.sound.synthesis import _check_histogram, _sample_groups, poisson_impulses
from sonolux.web.bundle import source_fields
from sonolux.web.compact_cells import (
    axis_of,
    cell_response,
    cut_bins,
    cut_cell,
    dense_histogram,
    pressure_energy,
    receiver_compact,
    reduced_energy,
    stored_energy_per_bin,
    time_bins,
)
from sonolux.web.options import TAIL_DB


def impulses(h, axis, fs, volume, c, seed):
    """The impulses (after the empty bins got theirs) that weighted_sequences uses."""
    start_s, width_s = time_bins(axis, h.shape[-1], fs)
    e, a, b = _check_histogram(h, start_s, width_s, fs)
    has = np.flatnonzero(e.sum(axis=0) > 0)
    if has.size == 0:
        return np.zeros(0)
    n = int(np.ceil(b[has[-1]]))
    group, first, size = _sample_groups(a, n, max(n, int(np.ceil(b[-1]))))
    rng = np.random.default_rng(seed)
    x = poisson_impulses(n / fs, fs, volume, c, rng, t0_s=a[has[0]] / fs)
    power = np.bincount(group, weights=x * x, minlength=a.size)
    empty = np.flatnonzero((e.sum(axis=0) > 0) & (power == 0) & (size > 0))
    where = first[empty] + np.floor(rng.random(empty.size) * size[empty]).astype(np.int64)
    x[where] = rng.choice([-1.0, 1.0], size=empty.size)
    return x


def main() -> None:
    path, r = sys.argv[1], int(sys.argv[2])
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    sound = open_field(path)
    fields = source_fields(sound)
    axis = axis_of(sound)
    fs = sound.sample_rate_hz
    volume, c = float(sound.settings["volume_m3"]), float(sound.settings["speed_of_sound_m_s"])
    bands = sound.synthesis_bands_hz
    parts = [receiver_compact(f, *reduced_energy(f), r) for _, f in fields]
    per_bin = pressure_energy(sum(stored_energy_per_bin(p, axis) for p in parts), bands, fs)
    late_bins, length = cut_bins(per_bin, axis, TAIL_DB)
    n_dir, n_cells = sound.energy.shape[1], sound.n_receivers
    out = []
    for j, p in enumerate(parts):
        dense = dense_histogram(cut_cell(p, late_bins), axis)
        part = {"impulses": [], "full": []}
        for d in range(n_dir):
            s = seed + (j * n_cells + r) * n_dir + d
            part["impulses"].append(impulses(dense[d], axis, fs, volume, c, s).tolist())
            part["full"].append(cell_response(dense[d], axis, length, fs, volume, c, bands,
                                              s).tolist())
        out.append(part)
    json.dump({"length": length, "parts": out}, sys.stdout)


if __name__ == "__main__":
    main()
