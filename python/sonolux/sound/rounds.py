"""One round of a progressive sound bake as a :class:`sonolux.ranges.RangeWork`, so that rounds
run in ranges here or on a Dask cluster and are checkpointed like any bake.

A round traces rays ``start..end`` of one bake of ``nominal`` rays
(:class:`sonolux.sound.ranges.SoundRanges`). The round is cut into ``groups`` equal parts; ray i
belongs to group (i − start) · groups // (end − start). :meth:`RoundWork.trace` splits whatever
range a runner hands it at those boundaries, so that every part knows its group exactly, however
the runner (or a resumed checkpoint) cuts the round. The sum it builds, :class:`RoundSum`,
carries the whole bake so far: the exact counts of every ray, and per group the counts summed
over directions, uint64[group, receiver, band, time] (what the error estimate needs).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sonolux import ranges
from sonolux.checkpoint import fingerprint
from sonolux.memory import check_memory
from sonolux.sound.compact import CompactArray
from sonolux.sound.ranges import SoundRanges, SoundSum, decode_sum, encode_sum
from sonolux.sound.tail import TailSum, of_core, watch_record

Range = tuple[int, int]


@dataclass
class RoundSum:
    """The exact sum of a progressive bake's rays so far: ``total`` (every ray's counts),
    ``groups`` (uint64[group, receiver, band, time], direction-summed; None before the first
    ray), ``rounds`` (what each finished round reached, for the record) and ``choice`` (the
    automatic estimator's record, :func:`sonolux.sound.progressive.choose`: kept in the
    checkpoint so that a resumed bake continues with it and traces no pilot again), ``tail``
    the largest late contributions of the round's rays so far (:mod:`sonolux.sound.tail`; None
    where the round is not watched)."""

    total: SoundSum | None = None
    groups: np.ndarray | None = None
    rounds: list[dict[str, Any]] = field(default_factory=list)
    choice: dict[str, Any] | None = None
    tail: TailSum | None = None


@dataclass
class RoundPart:
    """What one traced range adds: its counts, per group it touched its omni counts, and the
    largest late contributions of its rays (when watched)."""

    total: SoundSum
    by_group: dict[int, np.ndarray]
    tail: TailSum | None = None


class RoundWork:
    """Rays ``start..end`` of the bake ``inner`` (a SoundRanges of ``nominal`` rays), added to
    ``carry`` (the rounds before; a fresh RoundSum for the first). ``tail``: (from_s
    float64[receiver, band], kept per entry) of the late contributions the core keeps
    (:func:`sonolux.sound.tail.round_settings`), or None."""

    unit = "rays"

    def __init__(self, inner: SoundRanges, start: int, end: int, groups: int,
                 carry: RoundSum, tail: tuple[np.ndarray, int] | None = None) -> None:
        if (end - start) % groups:
            raise ValueError("a round must split into equal groups")
        self.inner, self.groups, self.carry, self.tail = inner, groups, carry, tail
        self.kind, self.name = inner.kind, f"{inner.name}, round {len(carry.rounds) + 1}"
        self.total = inner.total
        self.target: Range = (start, end)
        self.stamp = dict(inner.stamp, progressive=fingerprint(groups, start, end, carry.rounds))
        self.fingerprint = fingerprint("sound-progressive", self.stamp)

    def __getstate__(self) -> dict[str, Any]:  # Dask ships the work, never the sums
        return dict(self.__dict__, carry=None)

    def group_of(self, ray: int) -> int:
        start, end = self.target
        return (ray - start) * self.groups // (end - start)

    def cuts(self, first: int, end: int) -> list[Range]:
        """first..end cut at the groups' boundaries."""
        start, stop = self.target
        size = (stop - start) // self.groups
        out, at = [], first
        while at < end:
            nxt = min(end, start + (self.group_of(at) + 1) * size)
            out.append((at, nxt))
            at = nxt
        return out

    def trace(self, first: int, end: int, threads: int | None = None,
              progress: ranges.Progress | None = None) -> RoundPart:
        total: SoundSum | None = None
        by_group: dict[int, np.ndarray] = {}
        tail: TailSum | None = None
        for a, b in self.cuts(first, end):
            part = self.inner.trace(a, b, threads, _offset(progress, a - first), tail=self.tail)
            late = part.stats.pop("tail", None)
            if late is not None and self.tail is not None:
                t = of_core(late, self.tail[0].shape, self.target)
                tail = t if tail is None else tail.add(t)
            omni = omni_counts(part.counts)
            g = self.group_of(a)
            by_group[g] = omni if g not in by_group else by_group[g] + omni
            total = part if total is None else total.add(part)
        assert total is not None
        return RoundPart(total, by_group, tail)

    def add(self, total: RoundSum | None, part: RoundPart) -> RoundSum:
        out = self.carry if total is None else total
        out.total = part.total if out.total is None else out.total.add(part.total)
        for g, omni in part.by_group.items():
            if out.groups is None:
                check_memory(self.groups * omni.nbytes, "the progressive bake's ray groups",
                             f"{self.groups} groups of {omni.nbytes:,} bytes")
                out.groups = np.zeros((self.groups, *omni.shape), np.uint64)
            out.groups[g] += omni
        if part.tail is not None:
            fresh = out.tail is None or out.tail.target != self.target
            out.tail = part.tail if fresh or out.tail is None else out.tail.add(part.tail)
        return out

    def encode(self, total: RoundSum) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        meta, arrays = encode_sum(total.total) if total.total is not None else ({}, {})
        meta = {"sum": meta, "progressive": {"rounds": total.rounds, "groups": self.groups,
                                             "target": list(self.target),
                                             "choice": total.choice}}
        if total.groups is not None:
            arrays = dict(arrays, groups=total.groups)
        if self.tail is not None:  # what this round watches: a resumed round watches it too
            meta["progressive"]["watch"] = watch_record(self.tail)
        if total.tail is not None:
            meta["progressive"]["tail_target"] = list(total.tail.target)
            arrays = dict(arrays, tail_values=total.tail.values,
                          tail_contributing=total.tail.contributing)
        return meta, arrays

    def decode(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> RoundSum:
        inner = {k: v for k, v in arrays.items() if k != "groups" and not k.startswith("tail_")}
        total = decode_sum(meta["sum"], inner) if meta["sum"] else None
        groups = np.array(arrays["groups"], np.uint64) if "groups" in arrays else None
        progressive = meta["progressive"]
        tail = None
        if "tail_values" in arrays and "tail_target" in progressive:
            start, end = progressive["tail_target"]
            tail = TailSum((int(start), int(end)), np.array(arrays["tail_values"], np.float64),
                           np.array(arrays["tail_contributing"], np.uint64))
        return RoundSum(total, groups, list(progressive["rounds"]), progressive.get("choice"),
                        tail)

    def finish(self, total: RoundSum | None, done: list[Range]) -> RoundSum:
        del done
        return self.carry if total is None else total


def omni_counts(counts: Any) -> np.ndarray:
    """Exact counts summed over directions, uint64[receiver, band, time], from dense counts or a
    compact array (its late part at the resolution it stores: see :func:`omni_bins`)."""
    if isinstance(counts, CompactArray):
        return counts.direction_sums()
    return np.asarray(counts).sum(axis=1, dtype=np.uint64)


def omni_bins(template: Any, counts: Any) -> tuple[np.ndarray, np.ndarray]:
    """(bin starts, bin widths) in s of :func:`omni_counts`' time axis."""
    start, width = np.asarray(template.bin_start_s), np.asarray(template.bin_width_s)
    if not isinstance(counts, CompactArray) or counts.late_split == 1:
        return start, width
    e, k = counts.early_bins, counts.late_split
    return (np.concatenate([start[:e], start[e::k]]),
            np.concatenate([width[:e], width[e:].reshape(-1, k).sum(axis=1)]))


def _offset(progress: ranges.Progress | None, before: int) -> ranges.Progress | None:
    if progress is None:
        return None

    def report(done: int, total: int, elapsed_s: float) -> bool:
        return progress(before + done, total, elapsed_s)

    return report
