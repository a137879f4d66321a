"""From directions to output channels: each direction bin of the field is a virtual source at
the bin's centre, rotated into the listener's head frame by the heading, then sent to a layout.

Frames. The field's directions are in the world: azimuth 0° = +x, counter-clockwise from above,
elevation bands at the middle of their range of sin(elevation). A listener facing heading θ
(0° = +x, 90° = +y) hears a source at world azimuth φ at head-relative azimuth φ − θ, so
:func:`head_frame` rotates by −θ about z. Facing +x, "left" (+y) is at the left ear.

A spatializer turns the convolver's output spectra O[direction, 2, bins] of one block (planar,
see :class:`~sonolux.auralize.convolve.PartitionedConvolver`) into float[channel, B] samples,
for a heading that may change within the block (``heading_deg``: float[B]):

- :class:`GainSpatializer` (stereo, 5.1, 7.1, cube8, ambisonics): inverse FFT of each direction,
  then a gain matrix G(θ)[channel, direction], interpolated linearly between keyframes at most
  ``heading_step_deg`` apart (per sample, so a turn is smooth).
- :class:`BinauralSpatializer`: the HRIR spectra of the rotated directions multiplied into the
  direction spectra and summed per ear (:func:`~sonolux.auralize.convolve.fold`), one inverse
  FFT per ear and keyframe, keyframes cross-faded linearly. Keyframe headings are rounded to
  ``heading_step_deg`` so that HRIR spectra repeat and are cached, by heading and by
  head-frame direction (by ear angle for the spherical head), so a turn computes each HRIR
  spectrum once; all keyframes share one inverse FFT call.

While the head is still, :meth:`combine` folds the spatialization into a cell's partitioned
filters once (channels instead of directions: 2 ears instead of 8 directions for binaural),
so the convolver does a quarter of the work; the block renderer keeps them while the heading
and the cell stay the same.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from scipy import fft as sfft

from sonolux.auralize import ambisonics
from sonolux.auralize.binaural import load_hrtf
from sonolux.auralize.convolve import fold, planar
from sonolux.auralize.layouts import LAYOUTS, loudspeaker_layout, unit_vectors
from sonolux.errors import SonoluxError, close_matches

LAYOUT_NAMES = ("binaural", "cube8", "ambisonics", "stereo", "5.1", "7.1")


def check_layout(name: str) -> str:
    if name not in LAYOUT_NAMES:
        near = close_matches(name, LAYOUT_NAMES)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise SonoluxError(f"unknown layout {name!r}: one of {', '.join(LAYOUT_NAMES)}{hint}")
    return name


def field_directions(field) -> np.ndarray:
    """float[direction, 3]: world unit vectors of the centres of the field's direction bins."""
    n_az, n_el = field.azimuth_bands, field.elevation_bands
    az = 360.0 * np.arange(n_az) / n_az
    z = -1.0 + (2.0 * np.arange(n_el) + 1.0) / n_el  # middle of each band of sin(elevation)
    el = np.degrees(np.arcsin(z))
    return unit_vectors(np.tile(az, n_el), np.repeat(el, n_az))


def head_frame(world: np.ndarray, heading_deg: float) -> np.ndarray:
    """World unit vectors float[n, 3] seen by a listener facing ``heading_deg``."""
    t = np.radians(heading_deg)
    c, s = np.cos(t), np.sin(t)
    x, y = world[:, 0], world[:, 1]
    return np.column_stack([c * x + s * y, -s * x + c * y, world[:, 2]])


def _keyframes(heading_deg: np.ndarray, step_deg: float, min_spacing: int = 1) -> np.ndarray:
    """Sample indices of the keyframes of a block: first and last sample, and enough between
    that the heading moves at most step_deg from one keyframe to the next, but keyframes no
    closer than ``min_spacing`` samples."""
    b = heading_deg.size
    travel = float(np.sum(np.abs(np.diff(heading_deg)))) if b > 1 else 0.0
    if travel <= 1e-6:
        return np.array([0])
    n = min(b, int(np.ceil(travel / step_deg)) + 1, max(2, (b - 1) // max(1, min_spacing) + 1))
    return np.unique(np.round(np.linspace(0, b - 1, max(n, 2))).astype(int))


def _crossfade(frames: list[np.ndarray], keys: np.ndarray, b: int) -> np.ndarray:
    """Piecewise-linear interpolation in time between outputs frames[k] valid at keys[k]."""
    if len(frames) == 1:
        return frames[0]
    out = np.empty_like(frames[0])
    for k in range(len(keys) - 1):
        a, z = keys[k], keys[k + 1]
        end = b if k == len(keys) - 2 else z
        r = (np.arange(a, end) - a) / max(z - a, 1)
        out[:, a:end] = frames[k][:, a:end] * (1 - r) + frames[k + 1][:, a:end] * r
    return out


class GainSpatializer:
    """Amplitude panning (loudspeakers) or encoding (ambisonics) of the direction signals."""

    extra_taps = 0
    grid_keyframes = False  # keyframes at the exact headings

    def __init__(self, world: np.ndarray, gain_fn, channel_names, name: str,
                 heading_step_deg: float = 2.0):
        self.world = world
        self.gain_fn = gain_fn  # head-frame unit vectors float[n, 3] -> float[channel, n]
        self.channel_names = list(channel_names)
        self.name = name
        self.step = float(heading_step_deg)
        self.delay_samples = 0
        self._gains: OrderedDict = OrderedDict()

    @property
    def n_channels(self) -> int:
        return len(self.channel_names)

    def gains(self, heading_deg: float) -> np.ndarray:
        """float32[channel, direction] for a heading; the last 256 headings are kept (a still
        head asks for the same one every block, and VBAP solves a small system per source)."""
        key = round(float(heading_deg) % 360.0, 6)
        hit = self._gains.get(key)
        if hit is None:
            hit = self.gain_fn(head_frame(self.world, heading_deg)).astype(np.float32)
            self._gains[key] = hit
            if len(self._gains) > 256:
                self._gains.popitem(last=False)
        else:
            self._gains.move_to_end(key)
        return hit

    def combine(self, filters: np.ndarray, heading_deg: float, fft_size: int) -> np.ndarray:
        """Filter spectra [channel, P, 2, bins] of the channels for a still head: the gains
        mixed into the direction filters [direction, P, 2, bins] (worth it with fewer
        channels). Real gains act alike on real and imaginary parts: one matrix product."""
        g = self.gains(heading_deg).astype(filters.dtype)
        return np.tensordot(g, filters, axes=1)

    def render(self, spectra: np.ndarray, convolver, heading_deg: np.ndarray) -> np.ndarray:
        b = heading_deg.size
        s = convolver.inverse(spectra)
        keys = _keyframes(heading_deg, self.step)
        return _crossfade([self.gains(heading_deg[k]).astype(s.dtype) @ s for k in keys], keys, b)


class BinauralSpatializer:
    """HRIRs of the rotated virtual sources, applied in the convolver's frequency domain."""

    def __init__(self, world: np.ndarray, hrtf, heading_step_deg: float = 2.0,
                 cache_entries: int = 64):
        self.world = world
        self.hrtf = hrtf
        self.channel_names = ["left", "right"]
        self.name = f"binaural ({hrtf.name})"
        self.step = float(heading_step_deg)
        self.extra_taps = int(hrtf.taps)
        self.delay_samples = int(hrtf.delay_samples)
        self._cache: OrderedDict = OrderedDict()
        self._cache_entries = int(cache_entries)
        self._dir_cache: OrderedDict = OrderedDict()  # head-frame direction -> [ear, bins]
        self._dir_cache_entries = 1024

    n_channels = 2
    grid_keyframes = True  # a turning head's keyframes on the grid of heading_step_deg
    # A fast turn (more than heading_step_deg within a block) is rendered with keyframes at
    # least this many samples apart (21 ms at 48 kHz), linearly cross-faded: the filter update
    # rate of common dynamic binaural renderers; each keyframe costs two inverse FFTs.
    min_keyframe_spacing = 1024

    def _direction_spectra(self, heading_deg: float, fft_size: int) -> np.ndarray:
        """Planar float32[ear, direction, 2, bins]: the HRIR spectra for a heading, each cached by
        its head-frame direction: turning the head by a multiple of the grid step brings
        another world direction to the same head-frame direction (e.g. the field's azimuth
        bins 90° apart), so a turn computes each HRIR spectrum once."""
        dirs = head_frame(self.world, heading_deg)
        if hasattr(self.hrtf, "ear_angles"):
            return self._ear_spectra(dirs, fft_size)
        keys = [(round(float(x), 9), round(float(y), 9), round(float(z), 9), fft_size)
                for x, y, z in dirs]
        cache = self._dir_cache
        missing = [i for i, k in enumerate(keys) if k not in cache]
        if missing:
            h = self.hrtf.hrirs(dirs[missing])  # [direction, ear, taps]
            new = planar(sfft.rfft(h, fft_size, axis=-1, workers=1), np.float32)
            for j, i in enumerate(missing):
                cache[keys[i]] = new[j]
        out = np.empty((2, len(keys), 2, fft_size // 2 + 1), np.float32)
        for d, k in enumerate(keys):
            cache.move_to_end(k)
            out[:, d] = cache[k]
        while len(cache) > self._dir_cache_entries:
            cache.popitem(last=False)
        return out

    def _ear_spectra(self, dirs: np.ndarray, fft_size: int) -> np.ndarray:
        """As :meth:`_direction_spectra` for an HRTF whose ears depend on one angle each
        (the spherical head): each ear's spectrum is cached by that angle, which the two ears
        and mirrored directions (front/back, up/down) share."""
        theta = self.hrtf.ear_angles(dirs)  # [direction, ear]
        keys = [(round(float(t), 9), fft_size) for t in theta.ravel()]
        cache = self._dir_cache
        missing = {k: t for k, t in zip(keys, theta.ravel()) if k not in cache}  # key -> an angle
        if missing:
            h = np.array([self.hrtf.ear_hrir(t) for t in missing.values()])  # [ear IR, taps]
            new = planar(sfft.rfft(h, fft_size, axis=-1, workers=1), np.float32)
            for k, spec in zip(missing, new):
                cache[k] = spec
        out = np.empty((2, len(dirs), 2, fft_size // 2 + 1), np.float32)
        for i, k in enumerate(keys):  # keys run [direction][ear]
            cache.move_to_end(k)
            out[i % 2, i // 2] = cache[k]
        while len(cache) > self._dir_cache_entries:
            cache.popitem(last=False)
        return out

    def _spectra(self, heading_deg: float, fft_size: int) -> np.ndarray:
        """Planar float32[ear, direction, 2, bins]: the HRIR spectra for a heading (cached),
        laid out for :func:`~sonolux.auralize.convolve.fold`."""
        key = (round(heading_deg % 360.0, 6), fft_size)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        spec = self._direction_spectra(heading_deg, fft_size)
        self._cache[key] = spec
        if len(self._cache) > self._cache_entries:
            self._cache.popitem(last=False)
        return spec

    def combine(self, filters: np.ndarray, heading_deg: float, fft_size: int) -> np.ndarray:
        """Filter spectra [ear, P, 2, bins] for a still head: the HRIRs multiplied into the
        direction filters [direction, P, 2, bins] and summed, exact since K ≥ 2B + taps − 1."""
        return fold(filters, self._spectra(heading_deg, fft_size).astype(filters.dtype, copy=False))

    def render(self, spectra: np.ndarray, convolver, heading_deg: np.ndarray) -> np.ndarray:
        b = heading_deg.size
        keys = _keyframes(heading_deg, self.step, self.min_keyframe_spacing)
        ears = []
        for k in keys:
            # A still head keeps its exact heading; a turning one is sampled on a grid of
            # step_deg so that the spectra are found again in the cache.
            q = heading_deg[k] if keys.size == 1 else self.step * np.round(heading_deg[k] / self.step)
            mix = self._spectra(float(q), convolver.fft_size).astype(spectra.dtype, copy=False)
            ears.append(fold(spectra[:, None], mix)[:, 0])  # Σ_d HRIR_d · O_d: [ear, 2, bins]
        # One inverse FFT call for every keyframe and ear.
        frames = convolver.inverse(np.concatenate(ears)).reshape(keys.size, 2, b)
        return _crossfade(list(frames), keys, b)


def spatializer(field, layout: str, order: int = 1, hrtf: str | None = None,
                heading_step_deg: float = 2.0):
    """The spatializer of a layout name (see :data:`LAYOUT_NAMES`) for the field's directions."""
    layout = check_layout(layout)
    world = field_directions(field)
    if hrtf is not None and layout != "binaural":
        raise SonoluxError(f"an HRTF ({hrtf}) is only used with the binaural layout, not {layout}")
    if layout == "binaural":
        return BinauralSpatializer(world, load_hrtf(hrtf, field.sample_rate_hz),
                                   heading_step_deg)
    if layout == "ambisonics":
        order = ambisonics.check_order(order)
        return GainSpatializer(world, lambda d: ambisonics.sn3d_gains(d, order),
                               ambisonics.channel_names(order),
                               f"ambisonics order {order} (AmbiX: ACN, SN3D)", heading_step_deg)
    spk = loudspeaker_layout(layout)
    return GainSpatializer(world, spk.gains, spk.channel_names, layout, heading_step_deg)


__all__ = ["LAYOUTS", "LAYOUT_NAMES", "BinauralSpatializer", "GainSpatializer", "check_layout",
           "field_directions", "head_frame", "spatializer"]
