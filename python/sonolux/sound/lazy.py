"""What a [receiver, direction, band, time] array that is not held dense owes its numpy-like
callers: reductions and conversions computed one receiver at a time.

:class:`sonolux.sound.compact.CompactArray` (a field held compactly) and
:class:`SourceMix` (the weighted sum of several sources' fields, made on demand) both read like
the dense array they stand for: ``a[r]``, ``a[r, d]``, ``a[sel]``, ``shape``, ``dtype``,
``np.asarray(a)``, and from :class:`ReceiverWise` ``sum``, ``max``, ``min``, ``mean`` and
``astype``. Nothing else of numpy's array API is promised: an operation not listed here needs
``np.asarray(a)`` first (which makes the whole array dense; mind its size, ``dense_bytes``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonolux.errors import SonoluxError


class ReceiverWise:
    """Indexing and reductions of a 4-axis array that builds one receiver's block at a time
    (``self.receiver(k)`` -> [direction, band, time]); subclasses give ``shape``, ``dtype`` and
    ``receiver``."""

    shape: tuple[int, int, int, int]
    dtype: np.dtype

    def receiver(self, k: int) -> np.ndarray:  # pragma: no cover - given by subclasses
        raise NotImplementedError

    def __getitem__(self, key: Any) -> np.ndarray:
        """numpy's indexing, receivers built one at a time: an integer first index drops the
        receiver axis; a slice or index array keeps it when more indices follow."""
        rest: tuple[Any, ...] = ()
        if isinstance(key, tuple):
            key, rest = key[0], key[1:]
        n = self.shape[0]
        if isinstance(key, (int, np.integer)):
            k = int(key) + (n if key < 0 else 0)
            if not 0 <= k < n:
                raise IndexError(f"receiver {key} out of range for {n} receivers")
            out = self.receiver(k)
        else:
            idx = np.arange(n)[key]
            out = np.stack([self.receiver(int(k)) for k in idx]) if idx.size else \
                np.zeros((0, *self.shape[1:]), self.dtype)
            rest = (slice(None), *rest) if rest else rest  # the receiver axis is kept
        return out[rest] if rest else out

    def _reduce(self, name: str, axis: Any, dtype: Any, keepdims: bool) -> Any:
        """numpy's ``name`` reduction over ``axis``, one receiver's block at a time; across
        receivers (when axis 0 is reduced) accumulated in receiver order."""
        axes = tuple(range(4)) if axis is None else tuple(
            int(a) for a in (axis if isinstance(axis, tuple) else (axis,)))
        if any(not -4 <= a < 4 for a in axes):
            raise SonoluxError(f"axis {axis!r} is not an axis of a 4-axis field")
        axes = tuple(sorted({a % 4 for a in axes}))
        inner = tuple(a - 1 for a in axes if a > 0)
        op = "sum" if name == "mean" else name
        kw = {} if name in ("max", "min") else {"dtype": dtype}
        n = self.shape[0]
        if n == 0:
            out = getattr(np.zeros(self.shape, self.dtype), name)(axis=axes, keepdims=True, **kw)
        elif 0 in axes:
            out = None
            for k in range(n):
                block = getattr(np.asarray(self[k]), op)(axis=inner, keepdims=True, **kw)
                out = block if out is None else (
                    out + block if op == "sum" else getattr(np, f"{op}imum")(out, block))
            out = out[None]
            if name == "mean":
                out = out / (n * np.prod([self.shape[a] for a in axes if a > 0]))
        else:
            out = np.stack([getattr(np.asarray(self[k]), name)(axis=inner, keepdims=True, **kw)
                            for k in range(n)])
        return out if keepdims else out.squeeze(axis=axes)

    def sum(self, axis: Any = None, dtype: Any = None, keepdims: bool = False) -> Any:
        return self._reduce("sum", axis, dtype, keepdims)

    def mean(self, axis: Any = None, dtype: Any = None, keepdims: bool = False) -> Any:
        return self._reduce("mean", axis, dtype, keepdims)

    def max(self, axis: Any = None, keepdims: bool = False) -> Any:
        return self._reduce("max", axis, None, keepdims)

    def min(self, axis: Any = None, keepdims: bool = False) -> Any:
        return self._reduce("min", axis, None, keepdims)

    def astype(self, dtype: Any) -> np.ndarray:
        """The dense array in ``dtype`` (a copy, as numpy's)."""
        return np.asarray(self[:], dtype)

    @property
    def ndim(self) -> int:
        return 4

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def __len__(self) -> int:
        return self.shape[0]

    @property
    def dense_bytes(self) -> int:
        return self.size * np.dtype(self.dtype).itemsize

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self[:]
        return out if dtype is None else out.astype(dtype)


class SourceMix(ReceiverWise):
    """The weighted sum of sources' fields, each [receiver, direction, band, time], made one
    receiver at a time: Σ_s gain_s × part_s, summed in float64 in the sources' order and rounded
    once to float32 (the same bits every time). ``parts`` are dense arrays or compact ones."""

    def __init__(self, parts: list[Any], gains: list[float]) -> None:
        if not parts or len(parts) != len(gains):
            raise SonoluxError(f"a mix needs one gain per source: {len(parts)} sources, "
                               f"{len(gains)} gains")
        shapes = {tuple(p.shape) for p in parts}
        if len(shapes) != 1:
            raise SonoluxError(f"the sources' fields differ in shape: {sorted(shapes)}")
        self.parts = parts
        self.gains = [float(g) for g in gains]
        self.shape = tuple(parts[0].shape)  # type: ignore[assignment]
        self.dtype = np.dtype(np.float32)

    @property
    def nbytes(self) -> int:
        """Bytes held by the parts (a mix holds nothing of its own)."""
        return int(sum(p.nbytes for p in self.parts))

    def receiver(self, k: int) -> np.ndarray:
        out = np.zeros(self.shape[1:], np.float64)
        for g, p in zip(self.gains, self.parts):
            if g != 0.0:
                out += g * np.asarray(p[k], np.float64)
        return out.astype(np.float32)
