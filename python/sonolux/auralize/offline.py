"""Offline auralization: a dry signal heard at a point (or along a path, see walk.py) into one
array of output channels. It drives the block renderer of stream.py with a large block, so the
offline and the live paths are the same code.

Dry signals (:func:`load_dry`): a WAV/FLAC/... file of any rate, resampled to the field's rate
with ``scipy.signal.resample_poly``; several channels are mixed to mono (the mean: the source is
a point) unless one is chosen; or a built-in signal ``builtin:NAME[:SECONDS]`` (signals.py).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from math import gcd

import numpy as np
from scipy.signal import resample_poly

from sonolux.auralize.render import check_layout
from sonolux.auralize.signals import builtin, is_builtin
from sonolux.auralize.stream import StreamRenderer
from sonolux.errors import SonoluxError, check_number
from sonolux.limits import MAX_SEED


@dataclass
class AuralizeSettings:
    """How to render. layout: binaural, cube8, ambisonics, stereo, 5.1, 7.1; order: ambisonic
    order (1 to 7); hrtf: a SOFA file (binaural; None = the spherical head); fade_s: the
    equal-power cross-fade between cells (20-50 ms is usual); block: samples per block (any
    size ≥ 16; 64-1024 as a live device would use, larger is faster offline); seed: of the
    responses' fine structure; heading_step_deg: keyframe spacing of a turning head;
    precision: float32 or float64 spectra; tail_s: how long to keep rendering after the dry
    signal ends (None: the responses' whole length)."""

    layout: str = "binaural"
    order: int = 1
    hrtf: str | None = None
    fade_s: float = 0.03
    block: int = 8192
    seed: int = 0
    heading_step_deg: float = 2.0
    precision: str = "float32"
    tail_s: float | None = None

    def validate(self) -> AuralizeSettings:
        check_layout(self.layout)
        # 20 to 50 ms of fade hides the change of cell without smearing it.
        check_number("fade_s", self.fade_s, 0.005, 0.5, unit="s")
        check_number("heading_step_deg", self.heading_step_deg, 0.1, 15, unit="degrees")
        check_number("tail_s", self.tail_s, 0, 60, none_ok=True, unit="s")
        check_number("block", self.block, 16, 262144, integer=True, unit="samples")
        check_number("order", self.order, 1, 7, integer=True)
        check_number("seed", self.seed, 0, MAX_SEED, integer=True)
        if self.hrtf is not None and not isinstance(self.hrtf, (str, os.PathLike)):
            raise SonoluxError(f"hrtf = {self.hrtf!r} is not allowed: the path of a SOFA file")
        return self

    def renderer(self, field) -> StreamRenderer:
        return StreamRenderer(field, self.layout, self.block, order=self.order, hrtf=self.hrtf,
                              fade_s=self.fade_s, seed=self.seed,
                              heading_step_deg=self.heading_step_deg, precision=self.precision)


def load_dry(spec: str, sample_rate_hz: int, duration_s: float | None = None,
             channel: int | None = None) -> tuple[np.ndarray, str]:
    """float64[samples] at ``sample_rate_hz`` and a one-line description.

    spec: a sound file or ``builtin:NAME[:SECONDS]``; duration_s: the length of a built-in
    signal that names none; channel: the file's channel to use (0-based; None = mix to mono)."""
    from sonolux.audio import read_audio

    fs = int(sample_rate_hz)
    if is_builtin(spec):
        x = builtin(spec, fs, duration_s)
        return x, f"{spec} ({x.size / fs:.2f} s, generated)"
    data, rate = read_audio(spec)
    if data.shape[0] == 0:
        raise SonoluxError(f"{spec}: the audio file holds no samples")
    notes = []
    if channel is not None:
        if not 0 <= channel < data.shape[1]:
            raise SonoluxError(f"{spec}: channel {channel} does not exist (the file has "
                               f"{data.shape[1]}, numbered from 0)")
        x = data[:, channel]
        notes.append(f"channel {channel}")
    else:
        x = data.mean(axis=1)
        if data.shape[1] > 1:
            notes.append(f"{data.shape[1]} channels mixed to mono")
    if rate != fs:
        g = gcd(rate, fs)
        x = resample_poly(x, fs // g, rate // g)
        notes.append(f"resampled {rate} -> {fs} Hz")
    if not np.all(np.isfinite(x)):
        raise SonoluxError(f"{spec}: the audio holds NaN or infinite samples")
    extra = f", {', '.join(notes)}" if notes else ""
    return x, f"{spec} ({x.size / fs:.2f} s{extra})"


def run_blocks(renderer: StreamRenderer, x: np.ndarray, n_out: int, heading_deg,
               changes: list[tuple[int, int]] = ()) -> np.ndarray:
    """float32[n_out, channel]: the renderer fed with x (zero-padded) block by block.

    heading_deg: a number, or float[n_out] per sample (degrees, unwrapped); changes: (sample,
    receiver) in time order, the sample where each cross-fade to a new cell starts."""
    b = renderer.block
    blocks = -(-n_out // b)
    per_sample = np.ndim(heading_deg) > 0
    # Blocks are sliced from x and the headings as they are; only a block running past their
    # ends is padded (x with zeros, the heading held), without copying the whole signal.
    silence = np.zeros(b, np.float64)
    if per_sample:
        h = np.asarray(heading_deg, float)
        h_end = min(n_out, h.size)
    out = np.empty((blocks * b, renderer.spatializer.n_channels), np.float32)
    pending = list(changes)
    for i in range(blocks):
        start = i * b
        while pending and pending[0][0] < start + b:
            at, receiver = pending.pop(0)
            renderer.set_cell(receiver, at)
        xb = x[start:start + b]
        if xb.size < b:
            xb = np.concatenate([xb, silence[: b - xb.size]]) if xb.size else silence
        if per_sample:
            hb = h[start:min(start + b, h_end)]
            if hb.size < b:
                hb = np.concatenate([hb, np.full(b - hb.size, h[h_end - 1])])
        else:
            hb = float(heading_deg)
        out[start:start + b] = renderer.process(xb, hb).T
    return out[:n_out]


def response_samples(field) -> int:
    return int(np.ceil((field.bin_start_s[-1] + field.bin_width_s[-1]) * field.sample_rate_hz))


def auralize(field, dry: np.ndarray, at: tuple[float, float], heading_deg: float = 0.0,
             settings: AuralizeSettings | None = None,
             renderer: StreamRenderer | None = None) -> tuple[np.ndarray, dict]:
    """The dry signal float[samples] (at the field's rate) heard at ``at`` = (x, y) m facing
    ``heading_deg``: float32[samples + tail, channel] and a dict of what was done.
    ``renderer``: a fresh renderer to use (default: one made from the settings)."""
    s = (settings or AuralizeSettings()).validate()
    heading_deg = check_number("heading_deg", heading_deg, -36000.0, 36000.0, unit="degrees")
    dry = np.asarray(dry)
    if dry.ndim != 1 or dry.dtype.kind not in "iuf" or not np.all(np.isfinite(dry)):
        raise SonoluxError(f"the dry signal must be float[samples] of finite numbers (got "
                           f"{dry.dtype}{list(dry.shape)})")
    t0 = time.perf_counter()
    renderer = renderer or s.renderer(field)
    receiver = renderer.move_to(*at)
    renderer.face(heading_deg)
    tail = response_samples(field) if s.tail_s is None else int(s.tail_s * field.sample_rate_hz)
    n_out = np.asarray(dry).size + tail
    out = run_blocks(renderer, np.asarray(dry, float), n_out, float(heading_deg))
    seconds = time.perf_counter() - t0
    return out, {"receivers": [receiver], "channels": renderer.channel_names,
                 "layout": renderer.spatializer.name, "latency_samples": renderer.latency_samples,
                 "seconds": seconds, "prepare_seconds": renderer.cells.prepare_s,
                 "duration_s": n_out / field.sample_rate_hz}
