"""A hybrid field's exact early arrivals (image sources: docs/early-sound.md) reach the web
bundle: each at its own sample, in the response of the direction it comes from, with at least
its energy; so the viewer plays discrete early reflections from their sectors."""

from __future__ import annotations

import json
import math
import zlib

import numpy as np
import pytest

import sonolux
from sonolux.fieldfile import save_fields
from sonolux.sound.bake import bake
from sonolux.web import WebExportOptions, export_web

pytestmark = pytest.mark.usefixtures("core")

SIZE = (5.0, 4.0, 3.0)
SOURCE = (1.7, 1.3, 1.4)
RECEIVERS = [(3.6, 2.9, 1.6), (1.0, 3.0, 1.5)]


@pytest.fixture(scope="module")
def hybrid(tmp_path_factory):
    """A specular shoebox baked as a hybrid: images to order 2 before 40 ms, particles after.
    The walls absorb the same in every band and the air is left out, so every bin holds the
    same energy in each band and the synthesis keeps an arrival a single spike (synthesis.py:
    a histogram equal in every band gives p = s)."""
    alpha = [0.1] * 8  # the library's eight bands, 63..8000 Hz
    sc = sonolux.load_scene({
        "name": "early-bundle", "settings": {"bands_hz": [500, 1000], "seed": 4},
        "materials": {"wall": {"absorption": alpha, "scattering": [0.0] * 8}},
        "geometry": [{"type": "shoebox", "size_m": list(SIZE), "materials": {"default": "wall"}}],
        "sources": [{"position_m": list(SOURCE)}],
        "receivers": {"type": "points", "positions_m": [list(r) for r in RECEIVERS],
                      "radius_m": 0.1},
        "early": {"max_order": 2, "transition_ms": 40},
    })
    field = bake(sc, rays=3000, air_absorption=False, max_time_s=0.15)
    path = tmp_path_factory.mktemp("early") / "hybrid.h5"
    save_fields(path, sound=field)
    return path


def test_early_arrivals_are_in_their_directions_responses_at_their_samples(hybrid, tmp_path):
    export_web(hybrid, tmp_path / "b", WebExportOptions(tail_db=None, seed=1, responses="pcm"))
    index = json.loads((tmp_path / "b" / "field.json").read_text())
    data = (tmp_path / "b" / "responses.bin").read_bytes()
    field = sonolux.open(hybrid)
    fs = field.sample_rate_hz
    early = field.early
    assert early is not None
    images = np.flatnonzero(early["kind"] == 0)
    assert images.size >= 2 * 19  # orders 0..2 of a shoebox: 1 + 6 + 18 per receiver, most valid
    checked = 0
    for k in images:
        r, d, t = int(early["receiver"][k]), int(early["direction_bin"][k]), int(early["time_bin"][k])
        # One-sample bins hold the arrival at its exact time.
        assert t == math.floor(float(early["time_s"][k]) * fs + 1e-6)
        # Its sector is the one it comes from: the sector's centre (the bundle's direction
        # table, where the viewer places that response) is within half a sector of it.
        v = early["from_direction"][k]
        azimuth = math.degrees(math.atan2(v[1], v[0])) % 360
        centre = index["directions"][d]["azimuth_deg"]
        assert abs((azimuth - centre + 180) % 360 - 180) <= 22.5 + 1e-9
        # The response of that cell and sector, as the viewer decodes it, holds a spike at that
        # sample of at least the arrival's energy (to the int16 step).
        c = index["cells"][r]
        delay, length, offset, scale = c["full"][d]
        raw = zlib.decompress(data[c["byte_offset"]:c["byte_offset"] + c["byte_length"]])
        x = np.frombuffer(raw, np.int16)[offset:offset + length] * scale
        at = t - delay
        assert 0 <= at < x.size
        amplitude = math.sqrt(float(np.mean(early["energy"][k])) * fs)
        assert abs(x[at]) >= amplitude - 0.5 * scale
        checked += 1
    assert checked == images.size
    # The direct sound leads each cell's response in the source's direction, at full size.
    for r in range(len(RECEIVERS)):
        mine = images[early["receiver"][images] == r]
        first = mine[np.argmin(early["time_s"][mine])]
        d = int(early["direction_bin"][first])
        assert index["cells"][r]["full"][d][0] == int(early["time_bin"][first])  # its delay


def test_a_compact_bundle_carries_each_arrival_with_its_own_direction(hybrid, tmp_path):
    """sonolux-web/3 of a hybrid field: every image-source arrival within the one-sample bins
    is in its cell's block with its sample, its direction bin, its direction (azimuth,
    elevation of from_direction) and its energy per band, so the viewer pans it from its own
    direction (web/src/synth/synthesis.ts, panArrival). (Arrivals that the compact field keeps
    in its envelope, not exact, are not listed: here, two receivers, all are exact.)"""
    export_web(hybrid, tmp_path / "b", WebExportOptions(seed=1))
    index = json.loads((tmp_path / "b" / "field.json").read_text())
    data = (tmp_path / "b" / "responses.bin").read_bytes()
    assert index["format"] == "sonolux-web/3"
    field = sonolux.open(hybrid)
    early = field.early
    n_b = len(index["synthesis"]["bands_hz"])
    eb = index["synthesis"]["early_bins"]
    checked = 0
    for r, c in enumerate(index["cells"]):
        (f,) = c["fields"]
        raw = zlib.decompress(data[c["byte_offset"]:c["byte_offset"] + c["byte_length"]])
        n_d = len(index["directions"])
        at = f["byte_offset"] + 4 * (2 * f["arrivals"] + n_d * n_b * (f["envelope_bins"]
                                                                     + f["late_bins"]))
        m = f["exact_arrivals"]
        sample_bin = np.frombuffer(raw, "<u4", 2 * m, at).reshape(m, 2)
        direction = np.frombuffer(raw, "<f4", 2 * m, at + 8 * m).reshape(m, 2)
        energy = np.frombuffer(raw, "<f4", n_b * m, at + 16 * m).reshape(m, n_b)
        mine = np.flatnonzero((early["receiver"] == r) & (early["time_bin"] >= 0)
                              & (early["time_bin"] < eb))
        assert m == mine.size > 0
        for row, k in enumerate(mine):
            assert tuple(sample_bin[row]) == (early["time_bin"][k], early["direction_bin"][k])
            v = early["from_direction"][k]
            assert direction[row][0] == pytest.approx(math.degrees(math.atan2(v[1], v[0])) % 360,
                                                      abs=1e-4)
            assert direction[row][1] == pytest.approx(math.degrees(math.asin(v[2])), abs=1e-4)
            np.testing.assert_allclose(energy[row], early["energy"][k], rtol=1e-6)
            checked += 1
    assert checked >= 2 * 19
