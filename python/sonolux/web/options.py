"""Settings of the web bundle export (``sonolux export FIELD --web DIR``): one dataclass with
defaults and ``validate()``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from sonolux.errors import SonoluxError

SAMPLE_FORMATS = ("int16", "float32")
#: "compact": sonolux-web/3, the cells' compact fields, synthesised in the browser;
#: "pcm": sonolux-web/2, the synthesised responses themselves.
RESPONSES = ("compact", "pcm")
#: The decay a cell's responses keep by default: ISO 3382-1 takes a reverberation to have died
#: away 60 dB below its start (the T60), and what follows is masked by any ongoing sound.
TAIL_DB = 60.0


@dataclass(frozen=True)
class WebExportOptions:
    """max_length_s: responses are cut (with a 10 ms fade) after this time; None keeps the full
    decay. sample_format: "int16" (half the size; one scale per response, its peak at 32767:
    quantization noise about 100 dB below the peak, far below the end of a 60 dB decay) or
    "float32". seed: of the synthesized fine structure; response (cell r, direction d) uses
    seed + r × directions + d, so directions and cells are uncorrelated and an equal-power
    cross-fade between cells keeps the loudness. tail_db: a cell's responses end (with the same
    10 ms fade) where the energy still to come, summed over its directions, has fallen this far
    below the cell's whole energy (its Schroeder curve, ISO 3382-1); None keeps the field's
    whole time axis. compress: each cell's block is stored deflated (zlib, RFC 1950; the
    browser's DecompressionStream inflates it), lossless. threads: 0 = all cores.
    responses: "compact" (sonolux-web/3: each cell's compact field, the responses synthesised
    by the browser; sample_format does not apply) or "pcm" (sonolux-web/2: the responses);
    a field with a wave part is always written "pcm"."""

    max_length_s: float | None = None
    sample_format: str = "int16"
    seed: int = 0
    tail_db: float | None = TAIL_DB
    compress: bool = True
    threads: int = 0
    responses: str = "compact"

    def validate(self) -> WebExportOptions:
        if self.max_length_s is not None and not (
                isinstance(self.max_length_s, (int, float)) and math.isfinite(self.max_length_s)
                and self.max_length_s > 0):
            raise SonoluxError(f"max_length_s = {self.max_length_s!r} is not allowed: a time > 0 s "
                               "or None for the full decay")
        if self.sample_format not in SAMPLE_FORMATS:
            raise SonoluxError(f"sample_format = {self.sample_format!r} is not one of: "
                               f"{', '.join(SAMPLE_FORMATS)}")
        if self.tail_db is not None and not (
                isinstance(self.tail_db, (int, float)) and not isinstance(self.tail_db, bool)
                and 20.0 <= self.tail_db <= 200.0):
            raise SonoluxError(f"tail_db = {self.tail_db!r} is not allowed: a decay from 20 to "
                               "200 dB, or None for the field's whole time axis")
        if self.responses not in RESPONSES:
            raise SonoluxError(f"responses = {self.responses!r} is not one of: "
                               f"{', '.join(RESPONSES)}")
        if not isinstance(self.compress, bool):
            raise SonoluxError(f"compress = {self.compress!r} is not allowed: True or False")
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise SonoluxError(f"seed = {self.seed!r} is not allowed: a whole number ≥ 0")
        if not (isinstance(self.threads, int) and self.threads >= 0):
            raise SonoluxError(f"threads = {self.threads!r} is not allowed: a whole number ≥ 0 "
                               "(0 = all cores)")
        return self
