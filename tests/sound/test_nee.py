"""The sampled rain estimator ("nee"): unbiased against rain and paper, deterministic, and its
setting validated at the edge. The estimator: crates/sonolux-core/src/sound/nee.rs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import sonolux
from sonolux.errors import SettingError, SonoluxError
from sonolux.sound.bake import bake
from sonolux.sound.options import SoundOptions

pytestmark = pytest.mark.usefixtures("core")


@pytest.fixture(scope="module")
def small():
    return sonolux.load_scene("paper-small")  # 15 receivers


def with_threads(scene, n, seed=None):
    s = replace(scene.settings, threads=n, **({} if seed is None else {"seed": seed}))
    return replace(scene, settings=s)


def energy_by_receiver_band(field, window=None):
    """Energy summed over directions and time (or the time window (t0, t1) in s):
    float64[receiver, band]."""
    e = np.asarray(field.energy, dtype=np.float64)
    if window is not None:
        t = np.asarray(field.bin_start_s)
        e = e[..., (t >= window[0]) & (t < window[1])]
    return e.sum(axis=(1, 3))


def test_with_as_many_draws_as_receivers_it_is_the_rain_estimator_bit_for_bit(small):
    # M ≥ N connects every receiver once with weight 1: the rain estimator's deposits and keys.
    rain = bake(small, rays=1500, estimator="rain")
    nee = bake(small, rays=1500, estimator="nee", nee_receivers=15)
    assert np.array_equal(rain.energy, nee.energy)
    fewer = bake(small, rays=1500, estimator="nee", nee_receivers=3)
    assert not np.array_equal(rain.energy, fewer.energy)


def test_same_bits_on_one_and_two_threads_and_across_ranges(small):
    a = bake(with_threads(small, 1), rays=3000, estimator="nee", nee_receivers=3)
    b = bake(with_threads(small, 2), rays=3000, estimator="nee", nee_receivers=3)
    assert np.array_equal(a.energy, b.energy)
    parts = [bake(small, rays=3000, estimator="nee", nee_receivers=3, ray_range=r)
             for r in [(0, 700), (700, 2900), (2900, 3000)]]
    merged = parts[1].merge(parts[2]).merge(parts[0])
    assert np.array_equal(merged.energy, a.energy)
    # Parts of other M do not merge.
    other = bake(small, rays=3000, estimator="nee", nee_receivers=4, ray_range=(700, 3000))
    with pytest.raises(SonoluxError):
        parts[0].merge(other)


def test_expected_energy_per_receiver_and_band_is_the_rain_estimators(small):
    """Same rays, same paths (the draws do not touch the ray's stream): the only difference is
    which receivers each reflection reaches. Over 6 seeds the mean ratio nee / rain of the
    energy per receiver and band, whole response and late part (after 50 ms), is 1 within 4
    standard errors of the seeds' spread (plus 0.5 % for the rounding of tiny deposits)."""
    ratios_total, ratios_late = [], []
    for seed in range(6):
        sc = with_threads(small, 2, seed=100 + seed)
        rain = bake(sc, rays=4000, estimator="rain")
        nee = bake(sc, rays=4000, estimator="nee", nee_receivers=2)
        ratios_total.append(energy_by_receiver_band(nee) / energy_by_receiver_band(rain))
        late = (0.05, 10.0)
        ratios_late.append(energy_by_receiver_band(nee, late)
                           / energy_by_receiver_band(rain, late))
    for ratios in (np.array(ratios_total), np.array(ratios_late)):
        mean = ratios.mean(axis=0)
        se = ratios.std(axis=0, ddof=1) / np.sqrt(len(ratios))
        assert np.all(np.abs(mean - 1.0) <= 4 * se + 0.005), (mean, se)
        # And the pooled mean over every receiver and band, far tighter.
        pooled = ratios.mean(axis=0).ravel()
        assert abs(pooled.mean() - 1.0) < 4 * pooled.std(ddof=1) / np.sqrt(pooled.size) + 0.002


def test_total_energy_per_receiver_and_band_agrees_with_the_paper_estimator(small):
    """An independent estimator (spheres only, no connections): the energy per receiver and
    band of 60,000 rays each; the paper estimator's own spread (4 seeds) sets the tolerance."""
    sc = with_threads(small, 2)
    nee = energy_by_receiver_band(bake(sc, rays=20_000, estimator="nee", nee_receivers=3))
    papers = np.array([energy_by_receiver_band(bake(with_threads(small, 2, seed=s),
                                                    rays=15_000, estimator="paper"))
                       for s in range(4)])
    paper = papers.mean(axis=0)
    spread = papers.std(axis=0, ddof=1) / np.sqrt(len(papers))
    ratio = nee / paper
    assert np.all(np.abs(ratio - 1.0) <= 4 * spread / paper + 0.03), ratio
    assert abs(np.median(ratio) - 1.0) < 0.02


def test_nee_receivers_is_validated_at_the_edge(small):
    for bad in (0, 257, 2.5, "8"):
        with pytest.raises(SettingError, match="nee_receivers"):
            SoundOptions(estimator="nee", nee_receivers=bad).validate()
    with pytest.raises(SonoluxError, match="auto"):
        bake(small, rays=100, estimator="auto")


def test_the_command_line_refuses_a_bad_nee_receivers(tmp_path, capsys):
    from sonolux.cli.app import main

    code = main(["bake", "paper-small", "-o", str(tmp_path / "f.h5"), "--rays", "100",
                 "--estimator", "nee", "--nee-receivers", "0"])
    assert code == 2
    assert "--nee-receivers" in capsys.readouterr().err


def test_a_bake_in_receiver_tiles_has_the_bits_of_the_untiled_bake(small):
    """A memory budget smaller than the field traces the receivers in tiles; each tile is given
    the whole bake's receivers, draws among all of them (as the untiled bake does) and deposits
    only its own: the tiles together are the untiled bake, bit for bit (they used to draw within
    each tile: the same expectation, other bits)."""
    whole = bake(small, rays=1200, estimator="nee", nee_receivers=3)
    tiled = bake(small, rays=1200, estimator="nee", nee_receivers=3, memory_bytes=TILE_BYTES)
    assert tiled.stats["tiles"] > 1 and whole.stats.get("tiles", 1) == 1
    assert np.array_equal(np.asarray(whole.energy), np.asarray(tiled.energy))
    # Each tile draws for every reflection again (work counted in every tile).
    assert tiled.stats["draws"] == tiled.stats["tiles"] * whole.stats["draws"] > 0


def test_a_hybrid_in_receiver_tiles_has_the_bits_of_the_untiled_bake(small):
    """The hybrid's early diffuse connections draw their receivers like the nee estimator: in
    tiles they draw among all the bake's receivers, so the tiles are the untiled bake."""
    from dataclasses import replace

    from sonolux.scene.early import EarlySpec
    hybrid = replace(small, early=EarlySpec(max_order=1, diffraction=False,
                                            diffuse_connections=True))
    whole = bake(hybrid, rays=1200, nee_receivers=3)
    tiled = bake(hybrid, rays=1200, nee_receivers=3, memory_bytes=TILE_BYTES)
    assert tiled.stats["tiles"] > 1 and whole.stats["draws"] > 0
    assert np.array_equal(np.asarray(whole.energy), np.asarray(tiled.energy))


#: A memory budget that makes paper-small's field (15 receivers, 1200 rays) go in tiles of a few
#: receivers (0.3 GB for the rest of the bake, ~5 MB to trace a receiver: sound/budget.py).
TILE_BYTES = 318_000_000
