"""Level of detail (docs/early-sound.md, crates/sonolux-core/src/early/lod.rs): Rindel's
finite-panel specular share K, computed per reflection from the legs before and after it
(Christensen and Rindel's reflection-based scattering), applied alike by the image sources and
the particles.

- no double counting with level of detail on: a hybrid (image sources to order 2) and a bake
  whose reflections are all the particles' agree in energy per band within the Monte Carlo
  error, in a room with furniture whose small faces make K < 1;
- what level of detail changes: the furniture's faces scatter more at low frequencies, so the
  early specular energy falls there and not at high frequencies;
- same bits on 1 and 2 threads.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import sonolux
from sonolux.sound.bake import bake

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "furniture"))
from rooms import boxes_on_wall, furniture, write_obj  # noqa: E402

pytestmark = pytest.mark.usefixtures("core")

BANDS = [125, 250, 500, 1000, 2000, 4000]
ROOM = (7.0, 5.0, 2.8)
SOURCE = (5.8, 1.2, 1.5)
RECEIVERS = ((1.5, 1.2, 1.2), (3.5, 4.2, 1.2))


def furnished(tmp_path: Path, early: dict, seed: int = 1, threads: int = 0):
    obj = tmp_path / "furniture.obj"
    if not obj.exists():
        write_obj(obj, furniture())
    data = {
        "name": "furnished", "settings": {"bands_hz": BANDS, "seed": seed, "threads": threads},
        "materials": {"wood": {"absorption": 0.06, "scattering": [0.05] * 4 + [0.3] * 4},
                      "room": {"absorption": [0.25, 0.2, 0.15, 0.12, 0.1, 0.1, 0.12, 0.15],
                               "scattering": 0.1}},
        "geometry": [{"type": "shoebox", "size_m": list(ROOM), "materials": {"default": "room"}},
                     {"type": "mesh", "file": str(obj), "material": "wood"}],
        "sources": [{"position_m": list(SOURCE)}],
        "receivers": {"type": "points", "positions_m": [list(r) for r in RECEIVERS],
                      "radius_m": 0.3},
        "early": dict({"diffraction": False, "level_of_detail": True}, **early),
    }
    return sonolux.load_scene(data)


def totals(field, split_s):
    """Energy per receiver and band before and after split_s, float64[receiver, 2 · band]."""
    out = []
    for r in range(field.energy.shape[0]):
        e = field.omni_energy(r)
        before = field.bin_start_s < split_s
        out.append(np.concatenate([e[:, before].sum(axis=1), e[:, ~before].sum(axis=1)]))
    return np.array(out)


def test_level_of_detail_counts_nothing_twice(tmp_path):
    # Same seeds, hybrid (image sources to order 2 with K, particles leave those paths out)
    # against a bake whose reflections are all the particles' (order 0: the exact direct sound
    # only), both with level of detail. Before the transition the difference is (images' K-
    # weighted energy) − (particles' specular-only part with s' = 1 − (1 − s)K), zero in
    # expectation; the mean over seeds must lie within 4 standard errors of zero, per band and
    # receiver. After the transition both count the same paths.
    diffs, ref = [], []
    for seed in (21, 22, 23, 24, 25):
        kw = dict(seed=seed)
        pure = bake(furnished(tmp_path, {"max_order": 0, "transition_ms": 30}, **kw),
                    rays=20_000, air_absorption=False, max_time_s=0.25)
        hybrid = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 30}, **kw),
                      rays=20_000, air_absorption=False, max_time_s=0.25)
        p, h = totals(pure, 0.030), totals(hybrid, 0.030)
        diffs.append(h - p)
        ref.append(p)
    diffs, ref = np.array(diffs), np.mean(ref, axis=0)
    mean, err = diffs.mean(axis=0), diffs.std(axis=0, ddof=1) / math.sqrt(len(diffs))
    assert np.all(np.abs(mean) <= 4 * err + 1e-6 * ref), (mean / ref, err / ref)
    assert np.all(np.abs(mean) / ref < 0.05), mean / ref


def test_level_of_detail_takes_specular_energy_from_small_faces_at_low_frequencies(tmp_path):
    # The image sources alone: with level of detail, reflections on the furniture (table top
    # 3 × 1.2 m, chair seats 0.45 m, shelves 0.35 m deep) lose their specular share where the
    # panel is small against the wavelength, reflections on the 7 × 5 m floor and ceiling do
    # not. So the early specular energy falls more at 125 Hz than at 4 kHz, and never rises.
    on = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 40}), rays=200,
              air_absorption=False, max_time_s=0.1)
    off = bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 40,
                                    "level_of_detail": False}), rays=200,
               air_absorption=False, max_time_s=0.1)
    e_on, e_off = on.early["energy"], off.early["energy"]
    assert len(e_on) == len(e_off)
    assert np.all(e_on <= e_off * (1 + 1e-12))
    ratio = e_on.sum(axis=0) / e_off.sum(axis=0)
    assert ratio[0] < ratio[-1] and ratio[0] < 0.999, ratio


def test_level_of_detail_is_the_same_on_one_and_two_threads(tmp_path):
    fields = [bake(furnished(tmp_path, {"max_order": 2, "transition_ms": 30}, threads=t),
                   rays=3000, air_absorption=False, max_time_s=0.2) for t in (1, 2)]
    np.testing.assert_array_equal(fields[0].energy, fields[1].energy)
    for k, v in fields[0].early.items():
        np.testing.assert_array_equal(fields[1].early[k], v)
