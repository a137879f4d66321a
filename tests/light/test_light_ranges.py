"""The light bake in particle ranges: summed in any order, checkpointed and resumed, the same
bits as one bake, work plane and energy tallies included."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux import checkpoint as side
from sonolux.errors import SonoluxError
from sonolux.light.bake import bake_light
from sonolux.light.ranges import LightRanges, bake
from sonolux.range_bake import bake_ranges
from sonolux.ranges import Checkpointing

PARTICLES = 20_000
TALLIES = ("flux_emitted_w", "flux_absorbed_w", "flux_escaped_w", "flux_roulette_w")


@pytest.fixture(scope="module")
def lit(core):
    """A room lit by its ceiling, with a work plane (so that its counts merge too)."""
    return sonolux.load_scene({
        "name": "lit",
        "materials": {"wall": {"absorption": 0.3, "diffuse_rgb": [0.6, 0.5, 0.4]},
                      "lamp": {"absorption": 0.3, "diffuse_rgb": [0.8, 0.8, 0.8]}},
        "geometry": [{"type": "shoebox", "size_m": [4, 3, 2.5],
                      "materials": {"default": "wall", "ceiling": "lamp"}}],
        "lights": [{"type": "surface", "material": "lamp", "power_w": 50.0}],
        "workplane": {"height_m": 0.8, "spacing_m": 0.5},
    })


@pytest.fixture(scope="module")
def whole(lit):
    return bake_light(lit, particles=PARTICLES, patch_size_m=0.5)


def same_bits(a, b):
    assert np.array_equal(a.flux_w, b.flux_w) and np.array_equal(a.hits, b.hits)
    for k in (*TALLIES, "particles", "bounces", "escaped_particles"):
        assert a.stats[k] == b.stats[k], k
    if a.workplane is not None:
        assert np.array_equal(a.workplane.illuminance_lx, b.workplane.illuminance_lx)


def test_ranges_summed_in_any_order_give_the_bits_of_one_bake(lit, whole):
    work = LightRanges(lit, sonolux.LightOptions(particles=PARTICLES, patch_size_m=0.5))
    cuts = [(13_001, 20_000), (0, 7), (7, 13_001)]  # uneven, out of order
    total = None
    for a, b in cuts:
        total = work.add(total, work.trace(a, b, threads=1))
    field = work.finish(total, cuts)
    assert whole.workplane is not None
    same_bits(field, whole)
    assert field.stats["particles"] == PARTICLES


def test_checkpointed_bake_resumes_to_the_same_bits(lit, whole, tmp_path):
    path = tmp_path / "f.h5.light.checkpoint"

    class Stop(Exception):
        pass

    seen = []

    def stop_after_two(done, total, elapsed):
        if done % 4000 == 0 and done and done not in seen:
            seen.append(done)
            if len(seen) == 2:
                raise Stop
        return True

    options = sonolux.LightOptions(particles=PARTICLES, patch_size_m=0.5)
    with pytest.raises(Stop):
        bake_ranges(LightRanges(lit, options), checkpoint=path, checkpoint_every_s=0,
                    range_rays=4000, progress=stop_after_two)
    header, _ = side.read(path)
    assert header["kind"] == "light" and header["done"] == [[0, 4000]]
    with pytest.raises(SonoluxError, match="--resume"):
        bake_ranges(LightRanges(lit, options), checkpoint=path)
    field, report = bake_ranges(LightRanges(lit, options), checkpoint=path, resume=True,
                                range_rays=4000)
    assert report["restored"] == 4000
    same_bits(field, whole)


def test_a_checkpoint_of_other_settings_is_refused(lit, tmp_path):
    path = tmp_path / "f.h5.light.checkpoint"
    field = bake(lit, particles=PARTICLES, patch_size_m=0.5, checkpoint=path,
                 checkpoint_every_s=0, range_particles=PARTICLES // 2)
    assert not path.exists() and field.settings["particles"] == PARTICLES
    work = LightRanges(lit, sonolux.LightOptions(particles=PARTICLES, patch_size_m=0.5))
    total = work.trace(0, 5000)
    Checkpointing(path).save(work, total, [(0, 5000)])
    other = LightRanges(lit, sonolux.LightOptions(particles=PARTICLES, patch_size_m=0.25))
    with pytest.raises(SonoluxError, match="another bake.*settings"):
        bake_ranges(other, checkpoint=path, resume=True)
