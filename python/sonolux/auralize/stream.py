"""The block renderer: a dry signal in, blocks of output channels out, as a live audio device
would drive it. The offline renderings (:mod:`sonolux.auralize.offline`) run the same code with
a larger block.

One block of B samples:

1. push the dry block into the partitioned convolver (one FFT, shared by every cell);
2. for each active cell (one; two during a cross-fade), the direction spectra Σ_p X·H of its
   responses (:class:`~sonolux.auralize.convolve.PartitionedConvolver`);
3. the spatializer turns them into channels for the heading of each sample (render.py); while
   the head is still and the layout has fewer channels than the field has directions, the
   spatialization is folded into the cell's filters once and step 2 yields the channels;
4. cells that are fading are weighted with equal-power gains (cos and sin of a quarter turn
   over ``fade_s``) and summed.

Latency: an output block needs only the input block of the same call, so the renderer adds no
algorithmic delay; a device driving it has one block of buffering, B / fs (64 to 1024 samples:
1.3 to 21 ms at 48 kHz), plus the binaural path's HRIR delay (28 samples with the spherical
head), see :attr:`StreamRenderer.latency_samples`. The responses keep the propagation delay of
the direct sound, which is the room's, not the renderer's.

Cell responses are synthesised when a cell is first needed (:class:`CellFilters`, kept in an
LRU cache); a live application calls :meth:`StreamRenderer.prepare` for the cells around the
listener ahead of time, since synthesising one costs far more than one block.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from dataclasses import field as dataclass_field

import numpy as np

from sonolux.auralize.convolve import PartitionedConvolver, cell_responses, fft_size_for, partition
from sonolux.auralize.render import spatializer as make_spatializer
from sonolux.errors import SonoluxError

STREAM_BLOCKS = (64, 128, 256, 512, 1024)


class CellFilters:
    """Partitioned spectra of the cells' responses, planar float[direction, P, 2, K/2 + 1] (see
    :func:`~sonolux.auralize.convolve.partition`), made on first use and kept for the
    ``capacity`` most recently used cells. ``responses``: a dict shared between renderers
    (e.g. of several layouts) that keeps the synthesised responses themselves."""

    def __init__(self, field, block: int, fft_size: int, partitions: int, seed: int = 0,
                 capacity: int = 32, precision: str = "float32", responses: dict | None = None):
        self.field, self.block, self.fft_size = field, int(block), int(fft_size)
        self.partitions, self.responses = int(partitions), responses
        self.seed, self.capacity, self.precision = int(seed), int(capacity), precision
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self.prepared = 0  # cells synthesised so far (statistics)
        self.prepare_s = 0.0

    def get(self, receiver: int) -> np.ndarray:
        import time

        hit = self._cache.get(receiver)
        if hit is not None:
            self._cache.move_to_end(receiver)
            return hit
        t0 = time.perf_counter()
        h = None if self.responses is None else self.responses.get((receiver, self.seed))
        if h is None:
            h = cell_responses(self.field, receiver, self.seed)
            if self.responses is not None:
                self.responses[(receiver, self.seed)] = h
        spectra = partition(h, self.block, self.fft_size, self.precision, self.partitions)
        self.prepare_s += time.perf_counter() - t0
        self.prepared += 1
        self._cache[receiver] = spectra
        if len(self._cache) > self.capacity:
            self._cache.popitem(last=False)
        return spectra


@dataclass
class _Voice:
    """A cell being heard: full gain between its fade-in and its fade-out (absolute samples;
    None = no fade)."""

    receiver: int
    spectra: np.ndarray
    fade_in: int | None = None
    fade_out: int | None = None
    # Filters with the spatialization folded in, by heading (the last few headings).
    combined: dict = dataclass_field(default_factory=dict)

    def gain(self, start: int, b: int, fade: int) -> np.ndarray | None:
        """The gains at samples start .. start + b - 1, or None when all are 1 (no fade there)."""
        if (self.fade_in is None or start >= self.fade_in + fade) and \
                (self.fade_out is None or start + b - 1 <= self.fade_out):
            return None
        t = start + np.arange(b)
        g = np.ones(t.size)
        if self.fade_in is not None:
            g *= np.sin(0.5 * np.pi * np.clip((t - self.fade_in) / fade, 0.0, 1.0))
        if self.fade_out is not None:
            g *= np.cos(0.5 * np.pi * np.clip((t - self.fade_out) / fade, 0.0, 1.0))
        return g


class StreamRenderer:
    """Renders a dry signal block by block for a listener who may move and turn.

    field: a :class:`~sonolux.SoundField`; layout: binaural, cube8, ambisonics, stereo, 5.1,
    7.1; block: samples per :meth:`process` call (64 to 1024 for live use; any size ≥ 16
    offline); order: ambisonic order; hrtf: a SOFA file for binaural (None: spherical head);
    fade_s: the equal-power cross-fade between cells; heading_step_deg: keyframe spacing of a
    turning head; precision: "float32" (default) or "float64".
    """

    def __init__(self, field, layout: str = "binaural", block: int = 256, *, order: int = 1,
                 hrtf: str | None = None, fade_s: float = 0.03, seed: int = 0,
                 heading_step_deg: float = 2.0, precision: str = "float32",
                 cache_cells: int = 32, responses: dict | None = None):
        if not (isinstance(block, (int, np.integer)) and 16 <= block <= 1 << 18):
            raise SonoluxError(f"block size {block!r} is not allowed: 16 to 262144 samples "
                               f"(64 to 1024 for live use)")
        if not 0.0 <= fade_s <= 1.0:
            raise SonoluxError(f"fade of {fade_s} s is not allowed: 0 to 1 s (20-50 ms is usual)")
        if precision not in ("float32", "float64"):
            raise SonoluxError(f"precision {precision!r} is not allowed: float32 or float64")
        self.field = field
        self.fs = field.sample_rate_hz
        self.block = int(block)
        self.spatializer = make_spatializer(field, layout, order, hrtf, heading_step_deg)
        self.layout = layout
        # Room for the spatializer's filter (an HRIR) in the FFT: K ≥ 2B + taps − 1.
        extra = getattr(self.spatializer, "extra_taps", 0)
        self.fft_size = fft_size_for(2 * self.block + max(extra - 1, 0))
        n = int(np.ceil((field.bin_start_s[-1] + field.bin_width_s[-1]) * self.fs))
        p = -(-n // self.block)
        self.convolver = PartitionedConvolver(self.block, p, self.fft_size, precision)
        self.cells = CellFilters(field, self.block, self.fft_size, p, seed, cache_cells, precision,
                                 responses)
        self.fade = max(1, int(round(fade_s * self.fs)))
        self._voices: list[_Voice] = []
        self._t = 0  # absolute sample index of the next block
        self._heading = self._heading_target = 0.0

    # --- what a live application calls ------------------------------------------------------
    @property
    def channel_names(self) -> list[str]:
        return list(self.spatializer.channel_names)

    @property
    def latency_samples(self) -> int:
        """Input-to-output delay: one block of buffering plus the HRIR's delay (binaural)."""
        return self.block + int(self.spatializer.delay_samples)

    def prepare(self, receivers) -> None:
        """Synthesises the responses of these cells now (e.g. the listener's neighbours)."""
        for r in np.atleast_1d(receivers):
            self.cells.get(int(r))

    def move_to(self, x: float, y: float, at_sample: int | None = None) -> int:
        """The listener is at (x, y) m from ``at_sample`` on (default: the next block); returns
        the cell. A change of cell starts a cross-fade there."""
        r = self.field.cell_at(x, y)
        self.set_cell(r, at_sample)
        return r

    def set_cell(self, receiver: int, at_sample: int | None = None) -> None:
        t = self._t if at_sample is None else int(at_sample)
        live = [v for v in self._voices if v.fade_out is None]
        if live and live[0].receiver == receiver:
            return
        spectra = self.cells.get(int(receiver))
        if not self._voices and t <= self._t:  # the first cell: heard at once, no fade-in
            self._voices.append(_Voice(int(receiver), spectra))
            return
        for v in live:
            v.fade_out = t
        self._voices.append(_Voice(int(receiver), spectra, fade_in=t))

    def face(self, heading_deg: float) -> None:
        """The listener faces ``heading_deg`` from now on, without turning (e.g. at the start)."""
        self._heading = self._heading_target = float(heading_deg)

    def set_heading(self, heading_deg: float) -> None:
        """The heading reached at the end of the next block (turned to linearly across it)."""
        self._heading_target = float(heading_deg)

    def process(self, x: np.ndarray, heading_deg=None) -> np.ndarray:
        """float32[channel, B]: the output for the next B dry samples. heading_deg: None (keep
        the heading, or turn to the one given to set_heading), a number (turn to it across the
        block) or float[B] (the heading at each sample, degrees, unwrapped)."""
        if not self._voices:
            raise SonoluxError("the listener has no cell yet: call move_to(x, y) or set_cell()")
        b = self.block
        if heading_deg is None:
            heading_deg = self._heading_target
        h = np.asarray(heading_deg, float)
        if h.ndim == 0:
            target = self._heading + ((float(h) - self._heading + 180.0) % 360.0 - 180.0)
            h = self._heading + (target - self._heading) * (np.arange(1, b + 1) / b)
        elif h.shape != (b,):
            raise SonoluxError(f"heading_deg has shape {h.shape}, expected ({b},) or a number")
        self.convolver.push(x)
        out = np.zeros((self.spatializer.n_channels, b), np.float32)
        for v in self._voices:
            g = v.gain(self._t, b, self.fade)
            if g is not None and not np.any(g):
                continue
            y = self._render_voice(v, h)
            out += y if g is None or np.all(g == 1.0) else y * g.astype(np.float32)
        self._t += b
        self._heading = float(h[-1])
        self._voices = [v for v in self._voices
                        if v.fade_out is None or v.fade_out + self.fade > self._t]
        return out

    def _render_voice(self, v: _Voice, h: np.ndarray) -> np.ndarray:
        sp, conv = self.spatializer, self.convolver
        if sp.n_channels >= v.spectra.shape[0]:  # as many channels as directions: no folding
            return sp.render(conv.apply(v.spectra), conv, h)
        # Still (less than a micro-degree: smoothing leaves rounding noise): the exact heading.
        # Binaural turning slowly (the block's ends within one keyframe step): the keyframes
        # that render() would use, on the grid of heading_step_deg, cross-faded across the
        # block. Either way the spatialization is folded into the cell's filters (fewer
        # channels to convolve); gains keep per-sample keyframes while turning.
        if np.ptp(h) <= 1e-6:
            ends = [round(float(h[0]), 6)]
        elif not sp.grid_keyframes:
            return sp.render(conv.apply(v.spectra), conv, h)
        else:
            step = sp.step
            ends = [round(step * float(np.round(x / step)), 6) for x in (h[0], h[-1])]
            if abs(ends[1] - ends[0]) > step + 1e-9:  # a fast turn: keyframes per direction
                return sp.render(conv.apply(v.spectra), conv, h)
            if ends[0] == ends[1]:
                ends = ends[:1]
        frames = []
        for q in ends:
            if q not in v.combined:
                if len(v.combined) >= 3:
                    v.combined.pop(next(iter(v.combined)))
                v.combined[q] = sp.combine(v.spectra, q, self.fft_size)
            frames.append(conv.output(v.combined[q]))
        if len(frames) == 1:
            return frames[0]
        r = np.arange(self.block, dtype=np.float32) / max(self.block - 1, 1)  # as render()
        return frames[0] * (1 - r) + frames[1] * r
