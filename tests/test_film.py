"""The walk-through film: N frames at the path's times, a soundtrack as long as the picture
(within one frame), in sync, and the walk's auralization inside it (AAC-coded, nothing lost at
the encoder's block joins)."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.auralize.walk import load_path
from sonolux.errors import SonoluxError
from sonolux.film import FilmSettings, make_film, soundtrack
from sonolux.multisensory import bake_senses

av = pytest.importorskip("av")
FPS = 10


@pytest.fixture(scope="module")
def fields():
    if not engine.core_available():
        pytest.skip("the compiled core is not built (SONOLUX_TESTS_WITHOUT_CORE=1)")
    scene = sonolux.load_scene({
        "name": "film",
        "materials": {"wall": {"absorption": 0.3, "diffuse_rgb": [0.6, 0.5, 0.4]},
                      "lamp": {"absorption": 0.3, "diffuse_rgb": [0.8, 0.8, 0.8]}},
        "geometry": [{"type": "shoebox", "size_m": [6, 4, 3],
                      "materials": {"default": "wall", "ceiling": "lamp"}}],
        "lights": [{"type": "surface", "material": "lamp", "power_w": 30.0}],
        "sources": [{"position_m": [4.5, 2, 1.5]}],
        "receivers": {"height_m": 1.5, "spacing_m": 1.0},
    })
    both = bake_senses(scene, sound_options=sonolux.SoundOptions(rays=4000),
                       light_options=sonolux.LightOptions(particles=40_000))
    return both.sound, both.light


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    path = tmp_path_factory.mktemp("film") / "walk.csv"
    path.write_text("time,x,y,heading\n0,1.0,1.0,0\n1.5,3.5,1.0,0\n2.5,3.5,2.5,90\n")
    return path


def test_film_frames_sound_and_sync(fields, walk, tmp_path):
    sound, light = fields
    out = tmp_path / "walk.mp4"
    settings = FilmSettings(fps=FPS, width_px=160, height_px=90)
    done = make_film(sound, light, "builtin:speech", walk, out, settings)
    assert len(done["cells"]) >= 3  # the walk crosses cells
    expected, _, _ = soundtrack(sound, "builtin:speech", load_path(walk), settings)
    fs = sound.sample_rate_hz
    assert done["frames"] == int(np.ceil(expected.shape[0] * FPS / fs))
    with av.open(str(out)) as c:
        times = [float(f.time) for f in c.decode(video=0)]
    with av.open(str(out)) as c:
        audio = np.concatenate([f.to_ndarray() for f in c.decode(audio=0)], axis=1).T
        rate = c.streams.audio[0].rate
    # N frames at t = k / fps.
    assert len(times) == done["frames"]
    assert np.allclose(times, np.arange(done["frames"]) / FPS, atol=1e-6)
    # Audio as long as the picture, within one frame (AAC pads its last block).
    assert rate == fs and audio.shape[1] == 2
    assert abs(audio.shape[0] / fs - done["frames"] / FPS) < 1 / FPS
    # In sync and whole: the decoded track is the walk's auralization, shifted by less than a
    # frame (the encoder's priming; measured 0), correlated above 0.98 (measured 0.9996); no block
    # of 1024 samples differs by more than a fifth of the track's RMS (measured 0.09: AAC's
    # coding noise; a lost or repeated block at a join would be of the signal's own size).
    ref = expected[:, 0] / np.max(np.abs(expected))
    got = audio[:, 0] / np.max(np.abs(expected))
    n = min(ref.size, got.size)
    lags = np.arange(-2048, 2049)
    corr = [np.dot(ref[max(0, -k):n - max(0, k)], got[max(0, k):n - max(0, -k)]) for k in lags]
    lag = int(lags[int(np.argmax(corr))])
    assert abs(lag) < fs / FPS
    a, b = ref[max(0, -lag):n - max(0, lag)], got[max(0, lag):n - max(0, -lag)]
    assert np.corrcoef(a, b)[0, 1] > 0.98
    rms = np.sqrt(np.mean(a ** 2))
    blocks = (a[:a.size // 1024 * 1024] - b[:a.size // 1024 * 1024]).reshape(-1, 1024)
    assert np.max(np.sqrt(np.mean(blocks ** 2, axis=1))) < 0.2 * rms


def test_film_refuses_bad_settings_and_names(fields, walk, tmp_path):
    sound, light = fields
    with pytest.raises(SonoluxError, match="must end in one of"):
        make_film(sound, light, "builtin:speech", walk, tmp_path / "w.avi")
    with pytest.raises(SonoluxError, match="width_px = 161"):
        make_film(sound, light, "builtin:speech", walk, tmp_path / "w.mp4",
                  FilmSettings(width_px=161))
    assert not list(tmp_path.iterdir())  # nothing half-written left behind
