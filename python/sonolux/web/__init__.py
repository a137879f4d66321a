"""The walk-through viewer's side of sonolux: the web bundle and the local server.

- :mod:`sonolux.web.bundle`: ``export_web(field_path, out_dir)`` writes a bundle that the browser
  viewer (``web/`` in the repository, built into ``sonolux/web_dist``) reads, and nothing else:
  ``scene.glb`` (the scene, y up as glTF requires), ``field.json`` (the index, in sonolux's own
  coordinates: metres, z up) and ``responses.bin`` (per cell, per direction, the pressure
  impulse responses, full and direct sound only).
- :mod:`sonolux.web.responses`: the responses themselves, synthesized and packed.
- :mod:`sonolux.web.geometry`: the scene's triangles for ``scene.glb`` and the plan view.
- :mod:`sonolux.web.serve`: ``sonolux serve``, the bundle in a cache folder and a local server.
"""

from __future__ import annotations

from sonolux.web.bundle import export_web
from sonolux.web.options import WebExportOptions

__all__ = ["WebExportOptions", "export_web"]
