"""An independent image-source model of a shoebox [0, L] × [0, W] × [0, H], in numpy only.

It shares no code with sonolux and is the yardstick for the traced energy histograms of
shoebox rooms with specular walls.

Lattice (Allen & Berkley 1979): along each axis of length a, with the source at s, the images lie
at x = (1 - 2q) s + 2 n a for integers n and q in {0, 1}; such an image reflected |n - q| times
from the low wall (x = 0) and |n| times from the high wall (x = a). Its order is the sum of the
six counts. Per axis there is one image of order 0 and two of each order k >= 1, so the images
form the lattice Z³ with the order as its L1 norm: 4 k² + 2 images of order k >= 1 and
(2 N + 1)(2 N² + 2 N + 3) / 3 of order <= N (the centred octahedral numbers).

Each image's energy at the receiver, per band: W / (4π d²) · Π_walls (1 - α_wall)^count ·
exp(-m d), its delay d / c, and its arrival direction the unit vector from receiver to image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

WALLS = ("floor", "ceiling", "west", "east", "south", "north")
# Wall index pairs (low wall, high wall) along x, y, z.
_AXIS_WALLS = ((WALLS.index("west"), WALLS.index("east")),
               (WALLS.index("south"), WALLS.index("north")),
               (WALLS.index("floor"), WALLS.index("ceiling")))


@dataclass(frozen=True)
class Shoebox:
    """A shoebox room. ``absorption``: float[6, ...] energy absorption per wall in ``WALLS``
    order, with any band axes after the wall axis, or a {wall name: value} mapping.
    ``air_m_per_m``: air energy attenuation m (1/m), broadcast against the bands."""

    size_m: tuple[float, float, float]
    absorption: object = 0.0
    air_m_per_m: object = 0.0
    c_m_s: float = 343.0
    _alpha: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        if isinstance(self.absorption, dict):
            unknown = set(self.absorption) - set(WALLS)
            if unknown:
                raise ValueError(f"unknown walls {sorted(unknown)}; walls are {WALLS}")
            alpha = np.stack([np.asarray(self.absorption.get(w, 0.0), dtype=np.float64)
                              for w in WALLS])
        else:
            alpha = np.asarray(self.absorption, dtype=np.float64)
            if alpha.ndim == 0:
                alpha = np.full(6, float(alpha))
        object.__setattr__(self, "_alpha", alpha)
        self.validate()

    def validate(self):
        if len(self.size_m) != 3 or min(self.size_m) <= 0:
            raise ValueError(f"size_m must be three positive lengths, got {self.size_m}")
        if self._alpha.shape[:1] != (6,):
            raise ValueError(f"absorption needs one entry per wall {WALLS}")
        if np.any((self._alpha < 0) | (self._alpha > 1)):
            raise ValueError("absorption coefficients must lie in [0, 1]")
        if np.any(np.asarray(self.air_m_per_m) < 0) or self.c_m_s <= 0:
            raise ValueError("air_m_per_m must be >= 0 and c_m_s > 0")

    @property
    def alpha(self) -> np.ndarray:
        """float[6, ...]: absorption per wall (``WALLS`` order) and band."""
        return self._alpha


@dataclass(frozen=True)
class ImageSources:
    """Images sorted by distance (ties by order). N images, bands (...) as in the room."""

    position_m: np.ndarray  # float[N, 3]
    distance_m: np.ndarray  # float[N]
    delay_s: np.ndarray  # float[N]
    order: np.ndarray  # int[N]
    reflections: np.ndarray  # int[N, 6]: reflections per wall, WALLS order
    direction: np.ndarray  # float[N, 3]: unit vector from receiver to image
    energy: np.ndarray  # float[N, ...]: W / (4π d²) Π(1 - α)^count exp(-m d)

    def __len__(self):
        return self.distance_m.size


def _axis_images(a, s, r, n_max, max_order, max_distance):
    # n from -n_max to n_max, q in {0, 1}.
    """Images along one axis: coordinates, (low, high) reflection counts; filtered per axis."""
    n = np.repeat(np.arange(-n_max, n_max + 1), 2)
    q = np.tile([0, 1], 2 * n_max + 1)
    x = (1 - 2 * q) * s + 2 * n * a
    low, high = np.abs(n - q), np.abs(n)
    keep = (low + high <= max_order) & (np.abs(x - r) <= max_distance)
    return x[keep], low[keep], high[keep]


def image_sources(room: Shoebox, source_m, receiver_m, *, max_order=None, max_time_s=None,
                  power_w=1.0) -> ImageSources:
    """All images of order <= max_order and delay <= max_time_s (at least one limit needed)."""
    src = np.asarray(source_m, dtype=np.float64)
    rcv = np.asarray(receiver_m, dtype=np.float64)
    size = np.asarray(room.size_m, dtype=np.float64)
    for name, p in (("source_m", src), ("receiver_m", rcv)):
        if p.shape != (3,) or np.any(p <= 0) or np.any(p >= size):
            raise ValueError(f"{name} must lie strictly inside the room, got {p}")
    if np.allclose(src, rcv):
        raise ValueError("source and receiver coincide")
    if max_order is None and max_time_s is None:
        raise ValueError("give max_order, max_time_s or both")
    max_distance = np.inf if max_time_s is None else max_time_s * room.c_m_s
    order_cap = np.inf if max_order is None else int(max_order)
    # Per axis: |n| <= the order, and |x - r| >= 2 |n| a - 2 a bounds |n| by the distance.
    per_axis = []
    for k in range(3):
        limits = [] if max_order is None else [int(max_order)]
        if max_time_s is not None:
            limits.append(math.ceil(max_distance / (2 * size[k])) + 1)
        per_axis.append(_axis_images(size[k], src[k], rcv[k], min(limits), order_cap,
                                     max_distance))
    # Combine the axes (outer product), then filter by total order and distance.
    (x, xl, xh), (y, yl, yh), (z, zl, zh) = per_axis
    ix, iy, iz = (g.ravel() for g in np.meshgrid(np.arange(x.size), np.arange(y.size),
                                                 np.arange(z.size), indexing="ij"))
    pos = np.stack([x[ix], y[iy], z[iz]], axis=1)
    counts = np.zeros((ix.size, 6), dtype=np.int64)
    for (lo, hi), (cl, ch), idx in zip(_AXIS_WALLS, ((xl, xh), (yl, yh), (zl, zh)),
                                       (ix, iy, iz), strict=True):
        counts[:, lo], counts[:, hi] = cl[idx], ch[idx]
    order = counts.sum(axis=1)
    dist = np.linalg.norm(pos - rcv, axis=1)
    keep = np.nonzero((order <= order_cap) & (dist <= max_distance))[0]
    keep = keep[np.lexsort((order[keep], dist[keep]))]  # nearest first, ties by order
    pos, counts, order, dist = pos[keep], counts[keep], order[keep], dist[keep]
    # Energy per band: spreading, wall absorption (one factor per reflection), air.
    alpha = room.alpha
    bands = alpha.shape[1:]

    def column(v):  # (N,) -> (N, 1, ...) against the band axes
        return v.reshape(-1, *([1] * len(bands)))

    energy = np.broadcast_to(column(power_w / (4 * math.pi * dist**2)), (dist.size, *bands))
    for w in range(6):
        energy = energy * (1.0 - alpha[w]) ** column(counts[:, w])
    energy = energy * np.exp(-column(dist) * np.asarray(room.air_m_per_m, dtype=np.float64))
    return ImageSources(position_m=pos, distance_m=dist, delay_s=dist / room.c_m_s,
                        order=order, reflections=counts,
                        direction=(pos - rcv) / dist[:, None], energy=energy)


def energy_histogram(images: ImageSources, bin_edges_s) -> np.ndarray:
    """float[..., T]: the images' energy summed into bins [edge_i, edge_i+1) by delay.

    Band axes first, time last (the analysis convention); images outside the edges are
    dropped.
    """
    edges = np.asarray(bin_edges_s, dtype=np.float64)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("bin_edges_s must be increasing, with at least two edges")
    n_bins = edges.size - 1
    idx = np.searchsorted(edges, images.delay_s, side="right") - 1
    inside = (idx >= 0) & (idx < n_bins)
    energy = images.energy[inside].reshape(int(inside.sum()), -1)
    out = np.stack([np.bincount(idx[inside], weights=energy[:, b], minlength=n_bins)
                    for b in range(energy.shape[1])])
    return out.reshape(*images.energy.shape[1:], n_bins)


def schroeder_db(histogram) -> np.ndarray:
    """float[..., T]: plain backward integral at bin starts in dB re its start (Schroeder 1965).

    No truncation or noise handling: bins after the last non-empty one give -inf.
    """
    h = np.asarray(histogram, dtype=np.float64)
    remaining = np.flip(np.cumsum(np.flip(h, axis=-1), axis=-1), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 10.0 * np.log10(remaining / remaining[..., :1])
