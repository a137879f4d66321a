"""Built-in scenes: TOML files shipped in ``sonolux/data/scenes/``, loaded by name.

A built-in scene is data, not code: ``paper-small`` is ``data/scenes/paper-small.toml``, read
by the same loader as any user's file. The ``paper-*`` scenes are the three rooms of Pope and
Chalmers, "Multi-sensory rendering: combining graphics and acoustics" (6 x 2.5 x 2 m, twice
and four times that).
"""

from __future__ import annotations

from pathlib import Path

SCENES_DIR = Path(__file__).resolve().parent.parent / "data" / "scenes"


def names() -> list[str]:
    """The names of the built-in scenes, sorted."""
    return sorted(p.stem for p in SCENES_DIR.glob("*.toml"))


def path(name: str) -> Path:
    """The TOML file of built-in scene ``name`` (see :func:`names`)."""
    return SCENES_DIR / f"{name}.toml"
