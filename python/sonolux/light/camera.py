"""The camera of a picture: where it stands, where it looks, how wide, how many pixels.

Conventions: metres, z up; ``yaw_deg`` 0 looks along +x and grows counter-clockwise seen from
above (90 looks along +y), the project's azimuth convention; ``pitch_deg`` > 0 looks up.
``fov_deg`` is the vertical field of view; pixels are square. Instead of yaw and pitch a
``look_at_m`` point may be given.

The default camera (:func:`default_camera`) is the view of the paper's figure 7: at head height
(1.5 m above the floor), near the west end wall (x = min + 5 % of the length), in the middle of
the width, looking down the room along +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sonolux.errors import SonoluxError

HEAD_HEIGHT_M = 1.5
#: How far from the west end wall the default camera stands, as a share of the room's length.
DEFAULT_SETBACK = 0.05
MAX_PIXELS = 16384


@dataclass(frozen=True)
class Camera:
    """A pinhole camera. position_m float64[3]; look_at_m float64[3] or None (then yaw_deg and
    pitch_deg); fov_deg vertical field of view in (0, 180); width × height pixels."""

    position_m: tuple[float, float, float]
    look_at_m: tuple[float, float, float] | None = None
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    fov_deg: float = 60.0
    width: int = 960
    height: int = 540

    def validate(self) -> Camera:
        def bad(field: str, value: object, allowed: str) -> SonoluxError:
            return SonoluxError(f"camera {field} = {value!r} is not allowed: {allowed}")

        def finite(v: object, n: int) -> bool:
            return np.shape(v) == (n,) and bool(np.all(np.isfinite(np.asarray(v, float))))

        if not finite(self.position_m, 3):
            raise bad("position_m", self.position_m, "three finite numbers x, y, z in metres")
        if self.look_at_m is not None:
            if not finite(self.look_at_m, 3):
                raise bad("look_at_m", self.look_at_m, "three finite numbers x, y, z in metres")
            if np.linalg.norm(np.subtract(self.look_at_m, self.position_m)) < 1e-9:
                raise bad("look_at_m", self.look_at_m, "a point other than the camera's position "
                          f"{tuple(self.position_m)}")
        if not math.isfinite(self.yaw_deg):
            raise bad("yaw_deg", self.yaw_deg, "a finite angle in degrees")
        if not (-90.0 < self.pitch_deg < 90.0):
            raise bad("pitch_deg", self.pitch_deg, "an angle in (-90, 90) degrees (use look_at "
                      "to look straight up or down)")
        if not (0.0 < self.fov_deg < 180.0):
            raise bad("fov_deg", self.fov_deg, "a vertical field of view in (0, 180) degrees")
        for name in ("width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and 1 <= v <= MAX_PIXELS):
                raise bad(name, v, f"a whole number of pixels from 1 to {MAX_PIXELS}")
        return self

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(forward, right, up) unit vectors float64[3]."""
        if self.look_at_m is not None:
            f = np.subtract(self.look_at_m, self.position_m).astype(float)
            f /= np.linalg.norm(f)
        else:
            y, p = math.radians(self.yaw_deg), math.radians(self.pitch_deg)
            f = np.array([math.cos(p) * math.cos(y), math.cos(p) * math.sin(y), math.sin(p)])
        right = np.cross(f, [0.0, 0.0, 1.0])
        if np.linalg.norm(right) < 1e-9:  # straight up or down: right stays −y, as at yaw 0
            right = np.cross(f, [-1.0, 0.0, 0.0]) * np.sign(f[2])
        right /= np.linalg.norm(right)
        return f, right, np.cross(right, f)

    def rays(self, samples: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(origin float64[3], directions float64[H, W, s², 3]): unit directions through a
        samples × samples grid inside each pixel; row 0 is the top of the image."""
        f, right, up = self.basis()
        tan = math.tan(math.radians(self.fov_deg) / 2)
        sub = (np.arange(samples) + 0.5) / samples
        px = (np.arange(self.width)[:, None] + sub[None]).reshape(-1)  # [W s]
        py = (np.arange(self.height)[:, None] + sub[None]).reshape(-1)  # [H s]
        x = (2 * px / self.width - 1) * tan * self.width / self.height
        y = (1 - 2 * py / self.height) * tan
        d = (f[None, None] + x[None, :, None] * right[None, None] + y[:, None, None] * up[None, None])
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        h, w, s = self.height, self.width, samples
        d = d.reshape(h, s, w, s, 3).transpose(0, 2, 1, 3, 4).reshape(h, w, s * s, 3)
        return np.asarray(self.position_m, float), d


def default_camera(bbox_min: np.ndarray, bbox_max: np.ndarray, **overrides: object) -> Camera:
    """The paper's view: head height, near the west end wall, looking along +x."""
    lo, hi = np.asarray(bbox_min, float), np.asarray(bbox_max, float)
    pos = (lo[0] + DEFAULT_SETBACK * (hi[0] - lo[0]), 0.5 * (lo[1] + hi[1]), lo[2] + HEAD_HEIGHT_M)
    return replace(Camera(position_m=pos), **overrides)  # type: ignore[arg-type]
