"""Receivers no energy reaches: sealed off from every source (behind a closed door or wall, in
a part of the mesh the sources' air does not connect to), decided from the rays' statistics.

A progressive bake waits for a parameter undefined by the rays' noise; a receiver that no ray
can reach would be waited for until the ray cap. After each round, a receiver with not one
deposit is declared *unreached* when, were it in the room's diffuse field, so many hits were
expected that none at all is improbable beyond the bake's stated confidence:

- **Expected hits** (the mean-free-path argument the sphere estimator rests on): in a diffuse
  field, ray paths of total length L fill the room's volume V evenly and isotropically, and the
  number of them that cross a convex body is L / V × its mean projected area (a quarter of its
  surface), π r² for a sphere of radius r (Cauchy's formula; the same track-length argument
  gives the sphere estimator's chord / volume weight). A segment ends on a surface and a
  receiver's sphere is clear of every surface (the scene drops one nearer than its radius), so
  no segment ends inside it. With L = (surface hits) × 4V/S (the mean free path of a diffuse
  field, for any room shape: Kuttruff, *Room Acoustics*, the chapter on the diffuse field;
  checked by the core's tests to 1 %), a receiver would have been crossed
  μ = hits × 4π r² / S times: the sphere's surface against the room's (measured: 0.995 μ,
  averaged over four receivers of a shoebox, tests/sound/test_progressive_reach.py). The
  surface hits are the core's exact count, so the decision is the same on any machine and
  thread count. The rain and nee estimators connect every diffuse reflection to the receivers
  it sees, so a reachable receiver gets more deposits than μ there: the test is conservative
  for them.
- **Poisson**: crossings of independent rays are Poisson, P(no hit) = e^(−μ). With the bake's
  confidence (95 %, the interval it reports) shared among the R receivers (Bonferroni), a
  receiver with no deposit is declared unreached once μ > ln(R / (1 − 0.95)); then, with 95 %
  confidence over the whole bake, its energy density is below ln(R / 0.05) / μ of the diffuse
  field's (``level_below_db``). A receiver that gets any energy, however little, is noise and
  is waited for. The decision is taken again every round from all rays so far: one that later
  gets a deposit is waited for again.

What the test cannot tell: a receiver joined to the sources only through a small opening (a
coupled space) has an energy density far below the room's average (about the opening's area over
its own room's absorption area, Kuttruff's coupled rooms), so it too may get no hit in the first
rounds and be declared unreached, then be waited for again once a ray comes through. The bound
stated (its level at least so far below the room's) holds either way; the messages say both.

Rows of a field per source (rows source by source, docs/fieldfile.md) are each tested against
that source's share of the hits (each source traces the same number of rays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sonolux.errors import SonoluxError

#: The reason a receiver's parameters are left out, in the record and on the round line.
UNREACHED = "no energy reached it"
#: What an unreached receiver may be: the rays cannot tell a sealed space from one joined through
#: an opening so small that no ray has come through yet (a 1 cm² hole in a wall between two
#: reverberant rooms: none of 16,384 rays, some of 131,072; tests/sound/test_progressive_reach.py).
SEALED_OR_COUPLED = ("it is sealed off from the {sources} (a closed door or wall, a separate part "
                     "of the mesh?) or joined to them only through an opening too small for the "
                     "rays so far (a coupled space: more rays, --rays N, tell them apart)")
#: The confidence of the decision: the bake's reported interval (t(0.975, G − 1) × SE).
CONFIDENCE = 0.95


@dataclass(frozen=True)
class Reach:
    """Per row of the field: ``unreached`` bool[row]; ``expected_hits`` float64[row], the
    crossings μ a receiver in the diffuse field would have had by now; ``level_below_db``
    float64[row], 10 log10(ln(R / (1 − confidence)) / μ): with the stated confidence an
    unreached receiver's energy density is at least this far below the diffuse field's."""

    unreached: np.ndarray
    expected_hits: np.ndarray
    level_below_db: np.ndarray
    #: Receivers of the scene: rows beyond them are those of a field per source.
    receivers: int = 0

    def rows(self) -> list[int]:
        return [int(r) for r in np.flatnonzero(self.unreached)]

    def label(self, row: int) -> str:
        """``#k``, and ``from source j`` in a field per source (rows source by source)."""
        n = self.receivers or len(self.unreached)
        return f"#{row % n}" + (f" from source {row // n}" if len(self.unreached) > n else "")


def reach(groups: np.ndarray, surface_hits: int, receivers: int, radius_m: float,
          area_m2: float, confidence: float = CONFIDENCE) -> Reach:
    """The :class:`Reach` of a bake's counts ``groups`` uint64[group, row, band, time] after
    ``surface_hits`` (the core's count, all sources) in a room of surface ``area_m2`` with
    ``receivers`` spheres of ``radius_m`` (rows = receivers × sources in a field per source)."""
    rows = groups.shape[1]
    sources = max(1, rows // max(1, receivers))
    mu = surface_hits / sources * 4.0 * math.pi * radius_m**2 / area_m2
    expected = np.full(rows, mu, dtype=np.float64)
    threshold = math.log(rows / (1.0 - confidence))
    none = ~groups.any(axis=(0, 2, 3))
    with np.errstate(divide="ignore"):
        below = 10.0 * np.log10(threshold / expected)
    return Reach(none & (expected > threshold), expected, below, receivers)


def silent_receivers(field: Any, area_m2: float) -> list[str]:
    """Warnings naming the receivers a bake of a fixed ray count left without energy although
    its rays would have hit them about μ times in the room's diffuse field (:func:`reach` on the
    field summed over its sources: every ray counts). A progressive bake says this itself
    (``settings["progressive"]["unreached"]``): nothing for it here."""
    if field.settings.get("progressive") or not field.n_receivers:
        return []
    energy = field.energy
    try:  # a compact field: its exact direction sums, without the dense view
        reached = np.asarray(energy.direction_sums()).any(axis=(1, 2))
    except (AttributeError, SonoluxError):
        reached = np.array([np.any(energy[r]) for r in range(field.n_receivers)])
    flags = reached.astype(np.uint64).reshape(1, -1, 1, 1)
    found = reach(flags, int(field.stats.get("surface_hits", 0)), field.n_receivers,
                  float(field.radius_m), area_m2)
    out = []
    for r in found.rows():
        where = ", ".join(f"{v:g}" for v in np.asarray(field.positions_m[r], float))
        out.append(f"warning: no energy reached receiver #{r} at ({where}) m, where a receiver "
                   f"in the room's diffuse field would have been hit about "
                   f"{found.expected_hits[r]:,.0f} times (its level is at least "
                   f"{-found.level_below_db[r]:.1f} dB below the room's, 95 %): "
                   + SEALED_OR_COUPLED.format(sources="sources") + "; its field is silent")
    return out
