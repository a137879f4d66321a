"""What a scene says about speech, for the speech transmission index (``[speech]``).

STI (IEC 60268-16:2020, :mod:`sonolux.analysis.sti`) depends on how loud the talker speaks and
on the background noise at the listener, per octave 125 Hz … 8 kHz. Keys:

- ``speech_dba``: the talker's A-weighted speech level at 1 m on axis, 0..130 dB(A); default
  60, the standard's normal vocal effort (J.3; 66 raised, 72 loud, 78 shouted);
- ``noise_db``: the background noise at the listener per octave 125 Hz … 8 kHz, dB SPL: one
  number for every octave or seven; default none, a quiet room where only the absolute
  reception threshold of A.2.3 limits the index.

The bake records them in the field (``settings.speech``); ``sonolux params`` and ``maps`` use
them, and ``params --speech-dba/--noise-db`` override them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sonolux.scene.schema import Table

SPEECH_KEYS = ("speech_dba", "noise_db")
#: IEC 60268-16:2020 J.3: normal vocal effort, dB(A) at 1 m.
NORMAL_SPEECH_DBA = 60.0
#: STI's seven octaves.
STI_OCTAVES_HZ = (125, 250, 500, 1000, 2000, 4000, 8000)


@dataclass(frozen=True)
class SpeechSpec:
    speech_dba: float = NORMAL_SPEECH_DBA
    noise_db: tuple[float, ...] | None = None  # per octave 125 Hz … 8 kHz, dB SPL

    def as_dict(self) -> dict[str, Any]:
        return {"speech_dba": self.speech_dba,
                "noise_db": None if self.noise_db is None else list(self.noise_db)}


def read_speech(t: Table | None) -> SpeechSpec:
    """The ``[speech]`` table, or the defaults when the scene has none."""
    if t is None:
        return SpeechSpec()
    t.check_keys(SPEECH_KEYS)
    level = t.number("speech_dba", NORMAL_SPEECH_DBA, lo=0.0, hi=130.0)
    noise = None
    v = t.data.get("noise_db")
    n = len(STI_OCTAVES_HZ)
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        noise = (t.number("noise_db", lo=-50.0, hi=150.0),) * n
    elif isinstance(v, list):
        noise = tuple(float(x) for x in t.vector("noise_db", n, lo=-50.0, hi=150.0))
    elif v is not None:
        raise t.ctx.error(t.path("noise_db"), v, f"a level in [-50, 150] dB SPL for every octave "
                          f"125 Hz … 8 kHz, or a list of {n} such levels")
    return SpeechSpec(level, noise)


__all__ = ["NORMAL_SPEECH_DBA", "SPEECH_KEYS", "STI_OCTAVES_HZ", "SpeechSpec", "read_speech"]
