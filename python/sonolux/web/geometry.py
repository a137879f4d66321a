"""The scene's triangles for the bundle: ``scene.glb`` and the plan view's walls.

Where the geometry comes from, best first:

1. The field file's light field (``/light``) through the light export of :mod:`sonolux.light`
   (``sonolux export FIELD --gltf``): the lit scene, baked light as vertex colours, unlit
   material. Both are looked up at run time (:func:`light_api`), so the bundle works in builds
   with or without the light half.
2. The light field's copy of the scene when the export is not there: its surfaces in their
   materials' colours and its emitters, unlit (the viewer lights them).
3. The scene itself, reloaded from ``field.scene_origin`` (a built-in name or a file): the
   same, unlit. A scene file changed since the bake shows its new geometry.
4. Nothing left (a scene file that moved): a floor under the receiver grid, with a warning.

Axes: sonolux is z up; glTF is y up. The one mapping, (x, y, z) → (x, z, −y), a rotation (so
triangles keep their winding), is :func:`to_gltf` here and in the light export for the file,
and ``web/src/coords.ts`` for the viewer's use of ``field.json``, which stays in sonolux's axes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sonolux.errors import SonoluxError
from sonolux.sound.field import SoundField

#: glTF (y up) from sonolux (z up): a rotation of −90° about x.
GLTF_FROM_SONOLUX = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def to_gltf(points_m: np.ndarray) -> np.ndarray:
    """float64[..., 3] in sonolux axes → glTF axes."""
    return np.asarray(points_m, float) @ GLTF_FROM_SONOLUX.T


def from_gltf(points: np.ndarray) -> np.ndarray:
    """float64[..., 3] in glTF axes → sonolux axes."""
    return np.asarray(points, float) @ GLTF_FROM_SONOLUX


@dataclass
class Part:
    """Triangles float64[k, 3, 3] (sonolux axes) that share a look."""

    name: str
    triangles_m: np.ndarray
    base_rgb: np.ndarray  # linear, in [0, 1]
    emissive_rgb: np.ndarray | None = None


@dataclass
class SceneGlb:
    """What was written and how, for ``field.json``."""

    source: str  # "light-export", "light-field", "scene", "floor"
    lit: bool
    warnings: list[str] = field(default_factory=list)


def light_api() -> tuple[Callable | None, Callable | None]:
    """(open_light_field, export_gltf) of this build of sonolux, each None when missing."""
    try:
        from sonolux.fieldfile import open_light_field
    except ImportError:
        return None, None
    try:
        from sonolux.light.export import export_gltf
    except ImportError:
        export_gltf = None
    return open_light_field, export_gltf


def has_light_field(field_path: str | Path) -> bool:
    import h5py

    with h5py.File(field_path, "r") as f:
        return "light" in f


def write_scene_glb(sound: SoundField, field_path: str | Path, glb_path: Path) -> SceneGlb:
    """Writes ``glb_path`` from the best source there is (see the module doc)."""
    open_light, export = light_api()
    warnings: list[str] = []
    if open_light is not None and has_light_field(field_path):
        light = open_light(field_path)
        if export is not None:
            export(light, glb_path)
            return SceneGlb("light-export", True)
        _write_parts(_parts_from_light_field(light), glb_path, lit=False)
        return SceneGlb("light-field", False)
    try:
        parts = _parts_from_scene(sound)
        source = "scene"
    except SonoluxError as exc:
        warnings.append(f"the scene could not be reloaded ({exc}); the bundle shows only a floor")
        parts = _floor_parts(sound)
        source = "floor"
    _write_parts(parts, glb_path, lit=False)
    return SceneGlb(source, False, warnings)


def glb_triangles(glb_path: Path) -> np.ndarray:
    """float64[k, 3, 3]: every triangle of a glTF file, in sonolux axes (whatever wrote it)."""
    import trimesh

    scene = trimesh.load(str(glb_path), force="scene")
    mesh = scene.to_geometry() if hasattr(scene, "to_geometry") else scene.dump(concatenate=True)
    if len(mesh.faces) == 0:
        return np.zeros((0, 3, 3))
    return from_gltf(np.asarray(mesh.vertices)[np.asarray(mesh.faces)])


def plan_segments(triangles_m: np.ndarray, z_m: float) -> np.ndarray:
    """float64[k, 4] (x0, y0, x1, y1): where the triangles cross the plane z = z_m."""
    t = np.asarray(triangles_m, float).reshape(-1, 3, 3)
    out = []
    for tri in t:
        dz = tri[:, 2] - z_m
        pts = []
        for i in range(3):
            a, b = tri[i], tri[(i + 1) % 3]
            da, db = dz[i], dz[(i + 1) % 3]
            if (da < 0) != (db < 0):
                s = da / (da - db)
                pts.append(a[:2] + s * (b[:2] - a[:2]))
        if len(pts) == 2 and np.linalg.norm(pts[0] - pts[1]) > 1e-9:
            out.append([*pts[0], *pts[1]])
    return np.array(out, float).reshape(-1, 4)


# --- the sources -------------------------------------------------------------------------------
def _scene_of(sound: SoundField):
    from sonolux.scene import load_scene

    origin = sound.scene_origin
    if origin.startswith("built-in "):
        return load_scene(origin[len("built-in "):])
    if origin and Path(origin).exists():
        return load_scene(origin)
    raise SonoluxError(f"the scene {origin or sound.scene_name!r} is not there any more")


def _parts_from_scene(sound: SoundField) -> list[Part]:
    scene = _scene_of(sound)
    tris = scene.vertices_m[scene.triangles]
    parts = []
    for m, mat in enumerate(scene.materials):
        for tag in dict.fromkeys(scene.surface_tag[scene.material_index == m]):
            sel = (scene.material_index == m) & (scene.surface_tag == tag)
            if np.any(sel):
                parts.append(Part(f"{tag}:{mat.name}", tris[sel], base_rgb=np.asarray(mat.diffuse_rgb)))
    for light in scene.lights:
        rgb = np.asarray(light.color_rgb, float)
        parts.append(Part(f"light:{light.name}", np.asarray(light.triangles_m),
                          base_rgb=np.ones(3), emissive_rgb=rgb / max(rgb.max(), 1e-12)))
    return parts


def _parts_from_light_field(light) -> list[Part]:
    """The light field's surfaces by material, and its emitters."""
    tris = light.vertices_m[light.triangles]
    parts = [Part(f"surface:{name}", tris[light.material_index == m], base_rgb=np.asarray(light.rho[m]))
             for m, name in enumerate(light.material_names) if np.any(light.material_index == m)]
    if len(light.emitter_triangles_m):
        parts.append(Part("light:emitters", light.emitter_triangles_m, base_rgb=np.ones(3),
                          emissive_rgb=np.ones(3)))
    return parts


def _floor_parts(sound: SoundField) -> list[Part]:
    p = sound.positions_m
    half = (sound.grid_spacing_m or 2 * sound.radius_m) / 2
    (x0, y0), (x1, y1) = p[:, :2].min(0) - half, p[:, :2].max(0) + half
    quad = np.array([[[x0, y0, 0], [x1, y0, 0], [x1, y1, 0]], [[x0, y0, 0], [x1, y1, 0], [x0, y1, 0]]])
    return [Part("floor", quad, base_rgb=np.full(3, 0.5))]


# --- the file ------------------------------------------------------------------------------------
def _write_parts(parts: list[Part], glb_path: Path, lit: bool) -> None:
    """One glTF mesh a part, every triangle with its own corners (flat normals)."""
    import trimesh
    from trimesh.exchange.gltf import export_glb
    from trimesh.visual.material import PBRMaterial

    scene = trimesh.Scene()
    scene.metadata["sonolux"] = {"lit": lit, "up": "y", "from_sonolux": "(x, y, z) -> (x, z, -y)"}
    for part in parts:
        tris = np.asarray(part.triangles_m, float).reshape(-1, 3, 3)
        if len(tris) == 0:
            continue
        vertices = to_gltf(tris.reshape(-1, 3))
        faces = np.arange(len(vertices)).reshape(-1, 3)
        emissive = part.emissive_rgb
        visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
            name=part.name, baseColorFactor=[*np.clip(part.base_rgb, 0, 1), 1.0],
            metallicFactor=0.0, roughnessFactor=1.0,
            emissiveFactor=None if emissive is None else list(np.clip(emissive, 0, 1)),
            doubleSided=emissive is not None))
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, visual=visual)
        scene.add_geometry(mesh, node_name=part.name, geom_name=part.name)
    glb_path.write_bytes(export_glb(scene, include_normals=True))

