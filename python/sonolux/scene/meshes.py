"""Mesh rooms and obstacles read from files (OBJ, PLY, STL, glTF/GLB) with trimesh.

Each file is read as a trimesh scene (``force="scene"``), so that every material group stays
its own geometry: an OBJ's ``usemtl`` groups, a glTF's primitives. A group's name is its
material's name (or, without one, the name trimesh gives the geometry). Node transforms are
applied. Then, in this order, ``scale`` (to metres), ``up`` (``"y"`` turns a y-up file into
sonolux's z-up frame; the default is ``"y"`` for glTF/GLB, whose specification is y-up, and
``"z"`` otherwise) and ``translate_m``.

Each group's material is, in this order: ``material_map[group]``; the group's own name when
it names a scene or library material; ``material``; otherwise the scene is rejected.

Triangles should face into the room (the side a listener sees) and, for obstacles, out of the
obstacle, like the shoebox; ``sonolux check`` reports a mesh wound the other way.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from sonolux.errors import close_matches
from sonolux.scene.material_names import MaterialNames
from sonolux.scene.schema import GeometryPart, Material, Table

MESH_KEYS = ("type", "file", "scale", "translate_m", "up", "material", "material_map")
FORMATS = {".obj": "obj", ".ply": "ply", ".stl": "stl", ".gltf": "gltf", ".glb": "glb"}

# An OBJ's usemtl names survive trimesh's reader only if a material library defines them, so
# the OBJ text is handed over with a generated library that defines each name (and nothing
# else: colours come from the scene's materials, not from the OBJ's .mtl).
_GROUPS_MTL = "__sonolux_groups__.mtl"
_USEMTL = re.compile(r"^[ \t]*usemtl[ \t]+(\S+)", flags=re.MULTILINE)
_MTLLIB = re.compile(r"^[ \t]*mtllib\b.*$", flags=re.MULTILINE)

# y-up to z-up: a +90 degree turn about x, (x, y, z) -> (x, -z, y).
_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


class MeshReadError(Exception):
    """A mesh file that trimesh could not read (carried to the caller, who knows the key)."""


def _load_trimesh_scene(path: Path, fmt: str):
    import trimesh  # imported here: slow, and only mesh scenes need it

    if fmt == "obj":
        text = path.read_text(encoding="utf-8", errors="replace")
        names = list(dict.fromkeys(_USEMTL.findall(text)))
        body = _MTLLIB.sub("", text)
        resolver = None
        if names:
            body = f"mtllib {_GROUPS_MTL}\n" + body
            resolver = {_GROUPS_MTL: "".join(f"newmtl {n}\n" for n in names).encode()}
        return trimesh.load(io.BytesIO(body.encode()), file_type="obj", force="scene",
                            process=False, maintain_order=True, resolver=resolver)
    return trimesh.load(str(path), file_type=fmt, force="scene", process=False)


def read_mesh_groups(path: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """[(group name, vertices float64[n, 3], triangles int64[m, 3])], one per material group.

    Node transforms are applied (and a mirroring transform flips the winding back, so that
    the side that faced the listener still does). Groups of the same name are joined.
    """
    import trimesh

    fmt = FORMATS[path.suffix.lower()]
    try:
        scene = _load_trimesh_scene(path, fmt)
    except Exception as exc:  # noqa: BLE001  (trimesh raises many kinds; one message)
        raise MeshReadError(f"{type(exc).__name__}: {exc}") from None
    joined: dict[str, tuple[list[np.ndarray], list[np.ndarray], int]] = {}
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        mesh = scene.geometry.get(geom_name)
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        vertices = trimesh.transformations.transform_points(
            np.asarray(mesh.vertices, dtype=np.float64), transform)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if np.linalg.det(np.asarray(transform)[:3, :3]) < 0:
            faces = faces[:, ::-1]
        material = getattr(getattr(mesh, "visual", None), "material", None)
        name = getattr(material, "name", None) or str(geom_name)
        vs, fs, n = joined.get(name, ([], [], 0))
        vs.append(vertices)
        fs.append(faces + n)
        joined[name] = (vs, fs, n + vertices.shape[0])
    return [(name, np.concatenate(vs), np.concatenate(fs)) for name, (vs, fs, _) in
            joined.items()]


def build_mesh(t: Table, names: MaterialNames) -> GeometryPart:
    """The GeometryPart of one ``type = "mesh"`` entry."""
    ctx = t.ctx
    t.check_keys(MESH_KEYS)
    file = t.string("file")
    path = (ctx.base_dir / file) if not Path(file).is_absolute() else Path(file)
    if path.suffix.lower() not in FORMATS:
        raise ctx.error(t.path("file"), file, "a mesh file ending in " + ", ".join(FORMATS))
    if not path.is_file():
        raise ctx.error(t.path("file"), message=f'no such mesh file "{file}" (looked for '
                                                f"{path.resolve()})")
    scale = t.number("scale", 1.0, lo=0.0, lo_open=True, hi=1e6)
    translate_m = t.vector("translate_m", 3, (0.0, 0.0, 0.0))
    up = t.string("up", "y" if path.suffix.lower() in (".gltf", ".glb") else "z", ("z", "y"))
    fallback_name = t.string("material", None)
    fallback = names.resolve(fallback_name, t.path("material")) if fallback_name else None
    map_table = t.table("material_map")
    mapping: dict[str, str] = {}
    if map_table is not None:
        for k in map_table.data:
            mapping[k] = map_table.string(k)

    try:
        groups = read_mesh_groups(path)
    except MeshReadError as exc:
        raise ctx.error(t.path("file"), message=f'cannot read the mesh "{file}": {exc}') from None
    if not groups:
        raise ctx.error(t.path("file"), message=f'the mesh "{file}" contains no triangles')

    part_v, part_t, part_g, materials, tags, warnings = [], [], [], [], [], []
    offset = 0
    for gi, (gname, vertices, faces) in enumerate(groups):
        if not np.all(np.isfinite(vertices)):
            raise ctx.error(t.path("file"), message=f'the mesh "{file}" has non-finite vertex '
                                                    f'coordinates (group "{gname}")')
        v = vertices * scale
        if up == "y":
            v = v @ _Y_UP_TO_Z_UP.T
        part_v.append(v + translate_m)
        part_t.append(faces + offset)
        part_g.append(np.full(faces.shape[0], gi, dtype=np.int64))
        offset += v.shape[0]
        materials.append(_group_material(t, names, gname, mapping, fallback, file))
        tags.append(gname)
    group_names = [g for g, _, _ in groups]
    for k in mapping:
        if k not in group_names:
            near = close_matches(k, group_names)
            hint = f'; did you mean "{near[0]}"?' if near else ""
            warnings.append(f'{t.path("material_map")}: "{k}" matches no material group of '
                            f'"{file}" (its groups: {", ".join(group_names)}){hint}')
    return GeometryPart(np.concatenate(part_v), np.concatenate(part_t), np.concatenate(part_g),
                        materials, tags, warnings)


def _group_material(t: Table, names: MaterialNames, group: str, mapping: dict[str, str],
                    fallback: Material | None, file: str) -> Material:
    if group in mapping:
        return names.resolve(mapping[group], t.path(f"material_map.{group}"))
    own = names.find(group)
    if own is not None:
        return own
    if fallback is not None:
        return fallback
    raise t.ctx.error(
        t.path("material_map"),
        message=(f'the mesh material "{group}" of "{file}" has no scene material: map it in '
                 f'[geometry.material_map] ("{group}" = "NAME"), or set material = "NAME" for '
                 "the faces left unmapped"),
        matches=close_matches(group, names.names()))
