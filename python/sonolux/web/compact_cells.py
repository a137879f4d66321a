"""The bundle's cells as compact fields (format ``sonolux-web/3``): what the browser needs to
synthesise a cell's responses itself, in a Web Worker, instead of the responses.

A cell's block holds, for each source field of the bundle (in order), that receiver's compact
field (:class:`sonolux.sound.compact.CompactArray`, reduced: the strongest early arrivals exact,
the rest of the early part as a 1 ms envelope from the onset, the late part in its coarse bins)
cut where the cell's decay has died away:

- ``cell`` uint32[arrivals]: flat index into the [direction, band, early sample] block;
- ``value`` float32[arrivals]: the arrival's energy (J/m²) in that band;
- ``envelope`` float32[direction, band, envelope bin];
- ``late`` float32[direction, band, kept late bin]: the stored late bins before the cut.

All little-endian and 4-byte aligned, concatenated in that order, source after source; the
cell's ``fields`` entries in ``field.json`` give each part's counts and byte offset. The
synthesis (:func:`cell_response`, mirrored by ``web/src/synth/synthesis.ts``) decodes the dense
histogram exactly as :meth:`CompactArray.receiver` does, and makes the pressure response with
:func:`sonolux.sound.synthesis.pressure_ir` (Schröder/Vorländer's weighted Poisson sequences,
split into bands), so the browser's response is the library's, up to its own random fine
structure.

The cut (``tail_db``): the first stored bin from which the energy still to come (summed over the
cell's directions and source fields, as the synthesised pressure carries it:
:func:`pressure_energy`) is ``tail_db`` below the cell's whole energy. The
response ends there with a 10 ms fade, as the ``sonolux-web/2`` responses do; what is left out
is at most 10^(−tail_db/10) of the cell's energy. A full-resolution field is made compact a
receiver at a time, with the bake's defaults (128 arrivals, 1 ms envelope).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.sound.compact import CompactArray, is_compact
from sonolux.sound.field import SoundField
from sonolux.sound.synthesis import band_split_weights, pressure_ir
from sonolux.web.responses import direct_bins, fade_cut

#: The bake's defaults (sound/options.py), for fields stored at full resolution.
ARRIVALS = 128
ENVELOPE_S = 0.001


@dataclass
class CompactCell:
    """One receiver of one source field, as stored in the bundle (arrays as in the module doc)."""

    onset: int
    cell: np.ndarray  # uint32[arrivals]
    value: np.ndarray  # float32[arrivals]
    envelope: np.ndarray  # float32[direction, band, envelope bins]
    late: np.ndarray  # float32[direction, band, kept late bins]
    #: A hybrid bake's exact early arrivals (image sources, diffraction) at this receiver:
    #: sample and direction bin uint32[n, 2], direction float32[n, 2] (azimuth, elevation in
    #: degrees, where the sound comes from), energy float32[n, band] (J/m²). Empty without
    #: [early].
    exact_sample: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.uint32))
    exact_direction: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float32))
    exact_energy: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.float32))

    def to_bytes(self) -> bytes:
        return b"".join(np.ascontiguousarray(a, dt).tobytes() for a, dt in (
            (self.cell, "<u4"), (self.value, "<f4"), (self.envelope, "<f4"), (self.late, "<f4"),
            (self.exact_sample, "<u4"), (self.exact_direction, "<f4"),
            (self.exact_energy, "<f4")))

    @property
    def nbytes(self) -> int:
        return 4 * (self.cell.size + self.value.size + self.envelope.size + self.late.size
                    + self.exact_sample.size + self.exact_direction.size
                    + self.exact_energy.size)


@dataclass(frozen=True)
class Axis:
    """The dense view's time axis: ``early_bins`` one-sample bins, then bins of
    ``late_bin_samples``, each of ``late_split`` of them one stored late bin."""

    early_bins: int
    late_bin_samples: int
    late_split: int
    envelope_split: int
    late_stored: int

    def as_json(self) -> dict:
        return {"early_bins": self.early_bins, "late_bin_samples": self.late_bin_samples,
                "late_split": self.late_split, "envelope_split": self.envelope_split}


def check_synthesisable(sound: SoundField, name: str) -> None:
    if sound.waves is not None:
        raise SonoluxError(f"source field {name!r} holds a wave part (a hybrid bake): its "
                           "responses cannot be synthesised in the browser; export it with "
                           "responses='pcm' (sonolux-web/2)")


def reduced_energy(sound: SoundField) -> tuple[CompactArray | None, int, int]:
    """The field's reduced compact energy (None for a full field: reduced a receiver at a
    time) and its (arrivals, envelope split)."""
    fs = sound.sample_rate_hz
    s = sound.settings
    arrivals = int(s.get("compact_arrivals", ARRIVALS))
    split = max(1, round(float(s.get("compact_envelope_s", ENVELOPE_S)) * fs))
    e = sound.energy
    if is_compact(e):
        if e.envelope is None:
            e = e.reduce(arrivals, split)
        return e, arrivals, e.envelope_split
    return None, arrivals, split


def axis_of(sound: SoundField) -> Axis:
    """The dense axis of the field, checked to be one-sample bins then equal bins on the
    sample grid (what every bake writes)."""
    fs = sound.sample_rate_hz
    energy, _, split = reduced_energy(sound)
    if energy is not None:
        early, late_split, late_stored = energy.early_bins, energy.late_split, energy.late.shape[-1]
    else:
        early = int(sound.settings.get("early_bins", 0))
        late_split, late_stored = 1, sound.energy.shape[-1] - early
    a = np.rint(sound.bin_start_s * fs).astype(np.int64)
    w = np.rint(sound.bin_width_s * fs).astype(np.int64)
    late_w = int(w[early]) if w.size > early else 1
    expected_w = np.concatenate([np.ones(early, np.int64), np.full(w.size - early, late_w)])
    if not (np.allclose(sound.bin_width_s * fs, w, atol=1e-6) and np.array_equal(w, expected_w)
            and np.array_equal(a, np.concatenate([[0], np.cumsum(w)[:-1]]))):
        raise SonoluxError("the field's time bins are not one-sample bins followed by equal bins "
                           "on the sample grid: its responses cannot be synthesised in the "
                           "browser; export it with responses='pcm' (sonolux-web/2)")
    return Axis(early, late_w, late_split, split, late_stored)


def receiver_compact(sound: SoundField, reduced: CompactArray | None, arrivals: int,
                     split: int, r: int) -> CompactArray:
    """Receiver r's reduced compact field (one receiver), its late bins ungrouped (the
    bundle's cells and the browser's synthesis know one late resolution for all bands)."""
    if reduced is not None:
        return reduced.select(np.array([r])).ungrouped()
    early = int(sound.settings.get("early_bins", 0))
    dense = np.asarray(sound.energy[r:r + 1], np.float32)
    return CompactArray.of(dense, early).reduce(arrivals, split)


def stored_energy_per_bin(c: CompactArray, axis: Axis) -> np.ndarray:
    """float64[band, stored bin]: energy per early sample then per stored late bin, summed over
    directions."""
    n_bands = c.shape[2]
    early = np.zeros((n_bands, axis.early_bins))
    env = c.envelope[0].astype(np.float64).sum(axis=0)  # [band, envelope bin]
    starts = np.minimum(np.arange(env.shape[-1]) * axis.envelope_split, axis.early_bins - 1)
    early[:, starts] += env
    _, bi, ti = c._unravel(c.cell)
    np.add.at(early, (bi, ti), c.value.astype(np.float64))
    late = c.late[0].astype(np.float64).sum(axis=0)
    return np.concatenate([early, late], axis=-1)


def pressure_energy(per_band: np.ndarray, bands_hz: np.ndarray, fs: float) -> np.ndarray:
    """float64[bin]: the energy the synthesis gives a histogram's bins [band, bin]: white
    impulses scaled per band by sqrt(E_b) and split by the bank W_b (synthesis.py) carry
    mean_f (Σ_b W_b(f) sqrt(E_b))² (Parseval), the energy of the pressure the viewer plays."""
    if per_band.shape[0] == 1:
        return per_band[0]
    w = band_split_weights(2048, fs, bands_hz)  # [band, frequency]
    amp = np.sqrt(np.maximum(per_band, 0.0)).T @ w  # [bin, frequency]
    return np.mean(amp * amp, axis=1)


def cut_bins(per_bin: np.ndarray, axis: Axis, tail_db: float | None) -> tuple[int, int]:
    """(late bins kept, response length in samples) for a cell's energy per stored bin."""
    samples_per = np.concatenate([np.ones(axis.early_bins, np.int64),
                                  np.full(per_bin.size - axis.early_bins,
                                          axis.late_bin_samples * axis.late_split)])
    ends = np.cumsum(samples_per)
    n_late = per_bin.size - axis.early_bins
    if tail_db is None or per_bin.sum() <= 0:
        return n_late, int(ends[-1]) if ends.size else 0
    to_come = np.cumsum(per_bin[::-1])[::-1]
    below = np.flatnonzero(to_come <= to_come[0] * 10.0 ** (-tail_db / 10.0))
    if below.size == 0:
        return n_late, int(ends[-1])
    k = int(below[0])  # the first stored bin whose start has little enough still to come
    start = int(ends[k - 1]) if k > 0 else 0
    # One more late bin than the cut needs: the last kept bin is spread (spread_late) with
    # both its neighbours, as in the field.
    return min(n_late, max(0, k + 1 - axis.early_bins)), start


def cut_cell(c: CompactArray, late_bins: int, exact: tuple | None = None) -> CompactCell:
    out = CompactCell(int(c.onset[0]), c.cell.astype(np.uint32), c.value.astype(np.float32),
                      np.asarray(c.envelope[0], np.float32),
                      np.ascontiguousarray(c.late[0][..., :late_bins], np.float32))
    if exact is not None:
        out.exact_sample, out.exact_direction, out.exact_energy = exact
    return out


def exact_arrivals(sound: SoundField, r: int, part: CompactArray) -> tuple | None:
    """Receiver r's exact early arrivals of a hybrid field, as CompactCell stores them; None
    without [early]. The arrivals are in the histogram already (in their sector, at their
    sample): the viewer moves each from its sector's centre to its own direction
    (synthesis.ts, panArrival). Only arrivals whose (sector, sample) the compact part keeps
    exact are listed (the others are in its envelope, spread over 1 ms, and stay there)."""
    e = sound.early
    if e is None:
        return None
    early_bins = part.early_bins
    di, _, ti = part._unravel(part.cell)
    exact_cells = set(zip(di.tolist(), ti.tolist()))
    keep = (np.asarray(e["receiver"]) == r) & (np.asarray(e["time_bin"]) >= 0) \
        & (np.asarray(e["time_bin"]) < early_bins)
    mine = np.flatnonzero(keep)
    keep[mine] = [(int(e["direction_bin"][k]), int(e["time_bin"][k])) in exact_cells
                  for k in mine]
    v = np.asarray(e["from_direction"], np.float64)[keep]
    azimuth = np.degrees(np.arctan2(v[:, 1], v[:, 0])) % 360.0
    elevation = np.degrees(np.arcsin(np.clip(v[:, 2], -1.0, 1.0)))
    return (np.stack([np.asarray(e["time_bin"])[keep], np.asarray(e["direction_bin"])[keep]],
                     axis=1).astype(np.uint32),
            np.stack([azimuth, elevation], axis=1).astype(np.float32),
            np.asarray(e["energy"], np.float64)[keep].astype(np.float32))


# --- the synthesis (the reference the browser's worker follows) ------------------------------
def dense_histogram(cell: CompactCell, axis: Axis) -> np.ndarray:
    """float32[direction, band, time] of a stored cell on the dense axis (up to its last kept
    late bin), decoded by :meth:`CompactArray.receiver`."""
    n_d, n_b = cell.envelope.shape[:2]
    offset = np.array([0, cell.cell.size], np.int64)
    a = CompactArray(axis.early_bins, offset, cell.cell, cell.value, cell.late[None],
                     axis.late_split, cell.envelope[None], axis.envelope_split,
                     np.array([cell.onset], np.int64))
    assert a.shape[1:3] == (n_d, n_b)
    return a.receiver(0)


def time_bins(axis: Axis, n_bins: int, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """(bin_start_s, bin_width_s) of the dense axis's first n_bins bins."""
    w = np.concatenate([np.ones(axis.early_bins), np.full(n_bins - axis.early_bins,
                                                          float(axis.late_bin_samples))])
    start = np.concatenate([[0.0], np.cumsum(w)[:-1]])
    return start / fs, w / fs


def cell_response(histogram: np.ndarray, axis: Axis, length: int, fs: int, volume_m3: float,
                  c: float, bands_hz: np.ndarray, seed: int) -> np.ndarray:
    """The pressure response (float64) of one direction's histogram [band, time] of a cell,
    ended at ``length`` samples with a 10 ms fade: what the browser makes of it."""
    start_s, width_s = time_bins(axis, histogram.shape[-1], fs)
    if not np.any(histogram > 0):
        return np.zeros(0)
    ir = pressure_ir(histogram.astype(np.float64), start_s, width_s, bands_hz, fs, volume_m3, c,
                     seed=seed)
    return fade_cut(ir, length, fs)




def direct_mask(sound: SoundField, r: int, n_bins: int) -> np.ndarray:
    return direct_bins(sound, r)[:n_bins]
