"""Audio files: reading dry signals and writing results, with soundfile. Writes go to a
temporary file beside the target and are renamed, so an interrupted run leaves no half file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError


def write_wav(path: str | Path, samples: np.ndarray, sample_rate_hz: int,
              subtype: str = "FLOAT") -> Path:
    """Writes float32[samples, channels] (or [samples]) as WAV (32-bit float by default)."""
    import soundfile as sf

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp.wav", dir=path.parent)
    os.close(fd)
    try:
        sf.write(tmp, np.asarray(samples, np.float32), int(sample_rate_hz), subtype=subtype,
                 format="WAV")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_audio(path: str | Path) -> tuple[np.ndarray, int]:
    """float64[samples, channels] and the sample rate; clear errors for missing or bad files."""
    import soundfile as sf

    path = Path(path)
    if not path.exists():
        raise SonoluxError(f"{path}: no such audio file")
    try:
        data, rate = sf.read(str(path), dtype="float64", always_2d=True)
    except (RuntimeError, sf.LibsndfileError) as exc:
        raise SonoluxError(f"{path}: not an audio file soundfile can read ({exc})") from None
    return data, int(rate)
