"""Audio files: reading dry signals and writing results, with soundfile. Writes go to a
temporary file beside the target and are renamed, so an interrupted run leaves no half file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.outputs import atomic_output

#: WAVE_FORMAT_EXTENSIBLE speaker bits (Microsoft, "Multiple channel audio data and WAVE
#: files", 2017) of the channel names our layouts use.
SPEAKER_BITS = {"L": 0x1, "R": 0x2, "C": 0x4, "LFE": 0x8, "Lrs": 0x10, "Rrs": 0x20,
                "Ls": 0x200, "Rs": 0x400, "Lss": 0x200, "Rss": 0x400,
                "left": 0x1, "right": 0x2}


def channel_mask(channel_names: list[str] | tuple[str, ...] | None) -> int:
    """The dwChannelMask of a WAV with these channels: their speaker bits when every channel
    has one and they come in the order of their bits (as the format requires); else 0, "no
    speaker assigned" (cube8's corners, ambisonic components: the docs give their order)."""
    if not channel_names:
        return 0
    bits = [SPEAKER_BITS.get(n) for n in channel_names]
    if any(b is None for b in bits) or any(a >= b for a, b in zip(bits, bits[1:])):  # type: ignore[operator]
        return 0
    return sum(bits)  # type: ignore[arg-type]


def write_wav(path: str | Path, samples: np.ndarray, sample_rate_hz: int,
              subtype: str = "FLOAT", channel_names: list[str] | tuple[str, ...] | None = None
              ) -> Path:
    """Writes float32[samples, channels] (or [samples]) as WAV (32-bit float by default).

    More than two channels (or named channels) are written as WAVE_FORMAT_EXTENSIBLE with the
    channel mask of :func:`channel_mask`, so that players do not guess the layout."""
    import soundfile as sf

    x = np.asarray(samples, np.float32)
    n_channels = 1 if x.ndim == 1 else x.shape[1]
    extensible = n_channels > 2 or channel_names is not None
    with atomic_output(path) as tmp:
        sf.write(tmp, x, int(sample_rate_hz), subtype=subtype,
                 format="WAVEX" if extensible else "WAV")
        if extensible:
            _set_channel_mask(tmp, channel_mask(channel_names))
    return Path(path)


def _set_channel_mask(path: Path, mask: int) -> None:
    """Writes dwChannelMask into the extensible 'fmt ' chunk of the WAV at ``path``."""
    import struct

    with open(path, "r+b") as f:
        head = f.read(256)
        at = head.find(b"fmt ")
        size, tag = struct.unpack("<IH", head[at + 4: at + 10]) if at >= 0 else (0, 0)
        if size < 40 or tag != 0xFFFE:
            raise SonoluxError(f"{path}: the WAV writer made no extensible header")
        f.seek(at + 8 + 20)  # cbSize, wValidBitsPerSample, then dwChannelMask
        f.write(struct.pack("<I", mask))


#: Where the peak of a written response or auralization goes by default, in dBFS.
NORMALIZE_PEAK_DBFS = -1.0


def set_level(samples: np.ndarray, gain_db: float | None = None,
              calibrated: bool = False) -> tuple[np.ndarray, float, list[str]]:
    """The samples at the level to write, the gain applied in dB, and notes for the user.

    The level chain: the field holds energy in J/m² per bin for the sources' power (in W);
    its pressure responses and auralizations are in those units, so their size depends on the
    power and the room, not on what a sound file can hold. Two modes:

    - **normalized** (the default): the peak is scaled to :data:`NORMALIZE_PEAK_DBFS`, so the
      file is safe to play; the gain applied is returned (and printed by the commands).
    - **calibrated** (``calibrated=True`` or a ``gain_db``): the samples times
      ``10^(gain_db / 20)``, nothing else, so levels compare between files. A peak above full
      scale is kept in a float file and noted (never clipped in silence).

    NaN or infinite samples are refused (an :class:`~sonolux.errors.AnalysisError`)."""
    from sonolux.errors import AnalysisError

    y = np.asarray(samples, np.float32)
    if not np.all(np.isfinite(y)):
        raise AnalysisError("the rendered audio holds NaN or infinite samples (a damaged field "
                            "file, or a gain too large for 32-bit floats)")
    notes: list[str] = []
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    if gain_db is None and not calibrated:
        if peak == 0.0:
            notes.append("the output is silent (the field holds no energy at this point)")
            return y, 0.0, notes
        gain = 10 ** (NORMALIZE_PEAK_DBFS / 20) / peak
        return (y * np.float32(gain)).astype(np.float32), 20 * float(np.log10(gain)), notes
    gain_db = 0.0 if gain_db is None else float(gain_db)
    y = (y * np.float32(10 ** (gain_db / 20))).astype(np.float32)
    out_peak = peak * 10 ** (gain_db / 20)
    if not np.all(np.isfinite(y)):
        raise AnalysisError(f"gain_db = {gain_db:g} overflows 32-bit floats (peak {peak:.3g})")
    if out_peak > 1.0:
        notes.append(f"warning: the peak is {20 * np.log10(out_peak):+.1f} dBFS, above full "
                     "scale: kept in the float file as asked (calibrated), but players will "
                     "clip it; leave out --calibrated/--gain-db to normalise")
    return y, gain_db, notes


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
