"""What the report borrows from the other halves of sonolux: the light view (when the field
file holds ``/light``: :func:`sonolux.light.view.render_view`) and auralizations
(:func:`sonolux.auralize.to_file.auralize_to_file`), called as library functions; when either
fails, the report says so and goes on. Also a dry signal generated here, and browser-friendly
copies of WAV files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sonolux.audio import read_audio, write_wav
from sonolux.errors import SonoluxError

#: Layouts the report auralizes to: headphones, and the paper's cube of 8 loudspeakers.
REPORT_LAYOUTS = ("binaural", "cube8")


def has_light(field_path: Path) -> bool:
    from sonolux.fieldfile import contents

    try:
        return bool(contents(field_path)["light"])
    except SonoluxError:
        return False


def render_light_view(field_path: Path, png: Path) -> str:
    """Renders the field's lit scene to ``png`` with the default camera: '' or why not."""
    from sonolux.fieldfile import open_light_field
    from sonolux.light.view import render_view

    if not has_light(field_path):
        return "this field file holds no light field (bake with light to see the lit room)"
    try:
        render_view(open_light_field(field_path), png)
    except SonoluxError as exc:
        return f"the light view could not be rendered: {exc}"
    return ""


def dry_signal(sample_rate_hz: int, seconds: float = 3.0) -> np.ndarray:
    """A dry test signal float32[samples]: two clicks, then six plucked notes (a decaying
    sum of harmonics), then a short noise burst. Deterministic (seed 0)."""
    fs = sample_rate_hz
    out = np.zeros(int(seconds * fs))
    out[int(0.05 * fs)] = 0.9
    out[int(0.30 * fs)] = 0.9
    t = np.arange(int(0.35 * fs)) / fs
    for k, semitone in enumerate((0, 4, 7, 12, 7, 4)):
        f0 = 261.63 * 2 ** (semitone / 12)
        note = sum(np.sin(2 * np.pi * h * f0 * t) / h ** 1.5 for h in range(1, 8))
        note *= np.exp(-t / 0.08) * (1 - np.exp(-t / 0.002))
        start = int((0.6 + 0.28 * k) * fs)
        out[start:start + t.size] += 0.35 * note[: out.size - start]
    burst = np.random.default_rng(0).standard_normal(int(0.12 * fs)) * 0.25
    start = int(2.5 * fs)
    out[start:start + burst.size] += burst * np.hanning(burst.size)
    return out.astype(np.float32)


def auralize(field_path: Path, dry_wav: Path, at_m: tuple[float, float], out_dir: Path,
             stem: str) -> tuple[list[tuple[Path, str]], str]:
    """Auralizes ``dry_wav`` at the cell to each of REPORT_LAYOUTS: ([(wav, caption)], note)."""
    from sonolux.auralize.offline import AuralizeSettings
    from sonolux.auralize.to_file import Listening, auralize_to_file
    from sonolux.fieldfile import open_field

    field = open_field(field_path)
    made, failures = [], []
    for layout in REPORT_LAYOUTS:
        wav = out_dir / f"{stem}-{layout}.wav"
        try:
            auralize_to_file(field, str(dry_wav), wav, Listening(at_m=at_m, heading_deg=0.0),
                             AuralizeSettings(layout=layout))
            made.append((wav, f"{layout}, listener at ({at_m[0]:g}, {at_m[1]:g}) m facing +x"))
        except SonoluxError as exc:
            failures.append(f"{layout}: {exc}")
    return made, ("auralization failed for " + "; ".join(failures)) if failures else ""


def browser_copy(src: Path, dst: Path) -> str:
    """A 16-bit PCM copy of a WAV for the page's players, peak-normalised to -1 dBFS (a
    32-bit float WAV does not play everywhere): a caption suffix, e.g. '2 channels, 3.0 s'."""
    try:
        data, rate = read_audio(src)
    except SonoluxError as exc:
        raise SonoluxError(f"audio for the report: {exc}") from None
    peak = float(np.max(np.abs(data))) if data.size else 0.0
    if peak > 0:
        data = data * (10 ** (-1 / 20) / peak)
    write_wav(dst, data.astype(np.float32), rate, subtype="PCM_16")
    return f"{data.shape[1]} channel{'s' if data.shape[1] != 1 else ''}, " \
           f"{data.shape[0] / rate:.1f} s, normalised for listening"
