"""The progress line both bakes print while the core traces: what, how far, how fast, ETA."""

from __future__ import annotations

import sys
import time
from typing import Any


class ProgressLine:
    """Prints `rays done/total, rays/s, ETA` on one line of stderr, at most 5 times a second
    (``unit`` names what is counted: rays, particles). Called by the core as
    ``progress(done, total, elapsed_s)``; returns True (go on)."""

    def __init__(self, label: str, stream: Any = sys.stderr, unit: str = "rays") -> None:
        self.label, self.stream, self.last, self.unit = label, stream, 0.0, unit

    def __call__(self, done: int, total: int, elapsed_s: float) -> bool:
        now = time.monotonic()
        if now - self.last < 0.2 and done < total:
            return True
        self.last = now
        rate = done / elapsed_s if elapsed_s > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else float("nan")
        self.stream.write(f"\r{self.label}: {done:,}/{total:,} {self.unit}, {rate:,.0f} {self.unit}/s, "
                          f"ETA {eta:5.1f} s   ")
        if done >= total:
            self.stream.write("\n")
        self.stream.flush()
        return True
