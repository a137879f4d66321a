"""Ambisonics in the AmbiX convention: ACN channel order, SN3D normalisation, any order.

Channel k = n² + n + m holds the real spherical harmonic of order n and degree m (−n ≤ m ≤ n):

    Y_n^m(az, el) = N_n^|m| P_n^|m|(sin el) · (cos(m az) if m ≥ 0 else sin(|m| az)),
    N_n^|m| = sqrt((2 − δ_m0) (n − |m|)! / (n + |m|)!)      (SN3D: no 4π, no 2n + 1)

with the associated Legendre functions P without the Condon-Shortley phase. So a plane wave of
amplitude 1 from (az, el) gives W = 1 and, at first order, ACN 1..3 = Y, Z, X = sin az cos el,
sin el, cos az cos el. Directions are in the listener's head frame (x ahead, y left, z up):
any AmbiX decoder or binaural renderer plays the files. First order is 4 channels, third 16.

:func:`decoder` is a basic mode-matching decoder (the pseudo-inverse of the encoding matrix of
a loudspeaker layout), enough to check an encoding; :func:`intensity_direction` reads the
direction of a single plane wave from W, X, Y, Z.
"""

from __future__ import annotations

from math import factorial

import numpy as np
from scipy.special import lpmv

from sonolux.errors import SonoluxError

MAX_ORDER = 7


def n_channels(order: int) -> int:
    return (int(order) + 1) ** 2


def check_order(order) -> int:
    if not (isinstance(order, (int, np.integer)) and 1 <= order <= MAX_ORDER):
        raise SonoluxError(f"ambisonic order {order!r} is not allowed: a whole number from 1 to "
                           f"{MAX_ORDER} (1 = first order, 4 channels; 3 = third order, 16)")
    return int(order)


def channel_names(order: int) -> list[str]:
    """ACN names: W, Y, Z, X for first order, then ACN4 ... (AmbiX)."""
    first = ["W", "Y", "Z", "X"]
    return [first[k] if k < 4 else f"ACN{k}" for k in range(n_channels(order))]


def sn3d_gains(directions: np.ndarray, order: int) -> np.ndarray:
    """float[(order+1)², n] encoding gains of head-frame unit vectors float[n, 3]."""
    order = check_order(order)
    d = np.atleast_2d(np.asarray(directions, float))
    az = np.arctan2(d[:, 1], d[:, 0])
    sin_el = np.clip(d[:, 2] / np.linalg.norm(d, axis=1), -1.0, 1.0)
    out = np.empty((n_channels(order), d.shape[0]))
    for n in range(order + 1):
        for m in range(-n, n + 1):
            a = abs(m)
            norm = np.sqrt((2.0 - (m == 0)) * factorial(n - a) / factorial(n + a))
            legendre = (-1.0) ** a * lpmv(a, n, sin_el)  # undo scipy's Condon-Shortley phase
            trig = np.cos(m * az) if m >= 0 else np.sin(a * az)
            out[n * n + n + m] = norm * legendre * trig
    return out


def decoder(speaker_directions: np.ndarray, order: int) -> np.ndarray:
    """float[speaker, (order+1)²]: mode-matching decoder (pseudo-inverse) for the speakers."""
    return np.linalg.pinv(sn3d_gains(speaker_directions, order))


def fibonacci_sphere(n: int) -> np.ndarray:
    """float[n, 3]: n nearly uniform unit vectors (a golden-angle spiral)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    az = np.pi * (1.0 + 5**0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(az), r * np.sin(az), z])


def intensity_direction(bformat: np.ndarray) -> np.ndarray:
    """Unit vector float[3] of the time-averaged intensity ⟨W·(X, Y, Z)⟩ of an AmbiX signal
    float[channel, samples] (first-order channels used): the direction of a single source."""
    b = np.asarray(bformat, float)
    w, y, z, x = b[0], b[1], b[2], b[3]
    v = np.array([np.dot(w, x), np.dot(w, y), np.dot(w, z)])
    return v / np.linalg.norm(v)
