"""Which wall model a sound bake uses (docs/walls.md): how a surface's absorption depends on
the angle at which sound meets it, in the tracer and in the image sources alike
(``sonolux_core::sound::reflectance``).

- "random-incidence": each band's coefficient at every angle (the default of a plain bake).
- "locally-reacting": the wave solver's wall. Each band gets the real admittance g whose
  random-incidence absorption by Paris' formula is the coefficient, and absorbs
  α(θ) = 4g·cos θ/(cos θ + g)² of the sound arriving at θ from its normal (Kuttruff, *Room
  Acoustics*, §2.3 and §2.5; London, JASA 22, 1950).
- "locally-reacting-modes": the same walls, and rays nearly parallel to a pair of parallel
  planes (a flat floor under a flat ceiling) stand for the pair's grazing mode and lose its
  energy along their path (:mod:`sonolux.sound.grazing`; Morse and Ingard 1968, §9.4). A bake
  with waves uses it unless told otherwise (since session 12): the hybrid has the waves' walls
  on both sides of its crossover, and the rays damp the gap's grazing mode as the waves do
  (docs/waves-grazing.md). The image sources take the locally reacting walls
  alone (why: docs/waves-grazing.md).

What the options say wins, then the scene's ``[settings] wall_model``, then the automatic choice.
"""

from __future__ import annotations

from typing import Any

import numpy as np

RANDOM_INCIDENCE = "random-incidence"
LOCALLY_REACTING = "locally-reacting"
LOCALLY_REACTING_MODES = "locally-reacting-modes"


def core_model(name: str) -> str:
    """The core's wall model of ``name`` (the grazing modes are a table beside it)."""
    return LOCALLY_REACTING if name == LOCALLY_REACTING_MODES else name


#: The relative spread of a mixed plane's grazing rate (:func:`sonolux.sound.grazing.
#: mixed_plane_spread`) above which the bake says so: T30's just noticeable difference, 5 %
#: (ISO 3382-1:2009, table A.1), since a decay that grazing sound sets moves with its rate.
MIXED_PLANE_NOTE = 0.05


def grazing_table(scene: Any, name: str, absorption: Any, level: Any = None,
                  log: Any = None) -> Any:
    """``Acoustics(grazing=...)`` of ``scene`` under wall model ``name``: the grazing modes'
    table with "locally-reacting-modes", else None. With ``level`` (a
    :class:`sonolux.scene.simplify.Level` of level-of-detail band groups) the table of that
    group: its own mesh (small features folded into the surfaces they sit on may leave a gap
    clear that the full mesh blocks), its materials (a seat carries what it took in) and its
    bands; ``absorption`` is then the level's, cut to its bands. Each band's row depends on
    that band alone, so one group over every band on the full mesh is the whole bake's table.
    ``log``: told when a plane of several materials makes the table's rate uncertain by more
    than :data:`MIXED_PLANE_NOTE`."""
    if name != LOCALLY_REACTING_MODES:
        return None
    from sonolux.sound import grazing
    centres_hz = np.asarray(scene.settings.band_set.exact_hz, float)
    mesh = (scene.vertices_m, scene.triangles, scene.material_index) if level is None else \
        (scene.vertices_m, level.triangles, level.material_index)
    if level is not None:
        centres_hz = centres_hz[level.bands]
    args = (*mesh, absorption, centres_hz, scene.settings.speed_of_sound_m_s)
    if log is not None:
        spread = grazing.mixed_plane_spread(*args)
        if spread is not None and spread.max() > MIXED_PLANE_NOTE:
            p, b = np.unravel_index(int(np.argmax(spread)), spread.shape)
            k = 2 * np.pi * float(centres_hz[b]) / scene.settings.speed_of_sound_m_s
            length = grazing.interference_length_m(
                k, grazing.parallel_pairs(*mesh[:2])[p].spacing_m)
            log(f"walls: a pair of parallel planes holds several materials; its grazing mode's "
                f"loss is taken from their area-weighted admittance (right for patches much "
                f"smaller than the mode's interference length, {length:.3g} m at "
                f"{centres_hz[b]:.4g} Hz); patches much larger than that would change it by "
                f"up to {100 * spread[p, b]:.0f} % (docs/waves-grazing.md, \"Several materials "
                f"on a plane\")")
    return grazing.modes_table(*args)


def resolve(scene: Any, options: Any) -> tuple[str, str]:
    """(the wall model, why) for a bake of ``scene`` with ``options`` (a
    :class:`sonolux.sound.options.SoundOptions` whose ``waves`` is resolved)."""
    if options.wall_model is not None:
        return options.wall_model, f"walls {options.wall_model} (the bake's option)"
    given = getattr(scene.settings, "wall_model", None)
    if given is not None:
        return given, f"walls {given} (the scene's [settings] wall_model)"
    if options.waves:
        return LOCALLY_REACTING_MODES, (
            f"walls {LOCALLY_REACTING_MODES}: the wave solver's locally reacting walls, so that "
            "the hybrid has one wall model on both sides of its crossover, with the grazing "
            "modes of the room's parallel surface pairs in the rays (the waves damp them)")
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


__all__ = ["LOCALLY_REACTING", "LOCALLY_REACTING_MODES", "RANDOM_INCIDENCE", "core_model",
           "describe_kept", "grazing_table", "resolve"]
