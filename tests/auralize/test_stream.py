"""The block renderer as a live application drives it: any block size gives the offline
result, latency as stated, cell changes by position, bad use named."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.auralize.offline import AuralizeSettings, auralize
from sonolux.auralize.stream import StreamRenderer
from sonolux.errors import SonoluxError

from .conftest import synthetic_field


def field():
    return synthetic_field([(0.5, 0.5), (1.5, 0.5)], {(0, "right"): [(0.002, 1e-4)],
                                                      (0, "back-left"): [(0.009, 5e-5)],
                                                      (1, "front"): [(0.004, 1e-4)]})


@pytest.mark.parametrize("layout", ["binaural", "cube8", "ambisonics"])
def test_live_blocks_give_the_offline_result(layout):
    # Block 128 (live) against the offline block 8192: the same sums in another order, float32
    # spectra: 1e-5 relative.
    x = np.random.default_rng(1).standard_normal(6000)
    ref, _ = auralize(field(), x, (0.5, 0.5), 20.0, AuralizeSettings(layout=layout, order=3))
    r = StreamRenderer(field(), layout, 128, order=3)
    assert r.move_to(0.5, 0.5) == 0
    r.face(20.0)
    n = ref.shape[0]
    xp = np.zeros(-(-n // 128) * 128)
    xp[: x.size] = x
    y = np.concatenate([r.process(xp[i:i + 128]) for i in range(0, xp.size, 128)], axis=1).T[:n]
    assert np.linalg.norm(y - ref) / np.linalg.norm(ref) < 1e-5


def test_latency_is_one_block_plus_the_hrir():
    r = StreamRenderer(field(), "binaural", 256)
    assert r.latency_samples == 256 + r.spatializer.delay_samples
    assert 20 <= r.spatializer.delay_samples <= 32  # 16 (sinc) + a/c (12.2 samples)
    assert StreamRenderer(field(), "stereo", 64).latency_samples == 64


def test_moving_to_another_cell_fades_to_it():
    r = StreamRenderer(field(), "stereo", 256, fade_s=0.02)
    r.move_to(0.5, 0.5)
    x = np.zeros(256)
    x[0] = 1.0
    r.process(x)
    for _ in range(3):
        r.process(np.zeros(256))
    assert r.move_to(1.4, 0.6) == 1
    out = np.concatenate([r.process(np.zeros(256)) for _ in range(8)], axis=1)
    assert np.all(np.isfinite(out))
    assert [v.receiver for v in r._voices] == [1]  # the old cell is gone after its fade


def test_bad_use_is_named():
    with pytest.raises(SonoluxError, match="block size 8 is not allowed"):
        StreamRenderer(field(), "binaural", 8)
    r = StreamRenderer(field(), "binaural", 64)
    with pytest.raises(SonoluxError, match="no cell yet"):
        r.process(np.zeros(64))
    r.set_cell(0)
    with pytest.raises(SonoluxError, match="expected a block of 64"):
        r.process(np.zeros(65))
    with pytest.raises(SonoluxError, match="unknown layout 'binaurl'.*did you mean 'binaural'"):
        StreamRenderer(field(), "binaurl", 64)
    with pytest.raises(SonoluxError, match="outside the sound field"):
        r.move_to(10.0, 10.0)


def test_a_slow_binaural_turn_folded_into_the_filters_equals_the_keyframes():
    # Turning at 30°/s with blocks of 256: the renderer folds the HRIRs of the block's two
    # grid headings into the filters (2 channels); the
    # direction path (8 directions, HRIRs per keyframe) must give the same samples: float32
    # rounding, 1e-5 relative.
    x = np.random.default_rng(2).standard_normal(256 * 40)
    outs = []
    for fold in (True, False):
        r = StreamRenderer(field(), "binaural", 256)
        r.spatializer.grid_keyframes = fold
        r.set_cell(0)
        heading = 30.0 * np.arange(x.size) / 48000
        outs.append(np.concatenate([r.process(x[i:i + 256], heading[i:i + 256])
                                    for i in range(0, x.size, 256)], axis=1))
    assert np.linalg.norm(outs[0] - outs[1]) / np.linalg.norm(outs[1]) < 1e-5
