"""The scene layer: what a scene file says, validated and resolved into arrays.

``load_scene`` reads a TOML file, a dict of the same shape, or a built-in name
(``sonolux.scene.builtin.names()``) and returns a :class:`Scene`. The schema is documented in
``docs/scene.md``. Modules: ``schema`` (dataclasses, validation helpers), ``load`` (the
steps), ``shoebox`` and ``meshes`` (geometry), ``material_names`` (name resolution),
``emitters`` (sources, lights), ``receivers``, ``inside`` (in the air, outside, in an
obstacle), ``builtin`` (shipped scenes).
"""

from __future__ import annotations

from sonolux.scene.load import load_scene
from sonolux.scene.schema import (
                                  LIBRARY_BANDS_HZ,
                                  Air,
                                  Light,
                                  Material,
                                  Receivers,
                                  Scene,
                                  Settings,
                                  SoundSource,
)

__all__ = ["LIBRARY_BANDS_HZ", "Air", "Light", "Material", "Receivers", "Scene", "Settings",
           "SoundSource", "load_scene"]
