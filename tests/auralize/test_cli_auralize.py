"""``sonolux auralize``: a point, a walk, and every kind of bad input named clearly."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from sonolux import cli
from sonolux.fieldfile import save_fields

from .conftest import FS, synthetic_field


@pytest.fixture
def field_file(tmp_path):
    f = synthetic_field([(0.5, 0.5), (1.5, 0.5)], {(0, "right"): [(0.003, 1e-4)],
                                                    (1, "left"): [(0.006, 1e-4)]})
    return save_fields(tmp_path / "field.h5", sound=f)


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_builtin_signal_at_a_point_is_a_float_wav(capsys, tmp_path, field_file):
    out = tmp_path / "out.wav"
    code, text, err = run(capsys, "auralize", field_file, "builtin:clicks:0.5", "--at", "0.5,0.5",
                          "--heading", "0", "--layout", "binaural", "-o", out)
    assert code == 0, err
    info = sf.info(str(out))
    assert (info.samplerate, info.channels, info.subtype) == (FS, 2, "FLOAT")
    y, _ = sf.read(out)
    assert np.sum(y[:, 1] ** 2) > 10 * np.sum(y[:, 0] ** 2)  # the arrival is on the right
    assert "cell #0" in text and "left, right" in text


@pytest.mark.parametrize("layout,order,channels", [("cube8", 1, 8), ("ambisonics", 3, 16),
                                                   ("5.1", 1, 6), ("7.1", 1, 8),
                                                   ("stereo", 1, 2)])
def test_every_layout_and_normalize(capsys, tmp_path, field_file, layout, order, channels):
    out = tmp_path / "out.wav"
    code, _, err = run(capsys, "auralize", field_file, "builtin:noise:0.3", "--at", "0.5,0.5",
                       "--layout", layout, "--order", order, "--normalize", "-o", out)
    assert code == 0, err
    y, rate = sf.read(out)
    assert y.shape[1] == channels and np.isclose(np.max(np.abs(y)), 10 ** (-1 / 20), rtol=1e-6)


def test_a_stereo_file_at_another_rate_is_mixed_and_resampled(capsys, tmp_path, field_file):
    dry = tmp_path / "dry.wav"
    sf.write(dry, np.random.default_rng(0).standard_normal((22050, 2)) * 0.1, 44100)
    out = tmp_path / "out.wav"
    code, text, err = run(capsys, "auralize", field_file, dry, "--at", "0.5,0.5", "--layout",
                          "stereo", "-o", out)
    assert code == 0, err
    assert "2 channels mixed to mono" in text and "resampled 44100 -> 48000 Hz" in text
    assert sf.info(str(out)).frames >= 24000


def test_a_walk_writes_audio_and_its_plan_view(capsys, tmp_path, field_file):
    path = tmp_path / "walk.csv"
    path.write_text("time,x,y\n0,0.6,0.5\n1,1.4,0.5\n")
    out = tmp_path / "walk.wav"
    code, text, err = run(capsys, "auralize", field_file, "builtin:speech", "--path", path,
                          "--layout", "stereo", "-o", out)
    assert code == 0, err
    assert (tmp_path / "walk.png").exists() and "2 cells: #0 #1" in text
    outside = tmp_path / "out.csv"
    outside.write_text("time,x,y\n0,0.6,0.5\n1,4,0.5\n")
    code, _, err = run(capsys, "auralize", field_file, "builtin:speech", "--path", outside,
                       "-o", out)
    assert code == 2 and "leaves the sound field" in err and "--outside clamp" in err


def test_bad_input_is_a_clear_error(capsys, tmp_path, field_file):
    out = tmp_path / "out.wav"
    with pytest.raises(SystemExit) as e:
        cli.main(["auralize", str(field_file), "builtin:speech", "--at", "0.5,0.5", "--layout",
                  "quad", "-o", str(out)])
    assert e.value.code == 2 and "invalid choice: 'quad'" in capsys.readouterr().err
    code, _, err = run(capsys, "auralize", field_file, tmp_path / "missing.wav", "--at",
                       "0.5,0.5", "-o", out)
    assert code == 2 and "missing.wav: no such audio file" in err
    corrupt = tmp_path / "corrupt.wav"
    corrupt.write_bytes(b"RIFF\x00\x00\x00\x00WAVEjunk")
    code, _, err = run(capsys, "auralize", field_file, corrupt, "--at", "0.5,0.5", "-o", out)
    assert code == 2 and "corrupt.wav: not an audio file" in err
    code, _, err = run(capsys, "auralize", field_file, "builtin:speech", "--at", "9,9", "-o", out)
    assert code == 2 and "outside the sound field" in err
    code, _, err = run(capsys, "auralize", field_file, "builtin:speech", "--at", "0.5,0.5",
                       "--layout", "stereo", "--hrtf", tmp_path / "x.sofa", "-o", out)
    assert code == 2 and "only used with the binaural layout" in err
    code, _, err = run(capsys, "auralize", field_file, "builtin:speech", "--at", "0.5,0.5",
                       "--hrtf", tmp_path / "x.sofa", "-o", out)
    assert code == 2 and "x.sofa: no such SOFA file" in err
    assert not out.exists()
