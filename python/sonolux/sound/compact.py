"""The compact sound field: the same [receiver, direction, band, time] array, held as its early
part's non-zero cells and its late part at coarse resolution.

A sound field's time axis has one-sample bins for the first ``early_bins`` (the exact times of
early reflections) and ``late_bin_s`` bins after them. Most early cells of a receiver are empty
(a reflection is one sample wide; between reflections nothing arrives), while the late part is
dense and smooth. So :class:`CompactArray` keeps, per receiver,

- the early part as its non-zero cells: ``cell`` uint32[nonzero] (the flat index into the
  receiver's [direction, band, early time] block) and ``value`` [nonzero], receiver k's cells
  being ``offset[k]:offset[k + 1]``;
- the late part dense: ``late`` [receiver, direction, band, late time].

It reads like the dense array it stands for (``a[r]``, ``a[r, d]``, ``a[sel]`` with a slice or
an index array, ``shape``, ``dtype``, ``np.asarray(a)``, and the reductions ``sum``, ``max``,
``min``, ``mean`` and ``astype`` of :class:`sonolux.sound.lazy.ReceiverWise`): a receiver is
made dense only when asked for, so the analysis, synthesis and auralization need not know the
field is compact.
Nothing is lost: the dense array made from it is bit for bit the array it was made from.

The same layout holds the exact fixed-point counts (uint64) of a ray-range bake, which add up
exactly (:meth:`CompactArray.add`), so parts merge to the bits of one bake whether compact or not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.sound.lazy import ReceiverWise


@dataclass
class CompactArray(ReceiverWise):
    """A [receiver, direction, band, time] array as early non-zero cells + a dense late part."""

    early_bins: int
    offset: np.ndarray  # int64[receiver + 1]
    cell: np.ndarray  # uint32[nonzero]
    value: np.ndarray  # [nonzero]
    late: np.ndarray  # [receiver, direction, band, stored late time]
    #: Bins of the dense view per stored late bin (each stored bin spread over them by
    #: :func:`spread_late`); 1: the late part is shown as stored.
    late_split: int = 1
    #: The early energy not kept as cells (a reduced array, :meth:`reduce`):
    #: [receiver, direction, band, early envelope bin], each bin ``envelope_split`` one-sample
    #: bins wide and spread evenly over them; None: every non-zero early cell is kept.
    envelope: np.ndarray | None = None
    envelope_split: int = 1
    #: int64[receiver]: each receiver's onset sample (a reduced array): the envelope is spread
    #: over samples from it on only, so that nothing seems to arrive before the direct sound.
    onset: np.ndarray | None = None
    #: int64[band]: stored late bins summed per group in each band (a reduced array,
    #: :meth:`reduce`): band b's late part is held as groups of ``late_groups[b]`` stored bins,
    #: each group's sum in its first bin and zeros in the others (which the file's gzip takes
    #: to almost nothing), shown spread over the group as its neighbours' decay says (the
    #: stored bins past the last whole group are kept as they are); None: no groups.
    late_groups: np.ndarray | None = None

    # --- what it stands for ----------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int, int, int]:
        r, d, b, t = self.late.shape
        return (r, d, b, self.early_bins + t * self.late_split)

    @property
    def dtype(self) -> np.dtype:
        return self.late.dtype

    @property
    def nbytes(self) -> int:
        """Bytes held (not the dense array's)."""
        env = 0 if self.envelope is None else self.envelope.nbytes
        return int(self.offset.nbytes + self.cell.nbytes + self.value.nbytes + self.late.nbytes
                   + env)

    def receiver(self, k: int) -> np.ndarray:
        """The dense [direction, band, time] block of receiver k."""
        _, d, b, t = self.shape
        out = np.zeros((d, b, t), self.dtype)
        early = out[:, :, : self.early_bins]
        if self.envelope is not None:
            start = 0 if self.onset is None else int(self.onset[k])
            early[...] = spread_even(self.envelope[k], self.envelope_split, self.early_bins, start)
        lo, hi = int(self.offset[k]), int(self.offset[k + 1])
        # early is a view of a C-contiguous block's first columns: index through its shape.
        di, bi, ti = self._unravel(self.cell[lo:hi])
        if self.envelope is None:
            early[di, bi, ti] = self.value[lo:hi]
        else:
            early[di, bi, ti] = (early[di, bi, ti].astype(np.float64)
                                 + self.value[lo:hi]).astype(self.dtype)
        out[:, :, self.early_bins:] = self._late_view(self.late[k])
        return out

    def _late_view(self, late: np.ndarray) -> np.ndarray:
        """[direction, band, stored late bin] -> [direction, band, shown late bin]."""
        if self.late_groups is None:
            return late if self.late_split == 1 else spread_late(late, self.late_split)
        n = late.shape[-1]
        out = np.empty((*late.shape[:-1], n * self.late_split), late.dtype)
        for b, m in enumerate(int(g) for g in self.late_groups):
            whole = n // m * m
            parts = [spread_late(late[:, b, :whole:m], m * self.late_split)] if whole else []
            if whole < n:
                parts.append(spread_late(late[:, b, whole:], self.late_split))
            out[:, b] = np.concatenate(parts, axis=-1) if len(parts) > 1 else parts[0]
        return out

    def ungrouped(self) -> CompactArray:
        """The same array with no late groups: each group's sum spread over its stored bins
        as :func:`spread_late` shows it (sums kept), for readers that know only the stored
        late resolution (the web bundle's cells). Dense views agree with this array's to
        float32 rounding on an exponential decay, and closely elsewhere."""
        if self.late_groups is None:
            return self
        late = self.late.copy()
        n = late.shape[-1]
        for b, m in enumerate(int(g) for g in self.late_groups):
            whole = n // m * m
            if m > 1 and whole:
                late[:, :, b, :whole] = spread_late(self.late[:, :, b, :whole:m], m)
        return replace(self, late=late, late_groups=None)

    def _unravel(self, cell: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(direction, band, sample) of early cells."""
        bands = self.shape[2]
        di, rest = np.divmod(cell.astype(np.int64), bands * self.early_bins)
        bi, ti = np.divmod(rest, self.early_bins)
        return di, bi, ti

    def direction_sums(self) -> np.ndarray:
        """The array summed over directions, [receiver, band, time], with the late part at the
        resolution it is stored (``late_split`` bins of the dense view in one): exact for
        counts, where the dense view would spread them. Not for a reduced array."""
        if self.envelope is not None:
            raise SonoluxError("a reduced compact array no longer holds its early cells")
        n, _, bands, _ = self.shape
        early = np.zeros((n, bands, self.early_bins), self.dtype)
        owner = np.repeat(np.arange(n), np.diff(self.offset))
        _, bi, ti = self._unravel(self.cell)
        np.add.at(early, (owner, bi, ti), self.value)
        return np.concatenate([early, self.late.sum(axis=1, dtype=self.dtype)], axis=-1)

    # --- making and combining -------------------------------------------------------------
    @classmethod
    def of(cls, dense: np.ndarray, early_bins: int, late_split: int = 1) -> CompactArray:
        """The compact form of a dense [receiver, direction, band, time] array whose late bins
        are the stored ones (shown split into ``late_split`` bins each)."""
        dense = np.asarray(dense)
        r, d, b, t = dense.shape
        early = dense[..., :early_bins].reshape(r, d * b * early_bins)
        rows, cells = np.nonzero(early)
        offset = np.zeros(r + 1, np.int64)
        np.cumsum(np.bincount(rows, minlength=r), out=offset[1:])
        return cls(early_bins, offset, cells.astype(np.uint32), early[rows, cells],
                   np.ascontiguousarray(dense[..., early_bins:]), late_split)

    @classmethod
    def concatenate(cls, parts: list[CompactArray]) -> CompactArray:
        """The receivers of ``parts`` one after the other (tiles of one bake)."""
        if not parts:
            raise SonoluxError("no parts to concatenate")
        counts = np.concatenate([np.diff(p.offset) for p in parts])
        offset = np.zeros(counts.size + 1, np.int64)
        np.cumsum(counts, out=offset[1:])
        envelope = None if parts[0].envelope is None else \
            np.concatenate([p.envelope for p in parts])  # type: ignore[misc]
        onset = None if parts[0].onset is None else \
            np.concatenate([p.onset for p in parts])  # type: ignore[misc]
        return replace(parts[0], offset=offset, cell=np.concatenate([p.cell for p in parts]),
                       value=np.concatenate([p.value for p in parts]),
                       late=np.concatenate([p.late for p in parts]), envelope=envelope,
                       onset=onset)

    def _keys(self) -> np.ndarray:
        """int64 (receiver, cell) keys of the non-zero cells, in order."""
        per = np.int64(self.late.shape[1] * self.late.shape[2] * self.early_bins)
        rows = np.repeat(np.arange(self.shape[0], dtype=np.int64), np.diff(self.offset))
        return rows * per + self.cell.astype(np.int64)

    def _from_keys(self, keys: np.ndarray, values: np.ndarray, late: np.ndarray) -> CompactArray:
        per = self.late.shape[1] * self.late.shape[2] * self.early_bins
        rows, cells = np.divmod(keys, per)
        offset = np.zeros(self.shape[0] + 1, np.int64)
        np.cumsum(np.bincount(rows, minlength=self.shape[0]), out=offset[1:])
        return replace(self, offset=offset, cell=cells.astype(np.uint32), value=values,
                       late=late)

    def add(self, other: CompactArray) -> CompactArray:
        """The sum of two arrays of the same shape (exact for integer counts)."""
        if self.envelope is not None or other.envelope is not None:
            raise SonoluxError("a reduced field cannot be summed: sum the parts before reducing")
        if self.shape != other.shape or self.early_bins != other.early_bins \
                or self.dtype != other.dtype or self.late_split != other.late_split:
            raise SonoluxError("these two fields have different shapes and cannot be added")
        keys = np.concatenate([self._keys(), other._keys()])
        unique, slot = np.unique(keys, return_inverse=True)
        values = np.zeros(unique.size, self.dtype)
        np.add.at(values, slot, np.concatenate([self.value, other.value]))
        return self._from_keys(unique, values, self.late + other.late)

    def add_sparse(self, receiver: np.ndarray, direction: np.ndarray, band_values: np.ndarray,
                   time_bin: np.ndarray) -> CompactArray:
        """This array plus values at (receiver, direction, time bin) for every band
        (``band_values`` float[n, band]): each touched cell summed in float64, the additions in
        their order, rounded once to this array's type (how the exact early arrivals of a
        hybrid bake join the particles' field; see :func:`sonolux.sound.field.add_arrivals`)."""
        _, nd, nb, nt = self.shape
        n = receiver.size
        r = np.repeat(receiver.astype(np.int64), nb)
        d = np.repeat(direction.astype(np.int64), nb)
        b = np.tile(np.arange(nb, dtype=np.int64), n)
        t = np.repeat(time_bin.astype(np.int64), nb)
        v = np.asarray(band_values, np.float64).reshape(-1)
        late = self.late.copy()
        is_late = t >= self.early_bins
        if np.any(is_late):
            tl = t[is_late] - self.early_bins
            if self.late_groups is not None:  # a grouped band holds a group's sum in its first
                m = np.asarray(self.late_groups, np.int64)[b[is_late]]
                whole = late.shape[-1] // m * m
                tl = np.where(tl < whole, tl // m * m, tl)
            flat = np.ravel_multi_index((r[is_late], d[is_late], b[is_late], tl), late.shape)
            unique, slot = np.unique(flat, return_inverse=True)
            sums = np.zeros(unique.size, np.float64)
            np.add.at(sums, slot, v[is_late])
            lf = late.reshape(-1)
            lf[unique] = (lf[unique].astype(np.float64) + sums).astype(self.dtype)
        e = ~is_late
        per = np.int64(nd * nb * self.early_bins)
        new = r[e] * per + (d[e] * nb + b[e]) * self.early_bins + t[e]
        old = self._keys()
        keys = np.concatenate([old, new])
        unique, slot = np.unique(keys, return_inverse=True)
        sums = np.zeros(unique.size, np.float64)
        np.add.at(sums, slot[old.size:], v[e])
        base = np.zeros(unique.size, np.float64)
        base[slot[: old.size]] = self.value.astype(np.float64)
        values = base + sums  # + 0.0 leaves an untouched cell's value as it was
        return self._from_keys(unique, values.astype(self.dtype), late)

    def map_values(self, convert: Any, dtype: Any) -> CompactArray:
        """The same cells with every value through ``convert`` (e.g. counts to energies)."""
        late = np.empty(self.late.shape, dtype)
        for k in range(self.late.shape[0]):
            late[k] = convert(self.late[k])
        envelope = None if self.envelope is None else np.asarray(convert(self.envelope), dtype)
        return replace(self, value=np.asarray(convert(self.value), dtype), late=late,
                       envelope=envelope)

    def select(self, receivers: np.ndarray) -> CompactArray:
        """The receivers ``receivers`` (sorted indices) only."""
        receivers = np.asarray(receivers, np.int64)
        pieces = [np.arange(self.offset[k], self.offset[k + 1]) for k in receivers]
        take = np.concatenate(pieces) if pieces else np.zeros(0, np.int64)
        counts = np.diff(self.offset)[receivers]
        offset = np.zeros(receivers.size + 1, np.int64)
        np.cumsum(counts, out=offset[1:])
        return replace(self, offset=offset, cell=self.cell[take], value=self.value[take],
                       late=self.late[receivers],
                       envelope=None if self.envelope is None else self.envelope[receivers],
                       onset=None if self.onset is None else self.onset[receivers])

    def reduce(self, arrivals: int, envelope_split: int,
               late_groups: Any = None) -> CompactArray:
        """The early part as the ``arrivals`` strongest (direction, sample) arrivals of each
        receiver, exact in every band (with every cell up to its onset and at its peak), and
        the rest of it as an envelope of bins
        ``envelope_split`` samples wide (spread evenly over them when shown). Every envelope
        bin keeps its energy's sum, so energies over windows of whole envelope bins (and the
        total) are unchanged; the arrivals keep the exact times and directions of the
        strongest reflections. Ties are broken by the arrival's index: the same bits every time.
        ``late_groups`` (int[band] or None): the late part of band b summed in groups of that
        many stored bins (see the attribute).
        """
        if self.envelope is not None:
            raise SonoluxError("this field is reduced already")
        n_r, n_d, n_b, _ = self.shape
        eb = self.early_bins
        n_env = -(-eb // envelope_split)
        rows = np.repeat(np.arange(n_r, dtype=np.int64), np.diff(self.offset))
        d, rest = np.divmod(self.cell.astype(np.int64), n_b * eb)
        b, t = np.divmod(rest, eb)
        # Arrivals (receiver, direction, sample), their strength summed over bands.
        akey = (rows * n_d + d) * eb + t
        ukeys, slot = np.unique(akey, return_inverse=True)
        strength = np.zeros(ukeys.size, np.float64)
        np.add.at(strength, slot, self.value.astype(np.float64))
        a_row = ukeys // (n_d * eb)
        order = np.lexsort((ukeys, -strength, a_row))
        first = np.searchsorted(a_row[order], np.arange(n_r))
        rank = np.empty(ukeys.size, np.int64)
        rank[order] = np.arange(ukeys.size) - first[a_row[order]]
        keep = (rank < arrivals)[slot]
        # Also kept exact: every cell up to each receiver's onset and at its peak, so that the
        # onset (the first sample within 20 dB of the peak power, ISO 3382-1 A.3.4), from
        # which C50, C80, D50, Ts and EDT are counted, is the same sample as in the full field.
        omni = np.zeros((n_r, eb), np.float64)
        np.add.at(omni, (rows, t), self.value.astype(np.float64))
        peak = np.argmax(omni, axis=1)
        onset = np.argmax(omni >= 0.01 * omni[np.arange(n_r), peak][:, None], axis=1)
        keep |= (t <= onset[rows]) | (t == peak[rows])
        keep |= self._crossing_bins(rows, b, t, onset, envelope_split)
        envelope = np.zeros((n_r, n_d, n_b, n_env), np.float64)
        np.add.at(envelope, (rows[~keep], d[~keep], b[~keep], t[~keep] // envelope_split),
                  self.value[~keep].astype(np.float64))
        offset = np.zeros(n_r + 1, np.int64)
        np.cumsum(np.bincount(rows[keep], minlength=n_r), out=offset[1:])
        late, groups = self.late, None
        if late_groups is not None and np.any(np.asarray(late_groups) > 1):
            groups = np.asarray(late_groups, np.int64)
            late = grouped(self.late, groups)
        return replace(self, offset=offset, cell=self.cell[keep], value=self.value[keep],
                       envelope=envelope.astype(self.dtype), envelope_split=envelope_split,
                       onset=onset.astype(np.int64), late=late, late_groups=groups)


    def _crossing_bins(self, rows: np.ndarray, band: np.ndarray, t: np.ndarray,
                       onset: np.ndarray, split: int) -> np.ndarray:
        """bool[cell]: the early cells in the envelope bins where a band's decay curve (the
        backward integral from the receiver's onset, ISO 3382-1 5.3.3, all directions) falls
        through the levels that start or end a decay fit: -5 dB (T20, T30) and -10 dB (EDT).

        Near a source the curve falls in steps: the direct sound, then single reflections with
        gaps between them, so where it crosses -10 dB is a sample that a reflection sets.
        Spread evenly over its envelope bin, that reflection's energy would move the crossing
        to the bin's start (paper-large, 8 kHz, a receiver 1 m from the source: EDT 0.645 →
        0.637 s, 1.2 %). Kept exact, every bin before it and the late part keep their sums,
        so the curve is exact through that bin and crosses at the same sample."""
        n_r, _, n_b, _ = self.shape
        v = self.value.astype(np.float64)
        group = rows * n_b + band
        late = self.late.sum(axis=(1, 3), dtype=np.float64).reshape(-1)  # [receiver × band]
        after_onset = t >= onset[rows]
        start = late + np.bincount(group[after_onset], v[after_onset], n_r * n_b)
        # Energy from each cell's sample on (cells of one sample in any order: one bin).
        order = np.lexsort((t, group))
        g, vo = group[order], v[order]
        total = np.bincount(g, vo, n_r * n_b)
        before = np.cumsum(vo) - vo
        first = np.searchsorted(g, np.arange(n_r * n_b))
        before -= np.concatenate([[0.0], np.cumsum(vo)])[first][g]
        from_here = late[g] + total[g] - before
        after = from_here - vo
        cross = np.zeros(g.size, bool)
        for level_db in (-5.0, -10.0):
            limit = start[g] * 10.0 ** (level_db / 10.0)
            cross |= (from_here > limit) & (after <= limit) & after_onset[order]
        # The envelope bins holding a crossing, per (receiver, band).
        binned = group * np.int64(-(-self.early_bins // split)) + t // split
        held = np.unique(binned[order][cross])
        return np.isin(binned, held)


def grouped(late: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """[receiver, direction, band, stored bin] with band b's bins summed in groups of
    ``groups[b]`` (float64 sums rounded once), each sum in its group's first bin, zeros in the
    others; the bins past the last whole group as they were."""
    out = np.array(late, copy=True)
    n = late.shape[-1]
    for b, m in enumerate(int(g) for g in groups):
        whole = n // m * m
        if m <= 1 or whole == 0:
            continue
        block = late[:, :, b, :whole].astype(np.float64)
        sums = block.reshape(*block.shape[:-1], whole // m, m).sum(-1)
        out[:, :, b, :whole] = 0
        out[:, :, b, :whole:m] = sums.astype(late.dtype)
    return out


def is_compact(array: Any) -> bool:
    return isinstance(array, CompactArray)


#: The largest change of level a spread allows across one stored bin (ln of 10⁶: 60 dB), so
#: that an isolated deposit beside an empty bin is not squeezed into one edge.
MAX_LOG_STEP = math.log(1e6)


def spread_even(envelope: np.ndarray, split: int, n: int, start: int = 0) -> np.ndarray:
    """float[..., bins] -> float[..., n]: each bin's value shared evenly by the ``split``
    one-sample bins it covers (the last may cover fewer), none before sample ``start``."""
    e = np.asarray(envelope, np.float64)
    lo = np.arange(e.shape[-1]) * split
    hi = np.minimum(lo + split, n)
    counts = hi - np.clip(start, lo, hi)
    share = np.where(counts > 0, e / np.maximum(counts, 1), 0.0)
    out = np.repeat(share, hi - lo, axis=-1)
    out[..., :start] = 0.0
    # A bin wholly before the start (empty by construction) stays empty.
    return out.astype(envelope.dtype)


def spread_late(late: np.ndarray, split: int) -> np.ndarray:
    """Each stored late bin spread over ``split`` bins as the exponential its neighbours show:
    float[..., t] -> float[..., t × split], every stored bin's sum kept (to float32 rounding).

    A reverberant tail decays exponentially, so within a bin of width Δ the energy follows
    e^{−k t} with k read from the neighbours' levels (the central difference of ln E, one-sided
    at the ends or beside an empty bin; flat where neither neighbour has energy). Spread this
    way, a Schroeder curve of the coarse bins is exact at the stored bins' edges and follows
    the exponential between them, instead of the straight lines that a flat spread gives.
    """
    e = np.asarray(late, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        ln = np.where(e > 0, np.log(np.where(e > 0, e, 1.0)), np.nan)
    prev = np.concatenate([np.full(ln.shape[:-1] + (1,), np.nan), ln[..., :-1]], -1)
    nxt = np.concatenate([ln[..., 1:], np.full(ln.shape[:-1] + (1,), np.nan)], -1)
    step = np.where(np.isfinite(prev) & np.isfinite(nxt), 0.5 * (nxt - prev),
                    np.where(np.isfinite(nxt), nxt - ln, np.where(np.isfinite(prev), ln - prev,
                                                                  0.0)))
    step = np.clip(np.nan_to_num(step, nan=0.0), -MAX_LOG_STEP, MAX_LOG_STEP)
    i = (np.arange(split) + 0.5) / split - 0.5
    w = np.exp(step[..., None] * i)
    w /= w.sum(-1, keepdims=True)
    out = (e[..., None] * w).reshape(*e.shape[:-1], e.shape[-1] * split)
    return out.astype(late.dtype if late.dtype.kind == "f" else np.float64)


def add_counts(a: Any, b: Any) -> Any:
    """The exact sum of two count arrays, dense or compact (both the same kind)."""
    if isinstance(a, CompactArray) and isinstance(b, CompactArray):
        return a.add(b)
    if isinstance(a, CompactArray) or isinstance(b, CompactArray):
        raise SonoluxError("a compact field and a full one cannot be summed: bake the parts "
                           "with the same storage")
    return np.add(a, b)


def energy_of(counts: Any, quantum: float) -> Any:
    """float32 energy = counts × quantum, rounded once from float64 as the core does; one
    receiver at a time, so that no float64 copy of the whole field is made."""
    def convert(c: np.ndarray) -> np.ndarray:
        return (np.asarray(c).astype(np.float64) * quantum).astype(np.float32)

    if isinstance(counts, CompactArray):
        return counts.map_values(convert, np.float32)
    energy = np.empty(counts.shape, np.float32)
    for r in range(counts.shape[0]):
        energy[r] = convert(counts[r])
    return energy


def reduced(energy: Any, settings: dict[str, Any]) -> Any:
    """A complete bake's compact energy reduced as its settings say (``compact_arrivals``,
    ``compact_envelope_s``); dense or already reduced energy as it is."""
    if not isinstance(energy, CompactArray) or energy.envelope is not None:
        return energy
    split = max(1, round(float(settings["compact_envelope_s"]) * float(settings["sample_rate_hz"])))
    return energy.reduce(int(settings["compact_arrivals"]), split,
                         settings.get("compact_late_groups"))
