"""Head-related impulse responses: a spherical head needing no data, or any SOFA file.

Both give :meth:`hrirs` ``(directions float[n, 3]) -> float[n, 2, taps]`` (ear 0 = left,
1 = right) at the field's sample rate, for unit vectors in the head frame (x ahead, y left,
z up), and a ``delay_samples``: the arrival, in the ear's response, of a sound from straight
ahead (the latency the binaural path adds).

:class:`SphericalHead` is the model of Brown and Duda (*A structural model for binaural sound
synthesis*, IEEE TSAP 1998) without pinna and torso: for each ear, with θ the angle between the
source and the ear's axis (ears at azimuth ±90°), a head-shadow filter

    H(ω, θ) = (1 + j α(θ) ω / 2ω₀) / (1 + j ω / 2ω₀),   ω₀ = c / a,
    α(θ) = (1 + α_min/2) + (1 − α_min/2) cos(π θ / θ_min),   α_min = 0.1, θ_min = 150°

(+6 dB at high frequencies for the facing ear, down to −20 dB in the shadow) and a delay
(Woodworth): −(a/c) cos θ for θ < 90°, (a/c)(θ − π/2) beyond, so the interaural time difference
of a source at the side is (a/c)(1 + π/2) ≈ 0.66 ms for a = 8.75 cm. The filter is the bilinear
transform of H; the fractional delay a Kaiser-windowed sinc (±16 taps). No front/back or
elevation cues beyond the shadow: use a measured HRTF (SOFA) for those.

:class:`SofaHRTF` reads a SOFA file of the SimpleFreeFieldHRIR kind with ``sofar``, resamples
it to the field's rate when needed and, for each direction, uses the measured direction nearest
to it (largest dot product); the left ear is the receiver with the larger y. The file is taken
in SOFA's own listener frame (view +x, up +z, azimuth counter-clockwise), which is ours.
"""

from __future__ import annotations

from math import gcd
from pathlib import Path

import numpy as np
from scipy import signal as ss

from sonolux.errors import SonoluxError

_SINC_HALF = 16


class SphericalHead:
    def __init__(self, sample_rate_hz: int, head_radius_m: float = 0.0875,
                 speed_of_sound_m_s: float = 343.0, taps: int = 128):
        if not 0.03 <= head_radius_m <= 0.2:
            raise SonoluxError(f"head radius {head_radius_m} m is not allowed: 0.03 to 0.2 m")
        self.sample_rate_hz = int(sample_rate_hz)
        self.radius_m = float(head_radius_m)
        self.c = float(speed_of_sound_m_s)
        self.taps = int(taps)
        # The earliest ear (θ = 0) arrives a/c before the head's centre: shift everything by
        # a/c plus the sinc's half-width so the responses are causal.
        self._offset = _SINC_HALF + self.radius_m / self.c * self.sample_rate_hz
        self.delay_samples = int(round(self._offset))
        self._window = np.kaiser(2 * _SINC_HALF + 1, 8.0)
        self.name = f"spherical head (a = {100 * self.radius_m:g} cm)"

    def ear_angles(self, directions: np.ndarray) -> np.ndarray:
        """float[n, ear]: the angle θ between each direction and each ear's axis; an ear's
        HRIR depends on nothing else (:meth:`ear_hrir`), so a cache may key on it."""
        d = np.atleast_2d(np.asarray(directions, float))
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        return np.column_stack([np.arccos(np.clip(d[:, 1] * y, -1.0, 1.0)) for y in (1.0, -1.0)])

    def ear_hrir(self, theta: float) -> np.ndarray:
        """float[taps]: the HRIR of an ear for a source at angle θ (radians) from its axis."""
        return self._ear(float(theta))

    def hrirs(self, directions: np.ndarray) -> np.ndarray:
        theta = self.ear_angles(directions)
        out = np.zeros((theta.shape[0], 2, self.taps))
        for ear in range(2):
            for i, th in enumerate(theta[:, ear]):
                out[i, ear] = self._ear(th)
        return out

    def _ear(self, theta: float) -> np.ndarray:
        a_c = self.radius_m / self.c
        fs = self.sample_rate_hz
        w0 = self.c / self.radius_m
        alpha = 1.05 + 0.95 * np.cos(np.pi * theta / np.radians(150.0))
        # The bilinear transform of H, s -> 2 fs (1 - 1/z) / (1 + 1/z), written out.
        k = fs / w0
        b = np.array([1.0 + alpha * k, 1.0 - alpha * k]) / (1.0 + k)
        a = np.array([1.0, (1.0 - k) / (1.0 + k)])
        delay = (-a_c * np.cos(theta) if theta < np.pi / 2 else a_c * (theta - np.pi / 2)) * fs
        n = np.arange(2 * _SINC_HALF + 1)
        frac = self._offset + delay  # where the impulse lands, in samples
        i0 = int(np.floor(frac)) - _SINC_HALF
        x = n + i0 - frac
        kernel = np.sinc(x) * self._window
        kernel /= kernel.sum()
        impulse = np.zeros(self.taps)
        impulse[i0 + n] = kernel
        return ss.lfilter(b, a, impulse)


class SofaHRTF:
    def __init__(self, path: str | Path, sample_rate_hz: int):
        path = Path(path)
        if not path.exists():
            raise SonoluxError(f"{path}: no such SOFA file")
        try:
            import sofar
        except ImportError:
            raise SonoluxError("reading SOFA files needs the package sofar: pip install sofar") \
                from None
        try:
            sofa = sofar.read_sofa(str(path), verify=False, verbose=False)
            ir = np.asarray(sofa.Data_IR, float)
            pos = np.asarray(sofa.SourcePosition, float)
            kind = str(sofa.SourcePosition_Type).lower()
            rate = float(np.ravel(sofa.Data_SamplingRate)[0])
            ears = np.asarray(sofa.ReceiverPosition, float).reshape(-1, 3)
        except Exception as exc:  # sofar raises many kinds; all mean "not a usable SOFA file"
            raise SonoluxError(f"{path}: not a SOFA file sonolux can read ({exc})") from None
        if ir.ndim != 3 or ir.shape[1] != 2 or pos.shape != (ir.shape[0], 3):
            raise SonoluxError(f"{path}: expected HRIRs Data_IR[measurement, 2 ears, taps] and "
                               f"SourcePosition[measurement, 3], got {ir.shape} and {pos.shape}")
        if ears.shape[0] == 2 and ears[1, 1] > ears[0, 1]:
            ir = ir[:, ::-1]  # make ear 0 the left one (larger y)
        if kind.startswith("spherical"):
            from sonolux.auralize.layouts import unit_vectors

            dirs = unit_vectors(pos[:, 0], pos[:, 1])
        else:
            dirs = pos / np.linalg.norm(pos, axis=1, keepdims=True)
        fs = int(sample_rate_hz)
        if int(round(rate)) != fs:
            g = gcd(int(round(rate)), fs)
            ir = ss.resample_poly(ir, fs // g, int(round(rate)) // g, axis=2)
        self.sample_rate_hz = fs
        self.directions = dirs
        self.data = np.ascontiguousarray(ir)
        self.taps = ir.shape[2]
        self.name = f"SOFA {path.name} ({ir.shape[0]} directions)"
        front = self.data[self.nearest(np.array([[1.0, 0.0, 0.0]]))[0]]
        self.delay_samples = int(np.argmax(np.abs(front).sum(axis=0)))

    def nearest(self, directions: np.ndarray) -> np.ndarray:
        """int[n]: the measurement nearest to each head-frame unit vector."""
        d = np.atleast_2d(np.asarray(directions, float))
        return np.argmax(d @ self.directions.T, axis=1)

    def hrirs(self, directions: np.ndarray) -> np.ndarray:
        return self.data[self.nearest(directions)]


def load_hrtf(path: str | Path | None, sample_rate_hz: int):
    """The SOFA file at ``path``, or the spherical head when ``path`` is None."""
    return SphericalHead(sample_rate_hz) if path is None else SofaHRTF(path, sample_rate_hz)
