"""Wave receivers as the tracer's spheres (:mod:`sonolux.sound.waves`): cubature points over each
receiver sphere, the weights of its points in the room's part, and the direct sound's exact mean
over the sphere, added back after the core took each source's free-field direct sound out."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Points per receiver sphere: its centre and six on the axes at R·√0.7, equally weighted, a
#: cubature of the ball exact for polynomials up to degree 3 (the mean of x² over a ball of
#: radius R is R²/5 = 2·(0.7 R²)/7).
BALL_POINTS = 7


def ball_points(geometry: Any, centres_m: np.ndarray, radius_m: float) -> np.ndarray:
    """float64[receiver · 7, 3]: each receiver sphere's cubature points, receiver by receiver.

    The tracer's receivers are spheres: its energy is the mean over the sphere's volume
    (Pope and Chalmers' estimator), which smooths the interference a point would see (at
    500 Hz, λ/3 for the paper's 0.25 m spheres). The waves take the same mean, over these
    points, so that both sides of the crossover measure the same thing. A point outside the
    room (a sphere through a wall) is replaced by the centre."""
    a = radius_m * math.sqrt(0.7)
    offsets = np.vstack([np.zeros(3), a * np.eye(3), -a * np.eye(3)])
    pts = (centres_m[:, None, :] + offsets[None]).reshape(-1, 3)
    inside = np.abs(geometry.winding_numbers(pts)) > 0.5
    pts[~inside] = np.repeat(centres_m, BALL_POINTS, axis=0)[~inside]
    return np.ascontiguousarray(pts)


def point_weights(points_m: np.ndarray, source_m: np.ndarray, centres_m: np.ndarray,
                  near_m: float) -> np.ndarray:
    """float64[receiver, point]: the weights of each sphere's points in the mean of the room's
    part, equal, but 0 for a point nearer the source than ``near_m`` (there the grid's field is
    its own near field of the point source, not the continuous one, and what is left after the
    direct sound is taken out is not the room's part). A sphere all of whose points are that
    near keeps its farthest."""
    r = np.linalg.norm(points_m - source_m, axis=1).reshape(len(centres_m), BALL_POINTS)
    keep = r >= near_m
    far = r >= r.max(axis=1, keepdims=True)
    keep = np.where(keep.any(axis=1, keepdims=True), keep, far)
    return keep / keep.sum(axis=1, keepdims=True)


def ball_mean_inverse_square(radius_m: float, distance_m: np.ndarray,
                             r_m: np.ndarray) -> np.ndarray:
    """The mean over a ball of radius R of 1/(4πr²), r the distance from a point source d from
    the ball's centre, resolved by r: float64[..., len(r_m)] densities per metre of r, so that
    their integral over r is the mean. The sphere about the source of radius r has the area
    A(r) inside the ball: 4πr² while the sphere lies inside (r < R − d), 2πr²(1 − cos θ₀) on
    |R − d| < r < R + d with cos θ₀ = (r² + d² − R²)/(2rd) (its cap inside), 0 elsewhere; the
    density is A(r)/(4πr²·V), V = 4πR³/3. Its integral is closed (checked in the tests):
    [2πR + π(R² − d²)/d·ln|(R + d)/(R − d)|]/(4πV), which is 1/(4πd²) far from the ball and
    3/(4πR²) for a source at its centre. The tracer's sphere receivers measure this mean (each
    ray's path length in the sphere over its volume)."""
    d = np.asarray(distance_m, float)[..., None]
    r = np.asarray(r_m, float)
    volume = 4.0 / 3.0 * math.pi * radius_m ** 3
    with np.errstate(divide="ignore", invalid="ignore"):
        cos0 = (r * r + d * d - radius_m ** 2) / (2.0 * r * d)
        cap = 0.5 * (1.0 - np.clip(cos0, -1.0, 1.0))
    share = np.where(r < radius_m - d, 1.0, np.where(r < radius_m + d, np.nan_to_num(cap), 0.0))
    return share / volume


def add_direct(energy: np.ndarray, centres_m: np.ndarray, radius_m: float, source_m: np.ndarray,
               air_per_m: np.ndarray, c: float, bins: tuple[np.ndarray, np.ndarray],
               directions: tuple[int, int], gains: np.ndarray | None = None) -> None:
    """Adds, in place, each sphere's mean of the source's direct sound (per joule of source
    energy, :func:`ball_mean_inverse_square`, air as exp(−m·r)) to energy float64[receiver,
    direction, band, time]: at the times r/c it arrives, from the source's direction (from every
    direction alike when the source is in the sphere, the mean of a source at the centre).
    ``gains`` float64[receiver, band]: a directional source's energy gain towards each sphere's
    centre (its pattern's mean over the sphere when the source is inside is 1)."""
    start, width = (np.asarray(b, float) for b in bins)
    n_t = min(energy.shape[-1], start.size)
    n_az, n_el = directions
    d = np.linalg.norm(centres_m - source_m, axis=1)
    for k, dk in enumerate(d):
        # Midpoints of 4000 steps over the r the sphere spans (its integral to 10⁻⁶).
        lo, hi = max(dk - radius_m, 0.0), dk + radius_m
        step = (hi - lo) / 4000
        r = lo + step * (np.arange(4000) + 0.5)
        dens = ball_mean_inverse_square(radius_m, np.array(dk), r) * step
        t = r / c
        b = np.clip(np.searchsorted(start, t, side="right") - 1, 0, None)
        ok = b < n_t
        per_bin = np.zeros((air_per_m.size, n_t))
        for band, m in enumerate(air_per_m):
            per_bin[band] = np.bincount(b[ok], dens[ok] * np.exp(-m * r[ok]), n_t)
        if dk < radius_m:
            energy[k, :, :, :n_t] += per_bin[None] / (n_az * n_el)
        else:
            g = 1.0 if gains is None else gains[k][:, None]
            energy[k, direction_bin(source_m - centres_m[k], n_az, n_el), :, :n_t] += per_bin * g
    del width


def direction_bin(from_m: np.ndarray, n_azimuth: int, n_elevation: int) -> int:
    """The tracer's direction bin of sound arriving from ``from_m`` (``sound::Layout``:
    azimuth sectors centred on +x counter-clockwise, elevation bands of equal solid angle)."""
    v = np.asarray(from_m, float) / np.linalg.norm(from_m)
    w = 2.0 * math.pi / n_azimuth
    a = int(math.floor((math.atan2(v[1], v[0]) + 0.5 * w) / w)) % n_azimuth
    e = min(int((min(max(v[2], -1.0), 1.0) + 1.0) * 0.5 * n_elevation), n_elevation - 1)
    return e * n_azimuth + a
