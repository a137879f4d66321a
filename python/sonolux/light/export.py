"""Export for viewers: the geometry with the baked light as vertex colours, in binary glTF.

Every triangle is cut into its patches; the patches' corners are shared where the picture
smooths (:mod:`sonolux.light.patches`), the seams where patches of different sizes meet are
closed (no T-junctions, so no hairline cracks: :mod:`sonolux.light.seams`), and each corner's
colour is the smoothed radiance there,
exposed as by an incident-light meter (a white surface under the area-weighted log-average
light is exposed to 0.6; ``exposure_ev`` stops more),
tone-mapped (:mod:`sonolux.light.image`) and left linear: glTF's COLOR_0 is linear and viewers
apply the sRGB curve themselves. The material is unlit (KHR_materials_unlit) so that a viewer
shows the baked light instead of shading the surfaces again. Rectangle lights are a second
mesh, ``lights``, in their own tone-mapped colour.

glTF is y-up: a point (x, y, z) of the scene is written as (x, z, −y); sonolux reads glTF files
back with ``up = "y"``, which undoes it.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from sonolux.light.field import LightField
from sonolux.light.image import INCIDENT_WHITE, LOG_DELTA, _atomic, luminance, tone_map
from sonolux.light.patches import patch_mesh
from sonolux.light.seams import close_seams

UNLIT = "KHR_materials_unlit"


def to_y_up(p: np.ndarray) -> np.ndarray:
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)


def patch_exposure(field: LightField) -> float:
    """An incident-light meter over the whole scene: INCIDENT_WHITE / the area-weighted
    log-average of E / π (see :func:`sonolux.light.render.incident_exposure`)."""
    y = luminance(field.irradiance_w_m2 / np.pi)
    w = field.patch_area_m2 / max(float(field.patch_area_m2.sum()), 1e-300)
    return INCIDENT_WHITE / max(float(np.exp(np.sum(w * np.log(LOG_DELTA + np.maximum(y, 0))))),
                                LOG_DELTA)


def _rgba8(linear01: np.ndarray) -> np.ndarray:
    rgb = np.round(np.clip(linear01, 0, 1) * 255).astype(np.uint8)
    return np.column_stack([rgb, np.full(rgb.shape[0], 255, np.uint8)])


def _add_unlit_material(glb: bytes) -> bytes:
    """The same GLB with one unlit material that every primitive uses."""
    magic, version, _ = struct.unpack_from("<4sII", glb, 0)
    json_len, json_type = struct.unpack_from("<II", glb, 12)
    assert magic == b"glTF" and version == 2 and json_type == 0x4E4F534A
    tree = json.loads(glb[20:20 + json_len])
    rest = glb[20 + json_len:]
    materials = tree.setdefault("materials", [])
    materials.append({"name": "baked light", "extensions": {UNLIT: {}},
                      "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1],
                                               "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    for mesh in tree.get("meshes", []):
        for prim in mesh["primitives"]:
            prim["material"] = len(materials) - 1
    tree["extensionsUsed"] = sorted(set(tree.get("extensionsUsed", [])) | {UNLIT})
    text = json.dumps(tree, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def export_gltf(field: LightField, path: str | Path, *, exposure_ev: float = 0.0,
                curve: str = "aces", smooth: bool = True) -> dict[str, Any]:
    """Writes ``path`` (.glb) and returns what it holds (vertices, triangles, exposure)."""
    import trimesh

    mesh = patch_mesh(field)
    radiance = field.radiance_w_m2_sr
    scale = patch_exposure(field) * 2.0 ** exposure_ev
    if smooth:
        vertices, faces = mesh.node_m, mesh.nodes
        colours = mesh.node_values(radiance, field.patch_area_m2)
    else:
        vertices = mesh.corners_m.reshape(-1, 3)
        faces = np.arange(vertices.shape[0]).reshape(-1, 3)
        colours = np.repeat(radiance, 3, axis=0)
    # Closed seams: the stored (tone-mapped) colours are what a viewer interpolates, so an
    # inserted vertex is interpolated in them (see sonolux.light.seams).
    vertices, faces, shown = close_seams(vertices, faces, tone_map(colours * scale, curve))
    scene = trimesh.Scene()
    surfaces = trimesh.Trimesh(to_y_up(vertices), faces, process=False,
                               vertex_colors=_rgba8(shown))
    scene.add_geometry(surfaces, geom_name="surfaces", node_name="surfaces")
    rect = field.rectangle_emitters
    if np.any(rect):
        tris = field.emitter_triangles_m[rect]
        colour = np.repeat(tone_map(field.emitter_radiance[rect] * scale, curve), 3, axis=0)
        lights = trimesh.Trimesh(to_y_up(tris.reshape(-1, 3)), np.arange(tris.shape[0] * 3).reshape(-1, 3),
                                 process=False, vertex_colors=_rgba8(colour))
        scene.add_geometry(lights, geom_name="lights", node_name="lights")
    scene.metadata["sonolux"] = {"scene": field.scene_name, "exposure_scale": scale,
                                 "tone_map": curve, "up": "y (scene z)",
                                 "colour": "tone-mapped radiance, linear"}
    glb = _add_unlit_material(scene.export(file_type="glb"))
    out = _atomic(path, lambda tmp: Path(tmp).write_bytes(glb))
    return {"path": str(out), "vertices": int(vertices.shape[0]), "triangles": int(faces.shape[0]),
            "exposure_scale": scale, "bytes": len(glb)}
