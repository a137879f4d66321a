"""Source directivity patterns: per-band energy gains on the engine's (θ, φ) grid.

A pattern is a shape; the power is the source's. The engine normalises every band to a mean
gain of 1 over the sphere (an omnidirectional source's), so a source of ``power_w`` radiates
``power_w`` in every band whatever its pattern, and emits its rays by importance (see
``crates/sonolux-core/src/sound/pattern.rs``).

**Frame.** θ is the angle from the source's ``forward`` vector, φ the angle around it from
``up`` (φ = 0) towards left = up × forward (φ = 90°): x forward, y left, z up, as AES69 (SOFA)
describes a source. The grid has θ nodes every ``THETA_STEP_DEG`` from 0° to 180° and φ nodes
every ``PHI_STEP_DEG`` (one φ node for an axially symmetric pattern); the engine interpolates
bilinearly between nodes.

Built-in patterns (energy gains; the pressure pattern squared):

- ``"omni"`` and ``"cone"`` are the engine's own emitters (not tabulated).
- The first-order family, pressure a + (1 − a) cos θ (Eargle, *The Microphone Book*, 2nd ed.,
  Focal Press 2004, ch. 5): ``"cardioid"`` a = 1/2; ``"supercardioid"`` a = (√3 − 1)/2, the
  largest front-to-back energy ratio; ``"hypercardioid"`` a = 1/4, the largest directivity
  factor (Q = 4); ``"figure-of-eight"`` a = 0. Band-independent.
- ``"dodecahedron"``: the 12-driver measurement source, modelled as 12 rigid circular pistons
  (caps of half-angle ``DODECAHEDRON_CAP_DEG``) on a rigid sphere of radius
  ``DODECAHEDRON_RADIUS_M``, at the face centres of a regular dodecahedron, all in phase. Its
  far field is the sum over caps of the series for a cap on a sphere (Morse & Ingard,
  *Theoretical Acoustics*, McGraw-Hill 1968, §7.2): p(θ) ∝ Σ_n v_n (−i)^(n+1) P_n(cos θ) /
  h_n'(ka), with the cap's velocity coefficients v_0 = (1 − cos α)/2 and v_n =
  (P_{n−1}(cos α) − P_{n+1}(cos α))/2. The energy is averaged over 9 frequencies spaced
  evenly in log frequency across each band. The radius and cap are a typical source's
  (0.2 m, a driver filling most of a face), not a measured product: give a SOFA file of your
  own source when its deviation matters (ISO 3382-1:2009, A.3.2 bounds it per octave).
- ``"talker"``: a human talker as J. L. Flanagan modelled one ("Analog measurements of sound
  radiation from the mouth", J. Acoust. Soc. Am. 32(12), 1613–1620, 1960): "a small piston in
  a sphere of 9-cm radius" (the head), compared there with a mannequin measured at 250 Hz to
  4 kHz. The same series as the dodecahedron with one cap on ``forward`` (the mouth axis, the
  talker's facing direction), in the small-piston limit v_n = (2n + 1)/2 (a point on the
  sphere: we found no mouth-opening area we could cite; a cap of 1 cm radius changes the
  octave gains by ≤ 0.56 dB up to 4 kHz, 2.1 dB at 8 kHz). Axially symmetric about
  ``forward``: no torso, so up/down and left/right are alike, whereas measured talkers'
  main lobe moves from below the mouth towards above it as frequency rises (Leishman,
  Bellows et al., BYU speech directivity database, 2019–2021); and the rigid sphere's bright
  spot straight behind the head (the rear rises again above 135°), which a real head and
  torso blur. Flanagan (1960, abstract) found his measured mannequin within about 3 dB of even
  a simple source inside about π sr around the mouth axis: the model's front is its safest part.

SOFA files are read by :mod:`sonolux.scene.sofa_directivity`; give a measured talker's
file when these limits matter.

"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from sonolux.errors import SonoluxError

THETA_STEP_DEG = 2.5
PHI_STEP_DEG = 5.0
#: The first-order patterns: pressure a + (1 − a) cos θ.
FIRST_ORDER = {"cardioid": 0.5, "supercardioid": (math.sqrt(3.0) - 1.0) / 2.0,
               "hypercardioid": 0.25, "figure-of-eight": 0.0}
DODECAHEDRON_RADIUS_M = 0.2
DODECAHEDRON_CAP_DEG = 30.0
#: Flanagan (1960): "a small piston in a sphere of 9-cm radius" models the talker's head.
TALKER_HEAD_RADIUS_M = 0.09
#: The mouth as a point on the sphere (the small-piston limit; see the module docs).
TALKER_MOUTH_CAP_DEG = 0.0
#: Every name a scene's ``directivity`` may take (besides a ``{ sofa = "file" }`` table).
BUILTIN = ("omni", "cone", *FIRST_ORDER, "dodecahedron", "talker")
SPEED_OF_SOUND_M_S = 343.0


def theta_nodes_rad() -> np.ndarray:
    """θ of the grid's nodes, 0 to π inclusive: float64[n_theta]."""
    return np.radians(np.linspace(0.0, 180.0, int(round(180.0 / THETA_STEP_DEG)) + 1))


def phi_nodes_rad(symmetric: bool = False) -> np.ndarray:
    """φ of the grid's nodes, 0 to 2π exclusive (one node if axially symmetric)."""
    n = 1 if symmetric else int(round(360.0 / PHI_STEP_DEG))
    return np.arange(n) * (2.0 * np.pi / n)


def node_directions(symmetric: bool = False) -> np.ndarray:
    """Unit directions of the grid's nodes in the source frame (x forward, y left, z up):
    float64[theta, phi, 3]."""
    th, ph = np.meshgrid(theta_nodes_rad(), phi_nodes_rad(symmetric), indexing="ij")
    return np.stack([np.cos(th), np.sin(th) * np.sin(ph), np.sin(th) * np.cos(ph)], axis=-1)


def first_order(a: float, n_bands: int) -> np.ndarray:
    """The energy gains (a + (1 − a) cos θ)² on an axially symmetric grid:
    float64[theta, 1, band]."""
    g = (a + (1.0 - a) * np.cos(theta_nodes_rad())) ** 2
    return np.repeat(g[:, None, None], n_bands, axis=2)


def dodecahedron_axes() -> np.ndarray:
    """The 12 face normals of a regular dodecahedron (the icosahedron's vertices): float64[12, 3]."""
    t = (1.0 + math.sqrt(5.0)) / 2.0
    v = []
    for s1 in (-1.0, 1.0):
        for s2 in (-t, t):
            v += [(0.0, s1, s2), (s1, s2, 0.0), (s2, 0.0, s1)]
    a = np.array(v)
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def caps_on_sphere(dirs: np.ndarray, axes: np.ndarray, band_edges_hz: np.ndarray,
                   radius_m: float, cap_deg: float) -> np.ndarray:
    """Far-field energy of in-phase rigid caps of half-angle ``cap_deg`` centred on ``axes``
    float64[cap, 3] on a rigid sphere of ``radius_m``, towards unit ``dirs`` float64[n, 3],
    averaged over 9 log-spaced frequencies per band: float64[n, band] (unnormalised).
    ``cap_deg = 0`` is the point-source limit, v_n → (2n + 1)/2 (times the vanishing area)."""
    cos_to_caps = np.clip(dirs @ axes.T, -1.0, 1.0)  # [direction, cap]
    f_top = float(np.max(band_edges_hz))
    n_max = int(2.0 * np.pi * f_top / SPEED_OF_SOUND_M_S * radius_m) + 25
    orders = np.arange(n_max + 1)
    # Σ over caps of P_n(cos γ): [order, direction], frequency-independent.
    legendre_sum = np.stack([special.eval_legendre(n, cos_to_caps).sum(axis=1) for n in orders])
    if cap_deg == 0.0:
        v = (2.0 * orders + 1.0) / 2.0
    else:
        ca = math.cos(math.radians(cap_deg))
        v = np.empty(n_max + 1)
        v[0] = (1.0 - ca) / 2.0
        v[1:] = (special.eval_legendre(orders[1:] - 1, ca)
                 - special.eval_legendre(orders[1:] + 1, ca)) / 2.0
    out = np.empty((dirs.shape[0], len(band_edges_hz)))
    for b, (lo, hi) in enumerate(band_edges_hz):
        energy = np.zeros(dirs.shape[0])
        for f in np.geomspace(lo, hi, 11)[1:-1]:
            energy += np.abs(sphere_series(f, radius_m, v) @ legendre_sum) ** 2
        out[:, b] = energy
    return out


def sphere_series(f_hz: float, radius_m: float, v: np.ndarray) -> np.ndarray:
    """complex128[order]: the far-field coefficients v_n (−i)^(n+1) / h_n'(ka) of the series
    for caps on a rigid sphere (Morse & Ingard 1968, §7.2; time factor e^{−iωt}, referred to the
    sphere's centre), for velocity coefficients ``v`` float64[order] (see the module docs)."""
    orders = np.arange(v.size)
    ka = 2.0 * np.pi * f_hz / SPEED_OF_SOUND_M_S * radius_m
    dh = special.spherical_jn(orders, ka, True) + 1j * special.spherical_yn(orders, ka, True)
    return v * (-1j) ** (orders + 1) / dh


def talker_phase(cos_to_mouth_axis: np.ndarray, frequencies_hz: np.ndarray,
                 radius_m: float = TALKER_HEAD_RADIUS_M) -> np.ndarray:
    """complex128[direction, frequency]: the unit phasor of the talker model's far-field
    pressure (:func:`talker`'s series, not averaged) towards directions at ``cos_to_mouth_axis``
    from ``forward``, referred to the mouth (the source's position; a point ``radius_m`` in
    front of the head's centre) and to the pressure straight ahead, in the time convention of
    an FFT of a response (e^{−iωt} in the transform: a delay τ is e^{−iωτ}, the conjugate of
    Morse & Ingard's). At low frequency it is e^{ik(a/2)(cos θ − 1)}: the series' first two
    terms are 1 − (3/2)·i·ka·cos θ, the field of a point 1.5a in front of the head's centre,
    a/2 in front of the mouth (docs/waves-sources.md)."""
    c = np.clip(np.asarray(cos_to_mouth_axis, float), -1.0, 1.0)
    f_top = float(np.max(frequencies_hz))
    n_max = int(2.0 * np.pi * f_top / SPEED_OF_SOUND_M_S * radius_m) + 25
    orders = np.arange(n_max + 1)
    legendre = np.stack([special.eval_legendre(n, np.append(c, 1.0)) for n in orders])
    out = np.empty((c.size, len(frequencies_hz)), complex)
    for i, f in enumerate(np.asarray(frequencies_hz, float)):
        k = 2.0 * np.pi * f / SPEED_OF_SOUND_M_S
        p = np.conj(sphere_series(f, radius_m, (2.0 * orders + 1.0) / 2.0) @ legendre)
        p = p * np.exp(-1j * k * radius_m * np.append(c, 1.0))  # referred to the mouth
        p = p[:-1] * np.conj(p[-1])  # and to straight ahead
        out[:, i] = p / np.maximum(np.abs(p), 1e-300)
    return out


def dodecahedron(band_edges_hz: np.ndarray, radius_m: float = DODECAHEDRON_RADIUS_M,
                 cap_deg: float = DODECAHEDRON_CAP_DEG) -> np.ndarray:
    """The 12-piston sphere's energy gains per band (see the module docs):
    float64[theta, phi, band]; ``band_edges_hz`` float64[band, 2]."""
    dirs = node_directions().reshape(-1, 3)
    out = caps_on_sphere(dirs, dodecahedron_axes(), band_edges_hz, radius_m, cap_deg)
    return out.reshape(len(theta_nodes_rad()), -1, len(band_edges_hz))


def talker(band_edges_hz: np.ndarray, radius_m: float = TALKER_HEAD_RADIUS_M,
           cap_deg: float = TALKER_MOUTH_CAP_DEG) -> np.ndarray:
    """Flanagan's (1960) talker: a small piston (the point limit) on a rigid sphere of head
    size, its axis ``forward``; axially symmetric: float64[theta, 1, band]."""
    dirs = node_directions(symmetric=True).reshape(-1, 3)
    out = caps_on_sphere(dirs, np.array([[1.0, 0.0, 0.0]]), band_edges_hz, radius_m, cap_deg)
    return out.reshape(len(theta_nodes_rad()), 1, len(band_edges_hz))


def builtin_gains(name: str, edges_hz: np.ndarray) -> np.ndarray:
    """The tabulated gains of a built-in pattern (not omni or cone) for the bands with edges
    ``edges_hz`` float64[band, 2] (``Settings.band_set.edges_hz``): float64[theta, phi, band]."""
    if name in FIRST_ORDER:
        return first_order(FIRST_ORDER[name], len(edges_hz))
    if name == "dodecahedron":
        return dodecahedron(np.asarray(edges_hz, float))
    if name == "talker":
        return talker(np.asarray(edges_hz, float))
    raise SonoluxError(f"directivity {name!r}: not a tabulated pattern; allowed: "
                       + ", ".join(BUILTIN[2:]))
