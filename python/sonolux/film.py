"""The walk-through film: what a person walking through the room sees and hears, in one file.

:func:`make_film` takes a field file with both senses and a walk (the CSV or JSON paths of
``sonolux auralize --path``). The soundtrack is the walk's auralization
(:func:`sonolux.auralize.walk.auralize_walk`: binaural or stereo, cells cross-faded as in
``auralize``); the pictures are the light field rendered from the walker's eye with the
camera of ``sonolux render``, at the same smoothed position and heading the soundtrack uses, one
frame every 1/fps s from t = 0. Both go through PyAV (FFmpeg inside the wheel): H.264 video
(yuv420p) and AAC audio in an MP4, MKV or MOV container.

Sync: frame k shows t = k / fps; the audio starts at t = 0 too, and is padded with silence
to the end of the last frame, so the two have the same length (AAC adds its own priming of
1024 samples, which the container's edit list hides; under one frame at any usual rate).
Exposure is fixed for the whole film (the median of the incident-light meter at a few points
of the walk, as ``render`` meters one view), so the picture does not pump.
The audio is never written above full scale: a peak over 0 dBFS is scaled down to -1 dBFS,
and the result says so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.auralize.offline import AuralizeSettings, load_dry
from sonolux.auralize.walk import WalkSettings, auralize_walk, load_path, sample_path
from sonolux.errors import SonoluxError
from sonolux.light.camera import Camera
from sonolux.light.image import to_srgb8
from sonolux.light.render import Renderable, incident_exposure, render

CONTAINERS = (".mp4", ".mkv", ".mov")
FILM_LAYOUTS = ("binaural", "stereo")
#: Peak of the soundtrack when it had to be scaled down (as ``auralize`` does).
PEAK_DBFS = -1.0
#: Points along the walk where the exposure is metered.
METER_POINTS = 5


@dataclass(frozen=True)
class FilmSettings:
    """fps: frames per second; width_px × height_px (even, for yuv420p); fov_deg: vertical
    field of view; eye_height_m: the camera's height (None: the receivers' height, so that the
    eye is where the ears are); samples: samples² rays per pixel; layout: binaural or stereo; crf:
    H.264 quality (0 best, 51 worst; 18-23 usual)."""

    fps: float = 25.0
    width_px: int = 640
    height_px: int = 360
    fov_deg: float = 70.0
    eye_height_m: float | None = None
    samples: int = 1
    layout: str = "binaural"
    crf: int = 20

    def validate(self) -> FilmSettings:
        def bad(name: str, value: object, allowed: str) -> SonoluxError:
            return SonoluxError(f"film {name} = {value!r} is not allowed: {allowed}")

        if not (isinstance(self.fps, (int, float)) and 1 <= self.fps <= 120):
            raise bad("fps", self.fps, "1 to 120 frames per second")
        for name in ("width_px", "height_px"):
            v = getattr(self, name)
            if not (isinstance(v, int) and 16 <= v <= 3840 and v % 2 == 0):
                raise bad(name, v, "an even number of pixels from 16 to 3840")
        if not (0 < self.fov_deg < 170):
            raise bad("fov_deg", self.fov_deg, "an angle in (0, 170) degrees")
        if self.eye_height_m is not None and not (math.isfinite(self.eye_height_m)
                                                  and 0 < self.eye_height_m < 100):
            raise bad("eye_height_m", self.eye_height_m, "a height in (0, 100) m")
        if not (isinstance(self.samples, int) and 1 <= self.samples <= 16):
            raise bad("samples", self.samples, "a whole number from 1 to 16 (samples² rays "
                      "per pixel)")
        if self.layout not in FILM_LAYOUTS:
            raise bad("layout", self.layout, " or ".join(FILM_LAYOUTS))
        if not (isinstance(self.crf, int) and 0 <= self.crf <= 51):
            raise bad("crf", self.crf, "a whole number from 0 to 51")
        return self


def _av() -> Any:
    try:
        import av
    except ImportError as exc:
        raise SonoluxError(f"the film needs PyAV ({exc}): pip install av") from None
    return av


def soundtrack(sound: Any, dry: str, path: Any, settings: FilmSettings,
               fade_s: float = 0.03) -> tuple[np.ndarray, dict[str, Any], str]:
    """float32[samples, 2] of the walk (scaled below full scale if needed), the walk's info
    and a note of any scaling."""
    fs = sound.sample_rate_hz
    x, what = load_dry(dry, fs, duration_s=path.duration_s)
    y, info = auralize_walk(sound, x, path, AuralizeSettings(layout=settings.layout,
                                                             fade_s=fade_s), WalkSettings())
    info["dry"] = what
    peak = float(np.max(np.abs(y))) if y.size else 0.0
    note = ""
    if peak > 1.0:
        target = 10 ** (PEAK_DBFS / 20)
        y = y * np.float32(target / peak)
        note = f"soundtrack scaled down by {20 * math.log10(peak / target):.1f} dB to stay below full scale"
    return np.ascontiguousarray(y[:, :2], np.float32), info, note


def cameras(path: Any, settings: FilmSettings, frames: int, eye_height_m: float) -> list[Camera]:
    """The camera of each frame: the walk's smoothed position and heading at k / fps."""
    xy, heading = sample_path(path, settings.fps, frames, WalkSettings().heading_smoothing_s)
    return [Camera(position_m=(float(p[0]), float(p[1]), eye_height_m), yaw_deg=float(h),
                   fov_deg=settings.fov_deg, width=settings.width_px,
                   height=settings.height_px).validate() for p, h in zip(xy, heading)]


def make_film(sound: Any, light: Any, dry: str, path_file: str | Path, output: str | Path,
              settings: FilmSettings | None = None,
              progress: Callable[[int, int, float], bool] | None = None) -> dict[str, Any]:
    """Renders and encodes the film; returns what was done (frames, seconds, sizes, notes)."""
    settings = (settings or FilmSettings()).validate()
    output = Path(output)
    if output.suffix.lower() not in CONTAINERS:
        raise SonoluxError(f"{output}: the film's file name must end in one of "
                           f"{', '.join(CONTAINERS)}")
    av = _av()
    started = time.perf_counter()
    path = load_path(path_file)
    audio, info, note = soundtrack(sound, dry, path, settings)
    fs = sound.sample_rate_hz
    fps = Fraction(settings.fps).limit_denominator(1001)
    frames = max(1, math.ceil(audio.shape[0] * fps / fs))
    samples = round(frames * fs / fps)  # the audio ends with the last frame
    audio = np.concatenate([audio, np.zeros((max(0, samples - audio.shape[0]), 2), np.float32)])
    audio = audio[:samples]
    eye = settings.eye_height_m or float(np.mean(sound.positions_m[:, 2]))
    shots = cameras(path, settings, frames, eye)
    renderable = Renderable.of(light)
    metered = [incident_exposure(renderable, shots[k])
               for k in np.linspace(0, frames - 1, min(frames, METER_POINTS)).astype(int)]
    exposure = float(np.median(metered))
    tmp = output.with_name(f".{output.stem}.partial{output.suffix}")
    try:
        with av.open(str(tmp), "w") as container:
            video = container.add_stream("libx264" if "libx264" in av.codecs_available
                                         else "mpeg4", rate=fps)
            video.width, video.height, video.pix_fmt = settings.width_px, settings.height_px, \
                "yuv420p"
            video.options = {"crf": str(settings.crf)} if video.name == "libx264" else {}
            sound_out = container.add_stream("aac", rate=fs, layout="stereo")
            chunk = sound_out.codec_context.frame_size or 1024
            at = 0
            for k, camera in enumerate(shots):
                rgb = to_srgb8(render(renderable, camera, samples=settings.samples,
                                      keep_samples=True), exposure, samples_axis=2)
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
                frame.pts = k
                container.mux(video.encode(frame))
                until = round((k + 1) * fs / fps)
                while at < until:
                    block = audio[at:min(at + chunk, until if k + 1 < frames else samples)]
                    a = av.AudioFrame.from_ndarray(np.ascontiguousarray(block.T), format="fltp",
                                                   layout="stereo")
                    a.sample_rate, a.pts = fs, at
                    container.mux(sound_out.encode(a))
                    at += block.shape[0]
                if progress is not None and not progress(k + 1, frames,
                                                         time.perf_counter() - started):
                    raise SonoluxError("the film was stopped")
            container.mux(video.encode())
            container.mux(sound_out.encode())
        tmp.replace(output)
    finally:
        tmp.unlink(missing_ok=True)
    return {"frames": frames, "fps": float(fps), "duration_s": samples / fs,
            "sample_rate_hz": fs, "size_px": (settings.width_px, settings.height_px),
            "exposure_scale": exposure, "eye_height_m": eye, "layout": settings.layout,
            "cells": info["receivers"], "events": info["events"], "dry": info["dry"],
            "seconds": time.perf_counter() - started, "bytes": output.stat().st_size,
            "notes": [note] if note else [], "output": str(output)}
