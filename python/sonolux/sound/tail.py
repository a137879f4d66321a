"""The heavy-tail diagnostic of a progressive bake's late decay: Pareto k̂ of the per-ray late
contributions (docs/progressive.md, "The late decay of rare long-lived rays").

The jackknife over G groups measures the spread of what the groups hold; a mean carried by rare
draws that no group holds yet is outside its reach (Owen, *Monte Carlo theory, methods and
examples*, 2013, §2.8). A ray's energy late in the decay is a product of many reflections'
(1 − α): the late energy at a receiver can be such a mean. Whether it is, the upper tail of the
per-ray contributions says: Pareto smoothed importance sampling's diagnostic (Vehtari, Simpson,
Gelman, Yao and Gabry, *Pareto smoothed importance sampling*, JMLR 25(72), 2024) fits a
generalized Pareto distribution to the largest M = min(S / 5, 3√S) of S draws (§3.1, Appendix
H); its shape k̂ is the number of finite moments' reciprocal: at k̂ ≥ 1/2 the variance is
infinite and the standard error is no longer the error; the mean's estimate is reliable for
k̂ < min(1 − 1/log10 S, 0.7) (§3.2.3–3.2.4: the pre-asymptotic convergence rate, and the
sample size 10^(1/(1 − k̂)) it needs).

The contribution of a ray to an entry (receiver, band) is the energy it deposits there from the
time the whole bake's Schroeder decay (from its onset) falls to −35 dB: the end of T30's range
(ISO 3382-1:2009 §A.2.2), the latest point T30 rests on, where a ray's energy is the product of
the most reflections. The core keeps each entry's largest contributions (sound/tail.rs); this
module picks the time, sizes the list and fits k̂. The fit is Zhang and Stephens' (Technometrics
51, 2009) empirical-Bayes estimate of the generalized Pareto's parameters, with the weakly
informative prior of Vehtari et al. (Appendix C: k̂ shrunk to 1/2 with the weight of 10
exceedances); written here from the papers.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from sonolux.analysis.params import onsets_s

#: The T30 range's end below the onset's level (dB): deposits from there on count.
LATE_DROP_DB = 35.0
#: k̂ at and above which the late mean is unreliable whatever the rays (Vehtari et al. 2024,
#: §3.2.4); below, with S rays, 1 − 1/log10(S) is the other bound (:func:`reliable_below`).
K_LIMIT = 0.7
#: The fewest exceedances a fit is made of (fewer: k̂ unknown).
MIN_EXCEEDANCES = 5
#: The most memory the core's lists may take (a stated rule, not derived): each of the bake's
#: threads keeps up to 2 × kept contributions of 24 bytes an entry; a round that would need more
#: is not watched (its record has no fit).
BUDGET_BYTES = 256 * 2**20
CONTRIBUTION_BYTES = 24


def affordable(entries: int, kept: int, threads: int) -> bool:
    """Whether the core's lists for ``entries`` × ``kept`` fit :data:`BUDGET_BYTES`."""
    threads = threads if threads > 0 else (os.cpu_count() or 1)
    return entries * 2 * kept * CONTRIBUTION_BYTES * threads <= BUDGET_BYTES


def tail_draws(rays: int) -> int:
    """M, the largest draws the fit uses: min(S / 5, 3√S) (Vehtari et al. 2024, §3.1)."""
    return max(1, math.ceil(min(0.2 * rays, 3.0 * math.sqrt(rays))))


def kept_per_entry(rays: int) -> int:
    """How many contributions an entry keeps for S = ``rays``: M and the threshold below them."""
    return tail_draws(rays) + 1


def reliable_below(rays: int) -> float:
    """The k̂ below which a mean of S = ``rays`` draws is reliable: min(1 − 1/log10 S, 0.7)."""
    return min(1.0 - 1.0 / math.log10(rays), K_LIMIT) if rays > 10 else -math.inf


def late_from_s(omni: np.ndarray, bin_start_s: np.ndarray, bin_width_s: np.ndarray,
                onset_s: np.ndarray, drop_db: float = LATE_DROP_DB) -> np.ndarray:
    """float64[receiver, band] (s): the start of the first bin at which the energy still to come
    (float64[receiver, band, time] ``omni``, from the receiver's onset on) is ``drop_db`` below
    all of it; inf where it never is (no energy, or the record ends first)."""
    edges = np.append(bin_start_s, bin_start_s[-1] + bin_width_s[-1])
    after = np.asarray(bin_start_s)[None, None, :] >= np.asarray(onset_s)[:, None, None]
    energy = np.where(after, omni, 0.0)
    remaining = np.cumsum(energy[..., ::-1], axis=-1)[..., ::-1]
    whole = remaining[..., :1]
    with np.errstate(invalid="ignore", divide="ignore"):
        below = (remaining <= whole * 10.0 ** (-drop_db / 10.0)) & (whole > 0) & after
    first = np.argmax(below, axis=-1)
    return np.where(below.any(axis=-1), edges[first], np.inf)


def gpd_fit(exceedances: np.ndarray) -> tuple[float, float]:
    """(k̂, σ̂) of a generalized Pareto distribution fitted to ``exceedances`` (positive, sorted
    ascending): Zhang and Stephens (2009) — the posterior mean of θ = −k/σ over a grid of
    m = 30 + ⌊√n⌋ values from the quantile-based prior, weighted by the profile likelihood —
    then k̂ shrunk to 1/2 with the weight of 10 exceedances (Vehtari et al. 2024, App. C)."""
    x = np.asarray(exceedances, np.float64)
    n = x.size
    m = 30 + int(math.sqrt(n))
    quartile = x[max(int(n / 4 + 0.5) - 1, 0)]
    j = np.arange(1, m + 1)
    theta = 1.0 / x[-1] + (1.0 - np.sqrt(m / (j - 0.5))) / (3.0 * quartile)
    k = np.log1p(-theta[:, None] * x[None, :]).mean(axis=1)  # the shape ξ given θ
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        profile = n * (np.log(-theta / k) - k - 1.0)
        weights = 1.0 / np.exp(profile[None, :] - profile[:, None]).sum(axis=1)
    weights = np.where(np.isfinite(weights), weights, 0.0)
    if weights.sum() <= 0:
        return math.nan, math.nan
    theta_hat = float((theta * weights).sum() / weights.sum())
    k_hat = float(np.log1p(-theta_hat * x).mean())
    sigma = -k_hat / theta_hat
    return (n * k_hat + 10 * 0.5) / (n + 10), sigma


def pareto_k(largest: np.ndarray, rays: int) -> float:
    """k̂ of the S = ``rays`` draws whose largest values are ``largest`` (descending; zeros and
    missing values are draws of 0): the fit to the M largest over the (M + 1)-th
    (:func:`tail_draws`); NaN with fewer than :data:`MIN_EXCEEDANCES` exceedances."""
    m = tail_draws(rays)
    top = np.zeros(m + 1)
    have = np.asarray(largest, np.float64)[:m + 1]
    top[:have.size] = have
    threshold = top[m]
    over = np.sort(top[:m][top[:m] > threshold] - threshold)
    if over.size < MIN_EXCEEDANCES:
        return math.nan
    return gpd_fit(over)[0]


def pareto_ks(largest: np.ndarray, rays: int) -> np.ndarray:
    """:func:`pareto_k` of every entry: ``largest`` float64[receiver, band, kept]."""
    if largest.shape[-1] == 0:  # no ray had late energy anywhere: nothing to fit
        return np.full(largest.shape[:-1], np.nan)
    flat = largest.reshape(-1, largest.shape[-1])
    return np.array([pareto_k(row, rays) for row in flat]).reshape(largest.shape[:-1])


@dataclass
class TailSum:
    """The largest late contributions of one round's rays so far: ``values``
    float64[receiver, band, kept] (descending, zeros past the contributing rays), ``contributing``
    uint64[receiver, band] (rays with any late energy there), ``target`` the round's ray range."""

    target: tuple[int, int]
    values: np.ndarray
    contributing: np.ndarray

    def add(self, other: TailSum) -> TailSum:
        """Both parts' rays: the first ``kept`` of the union (the same values however the round
        is cut: a union's largest are the largest of each part's largest)."""
        if other.target != self.target or other.values.shape[:2] != self.values.shape[:2]:
            raise ValueError("the late tails of different rounds or fields cannot be summed")
        both = np.concatenate([self.values, other.values], axis=-1)
        kept = max(self.values.shape[-1], other.values.shape[-1])
        values = -np.sort(-both, axis=-1)[..., :kept]
        return TailSum(self.target, values, self.contributing + other.contributing)


def of_core(out: dict[str, Any], shape: tuple[int, int], target: tuple[int, int]) -> TailSum:
    """A :class:`TailSum` from ``trace_sound``'s ``tail`` (values float64[entry, kept],
    contributing uint64[entry]), ``shape`` (receivers, bands)."""
    values = np.asarray(out["values"], np.float64)
    return TailSum(target, values.reshape(*shape, values.shape[-1]),
                   np.asarray(out["contributing"], np.uint64).reshape(shape))


def round_settings(omni: np.ndarray | None, bins: tuple[np.ndarray, np.ndarray] | None,
                   start: int, end: int, threads: int = 0) -> tuple[np.ndarray, int] | None:
    """What the core watches in the round of rays ``start..end``: (from_s float64[receiver,
    band], kept per entry), from the rays before it (``omni`` float64[receiver, band, time] on
    the time axis ``bins``); None for the first round (no decay known yet)."""
    if omni is None or bins is None or start == 0:
        return None
    if not affordable(omni.shape[0] * omni.shape[1], kept_per_entry(end - start), threads):
        return None
    edges = np.append(bins[0], bins[0][-1] + bins[1][-1])
    onset = onsets_s(omni.sum(axis=1), edges)
    return late_from_s(omni, bins[0], bins[1], onset), kept_per_entry(end - start)


def round_k(tail: TailSum | None, target: tuple[int, int]) -> np.ndarray | None:
    """k̂ float64[receiver, band] of the round ``target``'s late contributions (NaN: too few to
    fit), None when the round was not watched."""
    if tail is None or tail.target != tuple(target):
        return None
    return pareto_ks(tail.values, target[1] - target[0])


def tail_record(k: np.ndarray, heavy: np.ndarray, rays: int) -> dict[str, Any]:
    """The record's ``errors["t30"]["tail"]``: the rays k̂ was fitted from, the bound, the
    largest k̂ and where, and the entries waited for (``heavy``: [[receiver, band, k̂], ...])."""
    out: dict[str, Any] = {"rays": int(rays), "reliable_below": reliable_below(rays),
                           "heavy": [[int(r), int(b), round(float(k[r, b]), 3)]
                                     for r, b in zip(*np.nonzero(heavy))]}
    fitted = ~np.isnan(k)
    if fitted.any():
        r, b = np.unravel_index(np.argmax(np.where(fitted, k, -np.inf)), k.shape)
        out.update(k_max=round(float(k[r, b]), 3), at_receiver=int(r), at_band=int(b))
    return out


def describe(record: dict[str, Any] | None) -> str:
    """The round's (and ``sonolux info``'s) words for :func:`tail_record`; '' without one."""
    if not record or "k_max" not in record:
        return ""
    bound = f"{record['reliable_below']:.2g}"
    if record["heavy"]:
        return (f"T30's late decay on a heavy tail at {len(record['heavy'])} receiver-bands "
                f"(Pareto k̂ up to {record['k_max']:.2f} ≥ {bound}, receiver #{record['at_receiver']}"
                f" band {record['at_band']}): reported, not waited for")
    return f"late tail Pareto k̂ ≤ {record['k_max']:.2f} (reliable below {bound})"


def watch_record(watch: tuple[np.ndarray, int]) -> dict[str, Any]:
    """A round's watch settings for a checkpoint's header (JSON: None for an unwatched entry)."""
    from_s = np.asarray(watch[0], np.float64)
    return {"from_s": np.where(np.isfinite(from_s), from_s.astype(object), None).tolist(),
            "keep": int(watch[1])}


def watch_of(record: Any) -> tuple[np.ndarray, int] | None:
    """:func:`watch_record`'s settings back (None: the round watched nothing)."""
    if not isinstance(record, dict):
        return None
    from_s = np.array(record["from_s"], np.float64)
    return np.where(np.isnan(from_s), np.inf, from_s), int(record["keep"])


def first_round_settings(scene: Any, rays: int) -> tuple[np.ndarray, int] | None:
    """The first round's watch (no decay measured yet): from the direct sound's arrival at each
    receiver (its nearest source) on, the time the room's diffuse decay (Eyring, the scene's
    theory) takes to fall :data:`LATE_DROP_DB`; None where theory has no finite decay."""
    from sonolux.scene.summary import theory

    t = theory(scene)
    eyring = t.get("eyring_t60_s")
    entries = scene.receivers.count * len(scene.settings.bands_hz)
    if not eyring or not affordable(entries, kept_per_entry(rays), scene.settings.threads):
        return None
    t60 = np.array([np.inf if v is None else v for v in eyring], np.float64)
    receivers = np.asarray(scene.receivers.positions_m, np.float64)
    sources = np.array([s.position_m for s in scene.sources], np.float64)
    direct_s = np.linalg.norm(receivers[:, None] - sources[None], axis=-1).min(axis=1) / float(
        t["speed_of_sound_m_s"])
    return direct_s[:, None] + t60[None, :] * LATE_DROP_DB / 60.0, kept_per_entry(rays)
