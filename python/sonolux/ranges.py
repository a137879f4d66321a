"""Bakes in ray ranges: run the ranges (here, or as Dask tasks), sum them exactly, checkpoint.

Ray ``i`` of a bake draws its random numbers from (seed, source, i) only, and the tracer sums
energy as integers (fixed point), so the rays of a bake can be traced in any ranges, in any
order, on any machine, and their sums add up to the bits of the bake done at once. This module
is the orchestration that uses this, the same for every kind of bake:

1. :class:`Checkpointing` reads the side file of an earlier run (``--resume``), checks that it
   belongs to this bake, and tells which rays are already done;
2. a runner traces what is missing in ranges: :class:`LocalRunner` one range after the other in
   this process, sized so that a range takes about one checkpoint interval, or
   :class:`sonolux.distributed.DaskRunner` as tasks of a Dask cluster;
3. every finished range is added to the sum (in the order they finish: integer sums do not care)
   and, once per interval, the sum is checkpointed;
4. the complete sum becomes the field.

What a kind of bake must provide is the small :class:`RangeWork` interface
(:class:`sonolux.sound.ranges.SoundRanges` for sound; light plugs in the same way once its ranges
merge exactly).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from sonolux import checkpoint as side
from sonolux import engine
from sonolux.errors import SonoluxError
from sonolux.scene.schema import Scene

Range = tuple[int, int]
Progress = Callable[[int, int, float], bool]
#: With checkpoints on and no range size given, the first range is this share of the bake; the
#: next ones are sized from its speed to take one checkpoint interval.
FIRST_RANGE_SHARE = 1 / 16
#: The last scene a worker process rebuilt (its fingerprint, the scene with its BVH).
_WORKER_SCENE: dict[str, Scene] = {}


def scene_content(scene: Scene) -> Scene:
    """The scene without what does not change a bake's bits: its BVH handle (rebuilt from the
    triangles), warnings, where it was loaded from and the thread count. Fingerprinted, it is
    the scene part of a checkpoint's stamp; pickled, what a Dask task carries."""
    return replace(scene, geometry=None, warnings=[], origin="",
                   settings=replace(scene.settings, threads=0))


def loaded_scene(scene: Scene, key: str, threads: int | None = None) -> Scene:
    """``scene`` with its BVH: as given, or (in a worker, where it arrives without one) rebuilt
    from its triangles once per worker process and kept under ``key``; with ``threads`` engine
    threads if given."""
    if scene.geometry is None:
        if key not in _WORKER_SCENE:
            _WORKER_SCENE.clear()
            _WORKER_SCENE[key] = replace(scene, geometry=engine.Geometry(
                scene.vertices_m, scene.triangles, scene.material_index))
        scene = _WORKER_SCENE[key]
    if threads is not None:
        scene = replace(scene, settings=replace(scene.settings, threads=threads))
    return scene


class RangeWork(Protocol):
    """One bake that can be traced in ray ranges and summed exactly.

    ``trace`` must be callable in another process from a pickled copy (Dask sends it to the
    workers once): it carries the scene's content, never a path to it."""

    kind: str            # "sound", ...: what is baked, for messages and the checkpoint
    name: str            # the scene's name, for the progress line
    unit: str            # "rays", ...: what a range counts
    total: int           # how many in the whole bake (they number the random streams)
    target: Range        # the ones this run traces: all of them, or a ``--range`` part
    fingerprint: str     # the bake's identity: scene content, settings, version
    stamp: dict[str, str]  # its parts (scene, settings, version), to say what differs

    def trace(self, first: int, end: int, threads: int | None = None,
              progress: Progress | None = None) -> Any:
        """The exact partial sum of rays first..end (picklable)."""

    def add(self, total: Any | None, part: Any) -> Any:
        """``total`` + ``part`` (``total`` None: nothing yet); may add into ``total``."""

    def encode(self, total: Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """A partial sum as JSON-able metadata and exact arrays, for the checkpoint."""

    def decode(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> Any:
        """The partial sum that ``encode`` wrote."""

    def finish(self, total: Any, done: list[Range]) -> Any:
        """The field of the sum of the ranges ``done``."""


def missing(target: Range, done: list[Range]) -> list[Range]:
    """The parts of ``target`` that no range in ``done`` covers, in order."""
    out, at = [], target[0]
    for a, b in sorted(done):
        if a > at:
            out.append((at, min(a, target[1])))
        at = max(at, b)
        if at >= target[1]:
            break
    if at < target[1]:
        out.append((at, target[1]))
    return [r for r in out if r[0] < r[1]]


def overlaps(ranges: list[Range]) -> list[tuple[Range, Range]]:
    """Pairs of ranges that share rays (neighbours after sorting)."""
    s = sorted(tuple(r) for r in ranges)
    return [(a, b) for a, b in zip(s, s[1:]) if b[0] < a[1]]


def join(ranges: list[Range]) -> list[Range]:
    """The ranges with touching ones joined: [(0, 5), (5, 9)] → [(0, 9)]."""
    out: list[list[int]] = []
    for a, b in sorted(ranges):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def split(ranges: list[Range], pieces: int) -> list[Range]:
    """``ranges`` cut into about ``pieces`` ranges of equal size (none empty)."""
    total = sum(b - a for a, b in ranges)
    if total == 0:
        return []
    size = max(1, math.ceil(total / max(1, pieces)))
    return [(s, min(s + size, b)) for a, b in ranges for s in range(a, b, size)]


class Tracker:
    """Turns the progress of ranges into the progress of the bake: ``done`` counts what was
    restored from the checkpoint and what finished since; the ETA comes from this run's speed."""

    def __init__(self, callback: Progress | None, total: int, done: int) -> None:
        self.callback, self.total, self.done = callback, total, done
        self.started, self.restored = time.perf_counter(), done

    def elapsed(self) -> float:
        return time.perf_counter() - self.started

    def during(self, first_done: int) -> Progress | None:
        """The engine's callback for one range that starts after ``first_done`` more units."""
        if self.callback is None:
            return None
        base = self.done + first_done

        def report(done: int, total: int, elapsed_s: float) -> bool:
            return self.report(base + done)
        return report

    def finished(self, n: int) -> None:
        self.done += n
        self.report(self.done)

    def report(self, done: int) -> bool:
        if self.callback is None:
            return True
        # The callback's rate is this run's: restored units are not counted as speed.
        elapsed = self.elapsed()
        traced = max(done - self.restored, 0)
        scaled = elapsed * done / traced if traced else elapsed
        return bool(self.callback(done, self.total, scaled))


class Runner(Protocol):
    def run(self, work: RangeWork, todo: list[Range], on_part: Callable[[Range, Any], None],
            tracker: Tracker) -> None:
        """Traces the ranges ``todo`` and hands each finished one to ``on_part``."""


@dataclass
class LocalRunner:
    """Traces in this process, one range after the other. ``range_size``: units per range;
    None = the first range is 1/16 of the bake, the next ones take about ``interval_s``."""

    range_size: int | None = None
    interval_s: float = 60.0
    threads: int | None = None

    def run(self, work: RangeWork, todo: list[Range], on_part: Callable[[Range, Any], None],
            tracker: Tracker) -> None:
        span = work.target[1] - work.target[0]
        size = self.range_size or max(1, math.ceil(span * FIRST_RANGE_SHARE))
        for a, b in todo:
            at = a
            while at < b:
                end = min(at + size, b)
                started = time.perf_counter()
                part = work.trace(at, end, self.threads, tracker.during(0))
                on_part((at, end), part)
                tracker.finished(end - at)
                seconds = time.perf_counter() - started
                if self.range_size is None and seconds > 0:
                    size = max(size, int((end - at) * self.interval_s / seconds))
                at = end


@dataclass
class Checkpointing:
    """The side file of a bake (``path``), written at most every ``interval_s`` (0: after every
    range). ``resume`` continues from it; ``restart`` discards it; with neither, an existing
    one stops the bake with a hint, so that hours of work are never thrown away unasked."""

    path: Path
    interval_s: float = 60.0
    resume: bool = False
    restart: bool = False
    log: Callable[[str], None] | None = None
    last_write: float = field(default_factory=time.perf_counter)
    writes: int = 0
    write_s: float = 0.0

    def note(self, message: str) -> None:
        if self.log:
            self.log(message)

    def load(self, work: RangeWork) -> tuple[Any | None, list[Range]]:
        """(the restored sum or None, the ranges it holds)."""
        self.path = Path(self.path)
        side.remove_leftovers(self.path)
        if not self.path.exists():
            if self.resume:
                self.note(f"no checkpoint {self.path} to resume from: baking from the start")
            return None, []
        if self.restart:
            self.path.unlink()
            self.note(f"discarded the checkpoint {self.path} (--restart)")
            return None, []
        try:
            header, arrays = side.read(self.path)
            self.check(work, header)
        except side.CheckpointError as exc:
            if exc.reason == "damaged" and self.resume:
                self.note(f"warning: {exc}: it is not used; baking from the start (it will be "
                          "replaced)")
                return None, []
            raise SonoluxError(f"{exc}; nothing of it is merged: --restart discards it"
                               + ("" if self.resume else ", or move it away")) from None
        done = [(int(a), int(b)) for a, b in header["done"]]
        share = sum(b - a for a, b in done) / max(1, work.target[1] - work.target[0])
        if not self.resume:
            raise SonoluxError(
                f"{self.path} holds {share:.0%} of this bake ({_ranges_text(done)} of "
                f"{_ranges_text([work.target])} {work.unit}): add --resume to continue it, or "
                "--restart to discard it and bake from the start")
        self.note(f"resuming from {self.path}: {share:.0%} done ({_ranges_text(done)} "
                  f"{work.unit})")
        return work.decode(header["meta"], arrays), done

    def check(self, work: RangeWork, header: dict[str, Any]) -> None:
        """A CheckpointError("foreign") naming what differs, unless it is this bake's."""
        if header.get("fingerprint") == work.fingerprint and header.get("kind") == work.kind \
                and list(header.get("target", [])) == list(work.target):
            return
        theirs = header.get("stamp", {})
        differs = [k for k, v in work.stamp.items() if theirs.get(k) != v]
        if header.get("kind") != work.kind:
            differs.insert(0, f"it is a {header.get('kind')} bake")
        if list(header.get("target", [])) != list(work.target):
            differs.append(f"its ray range is {_ranges_text([tuple(header.get('target', ()))])}")
        raise side.CheckpointError(
            f"{self.path}: the checkpoint belongs to another bake (differs in: "
            f"{', '.join(differs) or 'fingerprint'})", "foreign")

    def due(self) -> bool:
        return time.perf_counter() - self.last_write >= self.interval_s

    def save(self, work: RangeWork, total: Any, done: list[Range]) -> None:
        started = time.perf_counter()
        meta, arrays = work.encode(total)
        header = {"kind": work.kind, "fingerprint": work.fingerprint, "stamp": work.stamp,
                  "unit": work.unit, "total": work.total, "target": list(work.target),
                  "done": [list(r) for r in join(done)], "meta": meta}
        side.write(self.path, header, arrays)
        self.last_write = time.perf_counter()
        self.writes += 1
        self.write_s += self.last_write - started

    def discard(self) -> None:
        """Removes the side file once the output it was for is safely written."""
        Path(self.path).unlink(missing_ok=True)


def _ranges_text(ranges: list[Range]) -> str:
    return ", ".join(f"{a}..{b}" for a, b in join(list(ranges))) or "none"


def run_ranges(work: RangeWork, runner: Runner, *, checkpoint: Checkpointing | None = None,
               progress: Progress | None = None) -> tuple[Any, dict[str, Any]]:
    """Traces ``work.target`` with ``runner``, resuming from and writing to ``checkpoint``;
    returns (the field, a report: ranges, restored units, checkpoint writes and seconds)."""
    started = time.perf_counter()
    total: Any = None
    done: list[Range] = []
    if checkpoint is not None:
        total, done = checkpoint.load(work)
    restored = sum(b - a for a, b in done)
    todo = missing(work.target, done)
    tracker = Tracker(progress, work.target[1] - work.target[0], restored)
    ranges_run: list[Range] = []

    def on_part(rng: Range, part: Any) -> None:
        nonlocal total
        if any(max(a, rng[0]) < min(b, rng[1]) for a, b in done):
            raise SonoluxError(f"{work.unit} {rng[0]}..{rng[1]} were traced twice (a bug)")
        total = work.add(total, part)
        done.append(rng)
        ranges_run.append(rng)
        if checkpoint is not None and missing(work.target, done) and checkpoint.due():
            checkpoint.save(work, total, done)

    if todo:
        runner.run(work, todo, on_part, tracker)
    if missing(work.target, done):
        raise SonoluxError(f"{work.unit} {_ranges_text(missing(work.target, done))} were not "
                           "traced (a bug)")
    result = work.finish(total, done)
    report = {"ranges": [list(r) for r in sorted(ranges_run)], "restored": restored,
              "seconds": time.perf_counter() - started,
              "checkpoint_writes": checkpoint.writes if checkpoint else 0,
              "checkpoint_write_s": checkpoint.write_s if checkpoint else 0.0}
    return result, report
