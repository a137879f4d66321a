"""Receivers whose decay times stand out from their neighbours' beyond the Monte Carlo error.

A ray tracer's parameters scatter from receiver to receiver by Monte Carlo noise, and
change slowly with position elsewhere (away from the source, a diffuse room's EDT, T20 and
T30 vary by a few per cent). A receiver far off its neighbours is then either a real local
effect (the direct sound, a focus, a shadow, a coupled volume) or a fit gone wrong; either way
a consultant wants to see it before averaging it in.

Method, per parameter and column: each receiver's deviation d from the median of its
neighbours (the 8 grid cells around it on a grid, else its 6 nearest receivers); the Monte
Carlo scatter σ is estimated robustly from all deviations, 1.4826 × median |d| (the normal
distribution's MAD factor; real spatial variation only raises it, so the test errs on the
quiet side). A receiver is listed when |d| > 4σ (one in 16 000 for Gaussian scatter) and
|d| exceeds the just-noticeable difference (5 % for decay times, ISO 3382-1 Table A.1), so
that only differences a listener could hear are reported.
"""

from __future__ import annotations

import numpy as np

_NEAREST = 6  # neighbours of a listed (non-grid) receiver
_MIN_NEIGHBOURS = 3  # a receiver with fewer defined neighbours is not judged
_SIGMAS = 4.0
_JND_RELATIVE = 0.05  # decay times, ISO 3382-1:2009 Table A.1
_MAD_TO_SIGMA = 1.4826
CHECKED = ("edt_s", "t20_s", "t30_s")


def neighbours(positions_m: np.ndarray, grid_spacing_m: float | None) -> list[np.ndarray]:
    """Indices of each receiver's neighbours: the 8 around it on a grid, else the 6 nearest."""
    d = np.linalg.norm(positions_m[:, None, :2] - positions_m[None, :, :2], axis=-1)
    np.fill_diagonal(d, np.inf)
    if grid_spacing_m and np.isfinite(grid_spacing_m):
        return [np.nonzero(row <= grid_spacing_m * (np.sqrt(2) + 1e-6))[0] for row in d]
    k = min(_NEAREST, positions_m.shape[0] - 1)
    return [np.argsort(row)[:k] for row in d]


def outliers(values: dict[str, np.ndarray], xi_permille: dict[str, np.ndarray],
             positions_m: np.ndarray, receivers: np.ndarray, columns: list[str],
             grid_spacing_m: float | None, source_inside: np.ndarray) -> list[dict]:
    """Receivers that stand out (module docstring): a list of JSON-ready dicts with the
    receiver, parameter, column, value, neighbours' median, deviation, the estimated Monte
    Carlo scatter σ and the likely cause. ``values[name]``, ``xi_permille[name]``:
    float[receiver, column]; ``source_inside``: bool[receiver]."""
    if positions_m.shape[0] <= _MIN_NEIGHBOURS:
        return []
    near = neighbours(positions_m, grid_spacing_m)
    found = []
    for name in CHECKED:
        v = values[name]
        for c, column in enumerate(columns):
            med = np.full(v.shape[0], np.nan)
            for r, idx in enumerate(near):
                w = v[idx, c]
                w = w[np.isfinite(w)]
                if w.size >= _MIN_NEIGHBOURS and np.isfinite(v[r, c]):
                    med[r] = np.median(w)
            dev = v[:, c] - med
            ok = np.isfinite(dev)
            if ok.sum() < _MIN_NEIGHBOURS:
                continue
            sigma = _MAD_TO_SIGMA * float(np.median(np.abs(dev[ok])))
            flag = ok & (np.abs(dev) > _SIGMAS * sigma) & (np.abs(dev) > _JND_RELATIVE * np.abs(med))
            for r in np.nonzero(flag)[0]:
                found.append({
                    "receiver": int(receivers[r]), "position_m": positions_m[r].tolist(),
                    "parameter": name, "column": column, "value": float(v[r, c]),
                    "neighbours_median": float(med[r]), "deviation": float(dev[r]),
                    "monte_carlo_sigma": sigma,
                    "cause": _cause(name, dev[r], xi_permille[name][r, c], bool(source_inside[r]))})
    return found


def _cause(name: str, deviation: float, xi_permille: float, source_inside: bool) -> str:
    """The likely cause of a deviation, from what the receiver's own fit shows."""
    if source_inside:
        return "the source is inside this receiver's sphere (its direct sound is seen from within)"
    if np.isfinite(xi_permille) and xi_permille > 5.0:
        return (f"its decay is curved over the range (ξ = {xi_permille:.1f} ‰): a double slope "
                "(a coupled volume, an uneven absorption) or a sparse Monte Carlo tail")
    if name == "edt_s" and deviation < 0:
        return "a strong early arrival (the direct sound or a near reflection) shortens its EDT"
    return ("few rays reach it (Monte Carlo noise: bake more rays) or a real local effect "
            "(a focus, a shadow)")
