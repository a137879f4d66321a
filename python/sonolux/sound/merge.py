"""Ray-range bakes merged into one field: ``sonolux bake --range FIRST:END`` on several
machines, then ``sonolux merge PART... -o FIELD``. The counts are integers, so the merged field
is the same bits as the bake done at once; parts of other bakes (another seed, ray count,
scene or binning) and overlapping ranges are refused, and missing ranges are named."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sonolux.errors import SonoluxError
from sonolux.fieldfile import open_field
from sonolux.sound.field import SoundField


def missing_ranges(field: SoundField) -> list[tuple[int, int]]:
    """The ray ranges of 0..rays that no part covered, in order."""
    ranges = sorted(tuple(r) for r in field.settings.get("ray_ranges",
                                                         [field.settings["ray_range"]]))
    out, at = [], 0
    for first, end in ranges:
        if first > at:
            out.append((at, first))
        at = max(at, end)
    if at < field.settings["rays"]:
        out.append((at, int(field.settings["rays"])))
    return out


def merge_parts(paths: Sequence[str | Path], *, allow_missing: bool = False) -> SoundField:
    """The field of the parts added together; an error names a part that does not belong, and
    the missing ranges unless ``allow_missing``."""
    if not paths:
        raise SonoluxError("merge: give the field files of the ray ranges to merge")
    parts = [open_field(p) for p in paths]
    merged = parts[0]
    if merged.scene_name != parts[0].scene_name:
        raise SonoluxError(f"{paths[0]}: not a part of the same scene")
    for path, part in zip(paths[1:], parts[1:]):
        if part.scene_name != merged.scene_name:
            raise SonoluxError(f"{path}: a bake of {part.scene_name!r}, not of "
                               f"{merged.scene_name!r}: it does not belong with {paths[0]}")
        try:
            merged = merged.merge(part)
        except SonoluxError as exc:
            raise SonoluxError(f"{path}: {exc}") from None
    gaps = missing_ranges(merged)
    if gaps and not allow_missing:
        spans = ", ".join(f"{a}:{b}" for a, b in gaps)
        raise SonoluxError(f"merge: rays {spans} of the bake's {merged.settings['rays']:,} are "
                           f"missing: bake them with --range {gaps[0][0]}:{gaps[0][1]} (or "
                           "merge with --partial to keep a field of fewer rays)")
    return merged
