"""Merging the parts of a bake: field files of ray ranges and checkpoints, summed exactly.

A bake can be cut into parts: ``sonolux bake --range`` on several machines, a Dask bake, a
bake stopped and left with its checkpoint. :func:`merge_parts` takes any of these, checks that
they are parts of one bake (the same fingerprint: scene content, settings, version; for older
files without one, the same rays, seed, binning and quantum), that no rays are in two parts, and
names the rays that no part holds. The sum of the parts' counts is exact: a complete merge has
the bits of the bake done at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sonolux import checkpoint as side
from sonolux import fieldfile
from sonolux.errors import SonoluxError
from sonolux.ranges import Range, join, missing, overlaps
from sonolux.sound.field import SoundField
from sonolux.sound.ranges import SoundSum, decode_sum, field_of_sum

#: Settings that parts of one bake share (checked when a part has no fingerprint).
SHARED_SETTINGS = ("rays", "seed", "estimator", "nee_receivers", "max_time_s", "early_bins",
                   "late_bin_s", "azimuth_bands", "elevation_bands", "sample_rate_hz")


@dataclass
class Part:
    """One part: where it came from, the ranges of rays it holds, its exact sum."""

    path: str
    ranges: list[Range]
    sum: SoundSum
    fingerprint: str | None

    @property
    def settings(self) -> dict[str, Any]:
        return self.sum.template.settings


def read_part(path: str | Path) -> Part:
    """A field file with counts (a ray-range bake) or a checkpoint of a sound bake."""
    path = Path(path)
    if not path.exists():
        raise SonoluxError(f"{path}: no such file")
    with path.open("rb") as f:
        is_checkpoint = f.read(len(side.MAGIC)) == side.MAGIC
    if is_checkpoint:
        header, arrays = side.read(path)
        if header.get("kind") != "sound":
            raise SonoluxError(f"{path}: a checkpoint of a {header.get('kind')} bake: only sound "
                               "parts merge")
        ranges = [(int(a), int(b)) for a, b in header["done"]]
        return Part(str(path), ranges, decode_sum(header["meta"], arrays),
                    header.get("fingerprint"))
    field = fieldfile.open_field(path)
    if field.counts is None:
        raise SonoluxError(f"{path}: a whole bake (no counts): it holds every ray already and "
                           "is not a part to merge")
    ranges = [tuple(r) for r in field.settings.get("ray_ranges", [field.settings["ray_range"]])]
    return Part(str(path), ranges, SoundSum.of(field), field.settings.get("fingerprint"))


def check_together(parts: list[Part]) -> None:
    """A SonoluxError naming the first part that is not of the first part's bake."""
    first = parts[0]
    for p in parts[1:]:
        if first.fingerprint and p.fingerprint:
            if p.fingerprint != first.fingerprint:
                raise SonoluxError(f"{p.path} is a part of another bake than {first.path} (their "
                                   "fingerprints differ: scene content, settings or version)")
            continue
        differs = [k for k in SHARED_SETTINGS if p.settings.get(k) != first.settings.get(k)]
        if p.sum.template.quantum != first.sum.template.quantum:
            differs.append("quantum (source powers or receiver radius)")
        if p.sum.counts.shape != first.sum.counts.shape:
            differs.append(f"field shape {p.sum.counts.shape} vs {first.sum.counts.shape}")
        if differs:
            raise SonoluxError(f"{p.path} is a part of another bake than {first.path} (differs in "
                               f"{', '.join(differs)})")


def merge_parts(paths: list[str | Path], *, partial: bool = False) -> tuple[SoundField, dict]:
    """The exact sum of the parts at ``paths``; (field, report: parts, ranges, missing).

    Missing rays are an error that names them, unless ``partial`` (then the result is a part
    itself, with its counts, to be merged later)."""
    if not paths:
        raise SonoluxError("nothing to merge: give the parts (field files or checkpoints)")
    parts = [read_part(p) for p in paths]
    check_together(parts)
    owner = {r: p.path for p in parts for r in p.ranges}
    clash = overlaps(list(owner))
    if clash:
        (a, b) = clash[0]
        raise SonoluxError(f"rays {max(a[0], b[0])}..{min(a[1], b[1])} are in two parts "
                           f"({owner[a]} and {owner[b]}): merging would count them twice")
    rays = int(parts[0].settings["rays"])
    done = [r for p in parts for r in p.ranges]
    gaps = missing((0, rays), done)
    if gaps and not partial:
        text = ", ".join(f"{a}..{b}" for a, b in gaps)
        first = gaps[0]
        raise SonoluxError(
            f"rays {text} of the bake's 0..{rays} are in no part: bake them (sonolux bake SCENE "
            f"--range {first[0]}:{first[1]} -o part.h5, same settings) and merge again, or give "
            "--partial to write what is there as a part")
    total = parts[0].sum
    for p in parts[1:]:
        total = total.add(p.sum)
    field = field_of_sum(total, done, rays, parts[0].fingerprint)
    report = {"parts": len(parts), "ranges": [list(r) for r in join(done)],
              "missing": [list(r) for r in gaps], "rays": rays}
    return field, report
