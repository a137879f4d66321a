"""Safe levels: every ``sonolux ir`` and ``sonolux auralize`` example of the README and the docs
whose inputs are built in, run as written on a small bake of its scene, writes audio that
peaks at or below −1 dBFS (the default normalisation), and says the gain it applied.
``--calibrated`` keeps the field's units and warns, never clips in silence."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from sonolux import cli

from .conftest import assert_usage_error, run

REPO = Path(__file__).resolve().parents[2]
LIMIT = 10 ** (-1 / 20) * (1 + 1e-6)  # −1 dBFS, float32 rounding


def examples() -> list[tuple[str, list[str]]]:
    """(where, argv) of each ir/auralize example in a code block whose inputs need no file."""
    out = []
    for doc in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), start=1):
            m = re.match(r"^(?:\.venv/bin/)?sonolux\s+(ir|auralize)\s+(.*?)\s*(#.*)?$", line.strip())
            if not m:
                continue
            argv = [m.group(1), *shlex.split(m.group(2))]
            inputs = [a for a in argv[1:] if re.search(r"\.(flac|wav|csv|json|sofa)$", a)
                      and argv[argv.index(a) - 1] != "-o"]
            if not inputs:
                out.append((f"{doc.name}:{n}", argv))
    return out


EXAMPLES = examples()


def test_the_readme_examples_are_found():
    assert {w.split(":")[0] for w, _ in EXAMPLES} >= {"README.md", "auralize.md"}
    assert len(EXAMPLES) >= 4


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """The fields the examples name, baked small (sound only)."""
    folder = tmp_path_factory.mktemp("levels")
    names = {a for _, argv in EXAMPLES for a in argv if a.endswith(".h5")}
    scene_of = {"large.h5": "paper-large", "small.h5": "paper-small", "medium.h5": "paper-medium"}
    for name in names:
        assert cli.main(["bake", scene_of[name], "--rays", "4000", "--no-light", "-q",
                         "-o", str(folder / name)]) == 0
    return folder


@pytest.mark.parametrize(("where", "argv"), EXAMPLES, ids=[w for w, _ in EXAMPLES])
def test_every_example_peaks_at_or_below_minus_1_dbfs(capsys, baked, monkeypatch, where, argv):
    monkeypatch.chdir(baked)
    code, out, err = run(capsys, *argv)
    assert code == 0, err
    wav = baked / argv[argv.index("-o") + 1]
    x, _ = sf.read(wav, always_2d=True)
    assert np.all(np.isfinite(x)) and np.max(np.abs(x)) <= LIMIT
    assert "gain" in out and "inside its" not in err  # the listener is not in the source


def test_calibrated_keeps_the_units_and_warns_above_full_scale(capsys, baked, monkeypatch):
    monkeypatch.chdir(baked)
    field = sorted(baked.glob("*.h5"))[0]
    at = "18,5" if field.name == "large.h5" else "4.5,1.25"
    code, out, err = run(capsys, "ir", field, "--at", at, "--calibrated", "-o", "cal.wav")
    assert code == 0
    x, _ = sf.read(baked / "cal.wav", always_2d=True)
    code, _, _ = run(capsys, "ir", field, "--at", at, "-o", "norm.wav")
    y, _ = sf.read(baked / "norm.wav", always_2d=True)
    ratio = np.max(np.abs(x)) / np.max(np.abs(y))
    assert ratio == pytest.approx(10 ** (1 / 20) * np.max(np.abs(x)), rel=1e-5)  # y peaks at -1 dBFS
    if np.max(np.abs(x)) > 1:
        assert "above full scale" in err


def test_pcm_never_clips_in_silence(capsys, baked, monkeypatch):
    monkeypatch.chdir(baked)
    field = sorted(baked.glob("*.h5"))[0]
    at = "18,5" if field.name == "large.h5" else "4.5,1.25"
    code, _, err = run(capsys, "auralize", field, "builtin:clicks:0.3", "--at", at, "--gain-db",
                       "100", "--subtype", "PCM_16", "-o", "loud.wav")
    assert_usage_error(code, err, "PCM_16")
    assert not (baked / "loud.wav").exists()


@pytest.mark.parametrize("gain", ["nan", "inf", "1e6", "-1e6"])
def test_a_bad_gain_is_refused(capsys, baked, gain):
    field = sorted(baked.glob("*.h5"))[0]
    code, _, err = run(capsys, "ir", field, "--at", "1,1", f"--gain-db={gain}", "-o",
                       baked / "g.wav")
    assert_usage_error(code, err, "--gain-db", repr(gain))


MASKS = {"binaural": 0x3, "stereo": 0x3, "5.1": 0x60F, "7.1": 0x63F, "cube8": 0, "ambisonics": 0}


@pytest.mark.parametrize(("layout", "mask"), sorted(MASKS.items()))
def test_every_layout_writes_its_channel_mask(capsys, field_file, tmp_path, layout, mask):
    import struct

    out = tmp_path / "l.wav"
    code, _, err = run(capsys, "auralize", field_file, "builtin:clicks:0.2", "--at", "4.5,1.25",
                       "--layout", layout, "-o", out)
    assert code == 0, err
    head = out.read_bytes()[:100]
    at = head.find(b"fmt ")
    size, tag = struct.unpack("<IH", head[at + 4: at + 10])
    assert (size, tag) == (40, 0xFFFE)  # WAVE_FORMAT_EXTENSIBLE
    assert struct.unpack("<I", head[at + 28: at + 32])[0] == mask
