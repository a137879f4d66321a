"""Loudspeaker layouts and energy-preserving amplitude panning (VBAP).

Directions are unit vectors in the listener's head frame: +x ahead, +y to the left, +z up;
azimuth 0° ahead, counter-clockwise seen from above (+90° = left, −90° = right), elevation up.
:meth:`Layout.gains` pans each direction onto the loudspeakers with gains g ≥ 0 and Σ g² = 1,
so decorrelated virtual sources keep their energy whatever their direction.

Layouts and their channel orders (the order of the WAV file's channels):

- ``stereo``: L (+30°), R (−30°). Sources behind are mirrored to the front (az → 180° − az),
  sources beyond ±30° go to the nearer speaker alone.
- ``5.1``: L (+30°), R (−30°), C (0°), LFE, Ls (+110°), Rs (−110°): ITU-R BS.775, in the WAV
  and SMPTE order.
- ``7.1``: L (+30°), R (−30°), C (0°), LFE, Lrs (+135°), Rrs (−135°), Lss (+90°), Rss (−90°):
  ITU-R BS.2051 system I (0+7+0), in the WAV (WAVE_FORMAT_EXTENSIBLE) order FL FR FC LFE BL BR
  SL SR. The LFE channel is silent: every main channel is full range, bass management is left
  to the playback system.
- ``cube8``: the paper's eight loudspeakers at the corners of a 2 m cube around the listener
  (azimuth ±45°, ±135°, elevation ±35.26°). Order: the lower four, then the upper four, each
  counter-clockwise from front-left: LFL, LBL, LBR, LFR, UFL, UBL, UBR, UFR. A direction is
  panned on the cube face it points through: VBAP on both triangulations of that square face,
  averaged (so a level source feeds upper and lower corners alike), then scaled to Σ g² = 1.

Horizontal layouts (stereo, 5.1, 7.1) ignore elevation: a direction is panned by its azimuth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sonolux.errors import SonoluxError, close_matches

_EPS = 1e-9


def unit_vectors(azimuth_deg, elevation_deg=0.0) -> np.ndarray:
    """float[n, 3] unit vectors of azimuths and elevations in degrees (broadcast together)."""
    az, el = np.broadcast_arrays(np.radians(azimuth_deg), np.radians(elevation_deg))
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


@dataclass(frozen=True)
class Layout:
    """A loudspeaker layout. ``speakers_deg``: float[channel, 2] (azimuth, elevation) in degrees,
    NaN for an LFE channel (which receives nothing)."""

    name: str
    channel_names: tuple[str, ...]
    speakers_deg: np.ndarray
    horizontal: bool

    @property
    def n_channels(self) -> int:
        return len(self.channel_names)

    def gains(self, directions: np.ndarray) -> np.ndarray:
        """float[channel, n] panning gains of head-frame unit vectors float[n, 3]."""
        d = np.atleast_2d(np.asarray(directions, float))
        out = np.zeros((self.n_channels, d.shape[0]))
        live = np.flatnonzero(~np.isnan(self.speakers_deg[:, 0]))
        if self.name == "cube8":
            out[live] = _cube_gains(d)
        else:
            az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
            out[live] = _ring_gains(az, self.speakers_deg[live, 0], self.name == "stereo")
        return out


def _ring_gains(az_deg: np.ndarray, speakers_az: np.ndarray, fold_back: bool) -> np.ndarray:
    """Pairwise 2D VBAP on a ring (or, for stereo, the frontal arc), Σ g² = 1."""
    az = (np.asarray(az_deg, float) + 180.0) % 360.0 - 180.0
    if fold_back:  # stereo: mirror sources behind the listener to the front
        az = np.where(np.abs(az) > 90.0, np.sign(az) * 180.0 - az, az)
        az = np.clip(az, speakers_az.min(), speakers_az.max())
    order = np.argsort(speakers_az)
    s = speakers_az[order]
    gains = np.zeros((s.size, az.size))
    # Find the pair (i, i+1) on the ring (wrapping for full rings) that encloses each source.
    pairs = [(i, i + 1) for i in range(s.size - 1)]
    if not fold_back:
        pairs.append((s.size - 1, 0))
    p = np.stack([np.cos(np.radians(az)), np.sin(np.radians(az))])
    done = np.zeros(az.size, bool)
    for i, j in pairs:
        base = np.array([[np.cos(np.radians(s[i])), np.cos(np.radians(s[j]))],
                         [np.sin(np.radians(s[i])), np.sin(np.radians(s[j]))]])
        g = np.linalg.solve(base, p)
        inside = ~done & np.all(g >= -_EPS, axis=0)
        gains[i, inside] = g[0, inside]
        gains[j, inside] = g[1, inside]
        done |= inside
    gains = np.clip(gains, 0.0, None)
    gains /= np.sqrt(np.sum(gains**2, axis=0, keepdims=True))
    out = np.empty_like(gains)
    out[order] = gains
    return out


_CORNERS = np.array([[sx, sy, sz] for sz in (-1, 1) for sx, sy in
                     ((1, 1), (-1, 1), (-1, -1), (1, -1))], float) / np.sqrt(3.0)


def _cube_faces() -> list:
    """Per face of the cube (axis, sign): its two triangulations, each a list of (corner
    indices, inverse of the corners' matrix), so that gains are one matrix product."""
    faces = []
    for ax in range(3):
        for sg in (-1.0, 1.0):
            # The face's corners, in order around the square.
            face = np.flatnonzero(np.isclose(_CORNERS[:, ax] * np.sqrt(3.0), sg))
            other = [a for a in range(3) if a != ax]
            ang = np.arctan2(_CORNERS[face, other[1]], _CORNERS[face, other[0]])
            face = face[np.argsort(ang)]
            tris = [[(face[list(t)], np.linalg.inv(_CORNERS[face[list(t)]].T)) for t in tri]
                    for tri in (((0, 1, 2), (0, 2, 3)), ((1, 2, 3), (1, 3, 0)))]
            faces.append((ax, sg, tris))
    return faces


_CUBE_FACES = _cube_faces()


def _cube_gains(d: np.ndarray) -> np.ndarray:
    """VBAP on the cube's faces, both triangulations of each face averaged; float[8, n]."""
    gains = np.zeros((8, d.shape[0]))
    axis = np.argmax(np.abs(d), axis=1)
    sign = np.sign(d[np.arange(d.shape[0]), axis])
    for ax, sg, triangulations in _CUBE_FACES:
        rows = np.flatnonzero((axis == ax) & (sign == sg))
        if rows.size == 0:
            continue
        g = np.zeros((8, rows.size))
        for triangulation in triangulations:
            done = np.zeros(rows.size, bool)  # a point on the diagonal counts once
            for idx, inverse in triangulation:
                w = inverse @ d[rows].T  # p = Σ w_i l_i
                inside = ~done & np.all(w >= -_EPS, axis=0)
                g[np.ix_(idx, np.flatnonzero(inside))] += np.clip(w[:, inside], 0, None)
                done |= inside
        gains[:, rows] = g
    gains = np.clip(gains, 0.0, None)
    return gains / np.sqrt(np.sum(gains**2, axis=0, keepdims=True))


def _layout(name, channels, speakers, horizontal=True) -> Layout:
    return Layout(name, tuple(channels), np.array(speakers, float), horizontal)


NAN = float("nan")
LAYOUTS = {
    "stereo": _layout("stereo", ["L", "R"], [[30, 0], [-30, 0]]),
    "5.1": _layout("5.1", ["L", "R", "C", "LFE", "Ls", "Rs"],
                   [[30, 0], [-30, 0], [0, 0], [NAN, NAN], [110, 0], [-110, 0]]),
    "7.1": _layout("7.1", ["L", "R", "C", "LFE", "Lrs", "Rrs", "Lss", "Rss"],
                   [[30, 0], [-30, 0], [0, 0], [NAN, NAN], [135, 0], [-135, 0], [90, 0],
                    [-90, 0]]),
    "cube8": _layout("cube8", ["LFL", "LBL", "LBR", "LFR", "UFL", "UBL", "UBR", "UFR"],
                     np.column_stack([np.degrees(np.arctan2(_CORNERS[:, 1], _CORNERS[:, 0])),
                                      np.degrees(np.arcsin(_CORNERS[:, 2]))]), False),
}


def loudspeaker_layout(name: str) -> Layout:
    """The layout called ``name`` (stereo, 5.1, 7.1, cube8)."""
    if name not in LAYOUTS:
        near = close_matches(name, LAYOUTS)
        hint = f"; did you mean {near[0]!r}?" if near else ""
        raise SonoluxError(f"layout {name!r} is not a loudspeaker layout: one of "
                           f"{', '.join(LAYOUTS)}{hint}")
    return LAYOUTS[name]
