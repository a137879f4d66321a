"""Which wall model a sound bake uses (docs/walls.md): how a surface's absorption depends on
the angle at which sound meets it, in the tracer and in the image sources alike
(``sonolux_core::sound::reflectance``).

- "random-incidence": each band's coefficient at every angle (the default of a plain bake).
- "locally-reacting": the wave solver's wall. Each band gets the real admittance g whose
  random-incidence absorption by Paris' formula is the coefficient, and absorbs
  α(θ) = 4g·cos θ/(cos θ + g)² of the sound arriving at θ from its normal (Kuttruff, *Room
  Acoustics*, §2.3 and §2.5; London, JASA 22, 1950). A bake with waves uses it unless told
  otherwise, so that the hybrid has one wall model on both sides of its crossover.

What the options say wins, then the scene's ``[settings] wall_model``, then the automatic choice.
"""

from __future__ import annotations

from typing import Any

RANDOM_INCIDENCE = "random-incidence"
LOCALLY_REACTING = "locally-reacting"


def resolve(scene: Any, options: Any) -> tuple[str, str]:
    """(the wall model, why) for a bake of ``scene`` with ``options`` (a
    :class:`sonolux.sound.options.SoundOptions` whose ``waves`` is resolved)."""
    if options.wall_model is not None:
        return options.wall_model, f"walls {options.wall_model} (the bake's option)"
    given = getattr(scene.settings, "wall_model", None)
    if given is not None:
        return given, f"walls {given} (the scene's [settings] wall_model)"
    if options.waves:
        return LOCALLY_REACTING, (f"walls {LOCALLY_REACTING}, as the wave solver's: the hybrid "
                                  "has one wall model on both sides of its crossover")
    return RANDOM_INCIDENCE, f"walls {RANDOM_INCIDENCE} (each band's coefficient at every angle)"


def describe_kept(kept: list[tuple[int, int]], material_names: list[str],
                  bands_hz: Any) -> str | None:
    """A note naming the bands that keep their coefficient at every angle under the locally
    reacting model (their coefficient is above the 0.951 a locally reacting wall can absorb at
    random incidence; the wave solver clamps such a band to 0.951), or None."""
    if not kept:
        return None
    parts = [f"{material_names[m]} {float(bands_hz[b]):g} Hz" for m, b in kept]
    return ("walls: above the 0.951 a locally reacting wall can absorb, kept at every angle: "
            + ", ".join(parts))


__all__ = ["LOCALLY_REACTING", "RANDOM_INCIDENCE", "describe_kept", "resolve"]
