"""The scene's ``[waves]`` table: whether a sound bake joins the wave solver's low bands to the
rays (docs/waves.md), where they hand over, and how long the automatic crossover may plan to run.

    [waves]
    enabled = true          # bake with waves unless the command line says --no-waves
    crossover_hz = 500      # optional; default: from the Schroeder frequency and the budget
    time_budget_s = 600     # optional; warn when the predicted wave run time is over it

The command line and the API's options win over the table (``--waves``/``--no-waves``,
``--crossover-hz``, ``--wave-time-budget``; :func:`sonolux.sound.waves.with_scene`).
"""

from __future__ import annotations

from dataclasses import dataclass

from sonolux.scene.schema import Table

WAVES_KEYS = ("enabled", "crossover_hz", "time_budget_s")


@dataclass(frozen=True)
class WavesSpec:
    enabled: bool = False
    crossover_hz: float | None = None
    time_budget_s: float | None = None


def read_waves(t: Table | None) -> WavesSpec | None:
    """The ``[waves]`` table, or None when the scene has none."""
    if t is None:
        return None
    t.check_keys(WAVES_KEYS)
    enabled = t.data.get("enabled", False)
    if not isinstance(enabled, bool):
        raise t.ctx.error(t.path("enabled"), enabled, "true or false")
    crossover = t.number("crossover_hz", None, lo=10.0, hi=20_000.0)
    budget = t.number("time_budget_s", None, lo=0.0, hi=1e6, lo_open=True)
    if crossover is not None and not enabled:
        raise t.ctx.error(t.path("crossover_hz"), crossover, "only with enabled = true")
    return WavesSpec(enabled, crossover, budget)


__all__ = ["WAVES_KEYS", "WavesSpec", "read_waves"]
