"""BVH benchmark: build time and closest-hit throughput of sonolux against Intel Embree.

Run with ``make bench`` or ``.venv/bin/python benchmarks/bvh.py``. See benchmarks/README.md.

Every case is traced twice in the same run, by ``sonolux.engine.Geometry.closest_hit`` and by
a peer on the very same rays and mesh: Intel Embree through the PyPI package ``embreex``
(a benchmark-only dependency, installed into the running interpreter's environment when it is
missing), or, when that cannot be had, trimesh's pure-Python ray tracer on a subset of the rays.
Only ratios measured in one run mean anything; the absolute rays/s depend on the machine.
The two engines' answers are compared ray by ray: a throughput ratio between engines that do
not agree would be meaningless.

Cases (all built here, nothing is downloaded):
  icosphere     trimesh icosphere, 7 subdivisions (327,680 triangles), radius 1 m; origins
                uniform in the ball of radius 0.9 m, so every ray hits.
  room+bumps    the paper-large shoebox (24 x 10 x 8 m, 12 triangles) holding a bumpy sphere
                (icosphere, 7 subdivisions, radius 2.5 m, radially displaced by smooth bumps and
                seeded noise): 327,692 triangles whose areas run from ~1e-4 m^2 to 120 m^2
                side by side, as in a real room model. Origins uniform in the room outside
                the obstacle's bounding sphere.
  shoebox       the paper-large shoebox alone (12 triangles); origins uniform in the room.
  l-room        examples/l-room (652 triangles: an L-shaped classroom with tables, chairs and a
                cabinet); origins uniform in the room's air (winding number -1: inside the
                room, in no piece of furniture). The mesh whose sound segments
                benchmarks/mesh_room.py compares with its bounding box: Embree's rate here is
                the bar for the query of that target (issue 15).
  l-room-100k   the same room with tessellated walls and an 81,920-triangle bumpy sculpture
                (106,344 triangles, examples/l-room/make_l_room.py), origins as for l-room and
                off the sculpture's bounding ball.
Directions are uniform on the sphere. Rays are made in float64, rounded to float32 (Embree's
precision) and handed to both engines from those same values.

sonolux is timed on both of its BVH node encodings (docs/bvh.md, "Compressed nodes"): "full"
(f32 planes, 224 bytes a node) and "compressed" (byte planes, 96 bytes), alternated thread
count by thread count. The main columns and the target are the encoding `Geometry` chooses by
itself (marked *); the second table gives both, each against the same peer numbers, and the
run checks that both trees give the same hits, distance and triangle, to the bit.

Timing: time.perf_counter; one warm-up call per configuration, then the median of --repeats
(default 3) calls. Builds: median of --repeats builds. Results go to benchmarks/results/bvh.json.
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import trimesh
from common import load_peer, other_cpu_use, write_json

from sonolux import engine as core

HERE = Path(__file__).resolve().parent
L_ROOM = HERE.parent / "examples" / "l-room"
ROOM_SIZE_M = np.array([24.0, 10.0, 8.0])  # paper-large
T_REL_TOL = 1e-4
TARGET_RATIO = 1.0  # issue 15: closest hit at least Embree's rays/s, 1 and 2 threads, both big meshes
TARGET_CASES = ("icosphere", "room+bumps")
THREAD_COUNTS = (1, 2)
ENCODINGS = ("full", "compressed")  # the BVH's node encodings (engine.BVH_ENCODINGS less "auto")
TRIMESH_SUBSET = 20_000  # fallback peer: at most this many rays per case,
TRIMESH_CHUNK = 50  # traced this many at a time (its memory grows fast with the batch),
TRIMESH_SECONDS = 10.0  # until this much tracing time has been spent


def log(msg: str) -> None:
    print(f"[bvh {time.strftime('%H:%M:%S')}] {msg}", flush=True)


# --------------------------------------------------------------------------- meshes and rays


def shoebox(size_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Box [0, L] x [0, W] x [0, H]: 8 vertices, 12 triangles facing into the room."""
    corners = np.array([[ix, iy, iz] for iz in (0, 1) for iy in (0, 1) for ix in (0, 1)],
                       dtype=np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return corners * size_m, np.array(tris, dtype=np.int64)


def bumpy_sphere(radius: float, centre: np.ndarray, rng: np.random.Generator
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """Icosphere (7 subdivisions) displaced radially; also returns its largest radius."""
    ico = trimesh.creation.icosphere(subdivisions=7, radius=1.0)
    u = np.asarray(ico.vertices, dtype=np.float64)
    bumps = 0.08 * np.sin(6 * u[:, 0]) * np.sin(5 * u[:, 1] + 1) * np.sin(4 * u[:, 2] + 2)
    noise = np.clip(0.01 * rng.standard_normal(len(u)), -0.03, 0.03)
    r = radius * (1.0 + bumps + noise)
    return u * r[:, None] + centre, np.asarray(ico.faces, dtype=np.int64), float(r.max())


def unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    d = rng.standard_normal((n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def as_f32_exact(a: np.ndarray) -> np.ndarray:
    """float64 array holding exactly float32 values (the same rays for both engines)."""
    return np.ascontiguousarray(a.astype(np.float32).astype(np.float64))


def make_cases(n_rays: int, seed: int) -> list[dict]:
    rng = np.random.default_rng(seed)
    cases = []

    ico = trimesh.creation.icosphere(subdivisions=7, radius=1.0)
    o = unit_vectors(rng, n_rays) * (0.9 * rng.random(n_rays) ** (1 / 3))[:, None]
    cases.append({
        "name": "icosphere",
        "what": "trimesh icosphere(subdivisions=7), r = 1 m; origins in the ball r < 0.9 m",
        "vertices": np.asarray(ico.vertices, dtype=np.float64),
        "triangles": np.asarray(ico.faces, dtype=np.int64),
        "origins": o, "directions": unit_vectors(rng, n_rays)})

    rv, rt = shoebox(ROOM_SIZE_M)
    centre = np.array([9.0, 5.0, 4.0])
    bv, bt, r_max = bumpy_sphere(2.5, centre, rng)
    o = np.empty((0, 3))
    while len(o) < n_rays:  # uniform in the room, outside the obstacle's bounding sphere
        p = 0.01 + rng.random((n_rays, 3)) * (ROOM_SIZE_M - 0.02)
        p = p[np.linalg.norm(p - centre, axis=1) > r_max + 0.01]
        o = np.concatenate([o, p])[:n_rays]
    cases.append({
        "name": "room+bumps",
        "what": "24x10x8 m shoebox + bumpy icosphere(7) r = 2.5 m at (9, 5, 4); origins in room",
        "vertices": np.concatenate([rv, bv]),
        "triangles": np.concatenate([rt, bt + len(rv)]),
        "origins": o, "directions": unit_vectors(rng, n_rays)})

    o = 0.01 + rng.random((n_rays, 3)) * (ROOM_SIZE_M - 0.02)
    cases.append({
        "name": "shoebox",
        "what": "paper-large shoebox 24x10x8 m alone; origins in the room",
        "vertices": rv, "triangles": rt, "origins": o, "directions": unit_vectors(rng, n_rays)})

    cases += l_room_cases(n_rays, rng)

    for c in cases:
        c["origins"] = as_f32_exact(c["origins"])
        c["directions"] = as_f32_exact(c["directions"])
        c["vertices"] = as_f32_exact(c["vertices"])  # Embree stores float32 vertices
    return cases


def l_room_cases(n_rays: int, rng: np.random.Generator) -> list[dict]:
    """The L-room and its 100k-triangle variant, written by the example's own generator, with
    origins uniform in the room's air: inside the room and in no furniture (the generalised
    winding number of the whole mesh is -1 there: the room faces inwards, the furniture out)."""
    sys.path.insert(0, str(L_ROOM))
    import make_l_room  # the example's generator (examples/l-room/make_l_room.py)

    def mesh(dense: bool) -> tuple[np.ndarray, np.ndarray]:
        w = make_l_room.build(dense)
        tris = np.concatenate([np.asarray(t, dtype=np.int64) for t in w.groups.values()])
        return np.array(list(w.vertices), dtype=np.float64), tris

    v, t = mesh(False)
    geometry = core.Geometry(v, t.astype(np.uint32), np.zeros(len(t), dtype=np.uint32))
    lo, hi = v.min(axis=0), v.max(axis=0)
    centre, clear_m = np.array(make_l_room.SCULPTURE_CENTRE_M), 1.15 * make_l_room.SCULPTURE_RADIUS_M
    o = np.empty((0, 3))
    while len(o) < n_rays:
        p = lo + rng.random((n_rays, 3)) * (hi - lo)
        p = p[np.linalg.norm(p - centre, axis=1) > clear_m]  # off the dense variant's sculpture
        o = np.concatenate([o, p[np.abs(geometry.winding_numbers(p) + 1.0) < 0.5]])[:n_rays]
    d = unit_vectors(rng, n_rays)
    dv, dt = mesh(True)
    return [
        {"name": "l-room", "what": "examples/l-room (L-shaped classroom, furniture); origins in its air",
         "vertices": v, "triangles": t, "origins": o, "directions": d},
        {"name": "l-room-100k", "what": "its 106k-triangle variant (make_l_room dense); same rays",
         "vertices": dv, "triangles": dt, "origins": o.copy(), "directions": d.copy()},
    ]


# --------------------------------------------------------------------------- timing helpers





def median_time(fn, repeats: int, warmup: bool = True) -> tuple[float, object]:
    """(median seconds of `repeats` calls, result of the last call), after one warm-up."""
    if warmup:
        fn()
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


# --------------------------------------------------------------------------- sonolux


def sonolux_geometry(case: dict, bvh_encoding: str = "auto"):
    return core.Geometry(np.ascontiguousarray(case["vertices"]),
                         np.ascontiguousarray(case["triangles"], dtype=np.uint32),
                         np.zeros(len(case["triangles"]), dtype=np.uint32), bvh_encoding)


# --------------------------------------------------------------------------- peers


def load_embree(allow_install: bool):
    """(module pair, note) for embreex, installing it into this interpreter if allowed."""
    return load_peer("embreex", _import_embree, allow_install, log)


def _import_embree():
    from embreex import mesh_construction, rtcore_scene
    return rtcore_scene, mesh_construction


class EmbreePeer:
    """embreex: scene.run() loops rtcIntersect1 over the rays on the calling thread with the
    GIL released, so N-thread tracing = N Python threads each running a contiguous slice.
    The BVH build (commit) runs on Embree's own TBB pool, which embreex gives no way to size
    (rtcNewDevice(NULL): all cores)."""

    name = "embree"

    def __init__(self, modules):
        self.rtcore_scene, self.mesh_construction = modules
        self.version = _dist_version("embreex")

    def build(self, case: dict):
        scene = self.rtcore_scene.EmbreeScene()
        self.mesh_construction.TriangleMesh(
            scene, case["vertices"].astype(np.float32),
            np.ascontiguousarray(case["triangles"], dtype=np.int32))
        z = np.zeros((1, 3), dtype=np.float32)
        scene.run(z, z + np.float32(1.0), output=1)  # first run commits = builds the BVH
        return scene

    def prepare(self, case: dict, threads: int):
        o32 = case["origins"].astype(np.float32)
        d32 = case["directions"].astype(np.float32)
        return [(np.ascontiguousarray(o), np.ascontiguousarray(d))
                for o, d in zip(np.array_split(o32, threads), np.array_split(d32, threads))]

    def trace(self, scene, chunks, pool: ThreadPoolExecutor | None):
        def one(chunk):
            r = scene.run(chunk[0], chunk[1], output=1)
            return r["tfar"], r["primID"]
        parts = [one(chunks[0])] if pool is None else list(pool.map(one, chunks))
        t = np.concatenate([p[0] for p in parts]).astype(np.float64)
        tri = np.concatenate([p[1] for p in parts]).astype(np.int64)
        miss = tri < 0
        t[miss] = np.inf
        tri[miss] = -1
        return t, tri


class TrimeshPeer:
    """Fallback: trimesh's pure-Python tracer (needs rtree), single-threaded, on a subset of the
    rays (its broad phase tests each ray's bounding box, so it is slow and memory-hungry)."""

    name = "trimesh"

    def __init__(self):
        self.version = trimesh.__version__

    def build(self, case: dict):
        from trimesh.ray.ray_triangle import RayMeshIntersector
        mesh = trimesh.Trimesh(case["vertices"], case["triangles"], process=False)
        rmi = RayMeshIntersector(mesh)
        _ = mesh.triangles_tree  # the rtree broad phase is its acceleration structure
        return rmi

    def trace(self, rmi, o: np.ndarray, d: np.ndarray):
        loc, ray_idx, tri_idx = rmi.intersects_location(o, d, multiple_hits=False)
        t = np.full(len(o), np.inf)
        tri = np.full(len(o), -1, dtype=np.int64)
        t[ray_idx] = np.einsum("ij,ij->i", loc - o[ray_idx], d[ray_idx]) / np.einsum(
            "ij,ij->i", d[ray_idx], d[ray_idx])
        tri[ray_idx] = tri_idx
        return t, tri


def load_trimesh_peer(allow_install: bool):
    try:
        import rtree  # noqa: F401
    except ImportError:
        if not allow_install:
            return None, "rtree (needed by trimesh's tracer) missing and --no-install given"
        log("rtree missing: pip install rtree (benchmark-only dependency)")
        r = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "rtree"],
                           check=False, capture_output=True, text=True)
        if r.returncode != 0:
            return None, f"pip install rtree failed: {r.stderr.strip()[-300:]}"
        importlib.invalidate_caches()
    return TrimeshPeer(), "trimesh.ray.ray_triangle (pure Python, 1 thread, subset of rays)"


def _dist_version(name: str) -> str:
    try:
        from importlib.metadata import version
        return version(name)
    except Exception:  # noqa: BLE001
        return "?"


# --------------------------------------------------------------------------- agreement


def agreement(t_a, tri_a, t_b, tri_b) -> dict:
    miss_a, miss_b = tri_a < 0, tri_b < 0
    both_miss = miss_a & miss_b
    both_hit = ~miss_a & ~miss_b
    same_tri = both_hit & (tri_a == tri_b)
    with np.errstate(invalid="ignore"):
        close_t = both_hit & (np.abs(t_a - t_b) <= T_REL_TOL * np.maximum(np.abs(t_b), 1e-12))
    agree = both_miss | same_tri | close_t
    n = len(t_a)
    dt = np.abs(t_a - t_b)[same_tri]  # distance error where both name the same triangle
    rel = dt / np.maximum(np.abs(t_b[same_tri]), 1e-12)
    bad = np.nonzero(~agree)[0]
    examples = [{"ray": int(i), "t_sonolux": float(t_a[i]), "tri_sonolux": int(tri_a[i]),
                 "t_peer": float(t_b[i]), "tri_peer": int(tri_b[i])} for i in bad[:5]]
    return {"n": n,
            "same_triangle": float((same_tri | both_miss).sum() / n),
            "same_t": float((close_t | both_miss).sum() / n),
            "agree": float(agree.sum() / n),
            "n_disagree": len(bad),
            "max_abs_dt_same_tri": float(dt.max(initial=0.0)),
            "max_rel_dt_same_tri": float(rel.max(initial=0.0)),
            "miss_sonolux": int(miss_a.sum()),
            "miss_peer": int(miss_b.sum()),
            "examples": examples}


# --------------------------------------------------------------------------- main


def run_case(case: dict, peer, repeats: int) -> dict:
    n_tris, n_rays = len(case["triangles"]), len(case["origins"])
    log(f"case {case['name']}: {n_tris:,} triangles, {n_rays:,} rays")
    res = {"name": case["name"], "what": case["what"], "n_triangles": n_tris, "n_rays": n_rays}

    # sonolux build: the extension's own build_time_s (BVH only), median over builds
    builds, walls, g = [], [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        g = sonolux_geometry(case)
        walls.append(time.perf_counter() - t0)
        builds.append(g.build_time_s)
    res["sonolux_build_s"] = float(np.median(builds))
    res["sonolux_construct_wall_s"] = float(np.median(walls))
    res["bvh_nodes"] = int(g.bvh_nodes)
    log(f"  sonolux build {res['sonolux_build_s'] * 1e3:.1f} ms "
        f"(constructor wall {res['sonolux_construct_wall_s'] * 1e3:.1f} ms), "
        f"{g.bvh_nodes:,} BVH nodes")

    o, d = case["origins"], case["directions"]
    chosen = "compressed" if g.bvh_compressed else "full"
    res["bvh_encoding"] = chosen
    trees = {enc: g if enc == chosen else sonolux_geometry(case, enc) for enc in ENCODINGS}
    rates: dict[str, dict[str, float]] = {enc: {} for enc in ENCODINGS}
    hits = {}
    for th in THREAD_COUNTS:
        for enc, tree in trees.items():  # the two encodings alternated in the same minutes
            dt, hits[enc] = median_time(lambda th=th, t=tree: t.closest_hit(o, d, threads=th), repeats)
            rates[enc][str(th)] = n_rays / dt
            log(f"  sonolux closest_hit, {enc} nodes{' *' if enc == chosen else ''}, {th} thread(s): "
                f"{n_rays / dt / 1e6:.3f} Mrays/s")
    res["sonolux_rays_per_s"] = rates[chosen]
    res["sonolux_rays_per_s_by_encoding"] = rates
    (t_f, tri_f), (t_c, tri_c) = hits["full"], hits["compressed"]
    res["encodings_same_hits"] = bool(np.array_equal(t_f, t_c) and np.array_equal(tri_f, tri_c))
    log(f"  full and compressed nodes give the same hits: {res['encodings_same_hits']}")
    t_s, tri_s = hits[chosen]
    res["sonolux_hit_fraction"] = float((tri_s >= 0).mean())

    if peer is None:
        return res
    res["peer"] = peer.name
    if isinstance(peer, EmbreePeer):
        dt, scene = median_time(lambda: peer.build(case), repeats, warmup=False)
        res["peer_build_s"] = dt
        log(f"  embree build (commit, TBB all cores) {dt * 1e3:.1f} ms")
        res["peer_rays_per_s"] = {}
        for th in THREAD_COUNTS:
            chunks = peer.prepare(case, th)
            with ThreadPoolExecutor(th) as pool:
                use = pool if th > 1 else None
                dt, (t_p, tri_p) = median_time(
                    lambda c=chunks, u=use: peer.trace(scene, c, u), repeats)
            res["peer_rays_per_s"][str(th)] = n_rays / dt
            log(f"  embree rtcIntersect1, {th} thread(s): {n_rays / dt / 1e6:.3f} Mrays/s")
        res["agreement"] = agreement(t_s, tri_s, t_p, tri_p)
    else:  # trimesh fallback: ~30-100 rays/s on 300k triangles, so a time-boxed subset
        t0 = time.perf_counter()
        rmi = peer.build(case)
        res["peer_build_s"] = time.perf_counter() - t0
        parts, k, dt = [], 0, 0.0
        while k < min(TRIMESH_SUBSET, n_rays) and dt < TRIMESH_SECONDS:
            t0 = time.perf_counter()
            parts.append(peer.trace(rmi, o[k:k + TRIMESH_CHUNK], d[k:k + TRIMESH_CHUNK]))
            dt += time.perf_counter() - t0
            k = min(k + TRIMESH_CHUNK, n_rays)
        t_p = np.concatenate([q[0] for q in parts])
        tri_p = np.concatenate([q[1] for q in parts])
        res["peer_rays_per_s"] = {"1": k / dt}
        res["peer_subset_rays"] = k
        log(f"  trimesh, 1 thread, {k:,} rays: {k / dt / 1e6:.4f} Mrays/s")
        res["agreement"] = agreement(t_s[:k], tri_s[:k], t_p, tri_p)
    a = res["agreement"]
    log(f"  agreement: {a['agree'] * 100:.4f}% of rays (same triangle "
        f"{a['same_triangle'] * 100:.4f}%, |dt| <= {T_REL_TOL:g} t {a['same_t'] * 100:.4f}%); "
        f"same triangle: max |dt| {a['max_abs_dt_same_tri']:.2g}, "
        f"max |dt|/t {a['max_rel_dt_same_tri']:.2g}")
    res["ratio_rays_per_s"] = {th: res["sonolux_rays_per_s"][th] / v
                               for th, v in res["peer_rays_per_s"].items()}
    res["ratio_build"] = res["sonolux_build_s"] / res["peer_build_s"]
    return res


def print_table(results: list[dict], peer_name: str | None) -> None:
    p = peer_name or "peer"
    hdr = (f"{'case':<11} {'tris':>8} {'build ms':>9} {p + ' ms':>10} {'ratio':>6} | "
           + " | ".join(f"{th}T Mray/s sonolux {p:>8}  ratio" for th in THREAD_COUNTS)
           + " | agree %")
    print()
    print(hdr)
    print("-" * len(hdr))
    for r in results:
        pb = r.get("peer_build_s")
        line = (f"{r['name']:<11} {r['n_triangles']:>8,} {r['sonolux_build_s'] * 1e3:>9.2f} "
                + (f"{pb * 1e3:>10.2f} {r['ratio_build']:>6.2f}" if pb is not None
                   else f"{'-':>10} {'-':>6}") + " | ")
        cols = []
        for th in map(str, THREAD_COUNTS):
            s = r["sonolux_rays_per_s"][th] / 1e6
            pv = r.get("peer_rays_per_s", {}).get(th)
            cols.append(f"{'':>10}{s:>9.3f} " + (f"{pv / 1e6:>8.3g} {s * 1e6 / pv:>6.3g}"
                                                if pv else f"{'-':>8} {'-':>6}"))
        line += " | ".join(cols)
        a = r.get("agreement")
        line += f" | {a['agree'] * 100:.4f}" if a else " | -"
        print(line)
    print()
    print("ratio = sonolux / " + p + " (rays/s: > 1 means sonolux is faster; build: < 1 means "
          "sonolux builds faster). Build columns: BVH build only, median of the builds.")
    if peer_name == "embree":
        print(f"target (issue 15): closest hit >= {TARGET_RATIO:g}x Embree's rays/s on "
              + " and ".join(f"{th}" for th in THREAD_COUNTS) + " threads, "
              + " and ".join(TARGET_CASES) + ":")
        for r in results:
            if r["name"] in TARGET_CASES and r.get("ratio_rays_per_s"):
                ratios = r["ratio_rays_per_s"]
                verdict = "met" if min(ratios.values()) >= TARGET_RATIO else "NOT met"
                print(f"  {r['name']:<11} " + ", ".join(f"{th}T {v:.2f}x" for th, v in ratios.items())
                      + f": {verdict}")
    print_encodings(results, p)


def print_encodings(results: list[dict], p: str) -> None:
    """Both node encodings' rays/s, each against the same peer numbers (* = the one chosen)."""
    print()
    print("BVH node encodings (Mrays/s, ratio to " + p + "; * = chosen by Geometry):")
    for r in results:
        cols = []
        for enc in ENCODINGS:
            mark = "*" if r["bvh_encoding"] == enc else " "
            parts = []
            for th in map(str, THREAD_COUNTS):
                s = r["sonolux_rays_per_s_by_encoding"][enc][th]
                pv = r.get("peer_rays_per_s", {}).get(th)
                parts.append(f"{th}T {s / 1e6:6.3f}" + (f" ({s / pv:.2f}x)" if pv else ""))
            cols.append(f"{enc}{mark} " + ", ".join(parts))
        same = "same hits" if r["encodings_same_hits"] else "HITS DIFFER"
        print(f"  {r['name']:<11} " + " | ".join(cols) + f" | {same}")




def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rays", type=int, default=1_000_000, help="rays per case (1,000,000)")
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats, median taken (3)")
    ap.add_argument("--seed", type=int, default=20240601)
    ap.add_argument("--peer", choices=("auto", "embree", "trimesh", "none"), default="auto",
                    help="auto: Embree, else trimesh on a subset")
    ap.add_argument("--no-install", action="store_true", help="never pip-install a peer")
    ap.add_argument("--out", type=Path, default=HERE / "results" / "bvh.json")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    busy_start = other_cpu_use()

    peer, peer_note = None, "none requested"
    if args.peer in ("auto", "embree"):
        mods, peer_note = load_embree(not args.no_install)
        peer = EmbreePeer(mods) if mods else None
        log(f"peer embree (embreex): {peer_note}")
    if peer is None and args.peer in ("auto", "trimesh"):
        if args.peer == "auto":
            log("FALLBACK: Embree unavailable, using trimesh's tracer on a subset of rays")
        peer, peer_note = load_trimesh_peer(not args.no_install)
        log(f"peer trimesh: {peer_note}")
    if peer is None:
        log(f"WARNING: no peer, only sonolux's own numbers ({peer_note})")

    log(f"making meshes and {args.rays:,} rays per case")
    cases = make_cases(args.rays, args.seed)
    results = [run_case(c, peer, args.repeats) for c in cases]

    print_table(results, peer.name if peer else None)
    if isinstance(peer, EmbreePeer):
        print("Embree: tracing threads = Python threads over contiguous slices (scene.run "
              "releases the GIL); its BVH build uses TBB on all cores (not settable in embreex).")
    elif isinstance(peer, TrimeshPeer):
        print("FALLBACK peer: trimesh's pure-Python tracer, 1 thread, on the first "
              + ", ".join(f"{r['name']} {r['peer_subset_rays']:,}" for r in results)
              + " rays (not Embree: its ratios say little about the BVH's quality).")
    busy_end = other_cpu_use()
    if max(busy_start, busy_end) > 0.15:
        print(f"WARNING: other processes kept {busy_start:.0%} of the CPUs busy at the start, "
              f"{busy_end:.0%} at the end: the rates are noisy, run again on an idle machine.")
    for r in results:
        a = r.get("agreement")
        if a and a["n_disagree"]:
            print(f"{r['name']}: {a['n_disagree']} of {a['n']:,} rays disagree, e.g. "
                  + "; ".join(f"ray {e['ray']}: t {e['t_sonolux']:.6g}/{e['t_peer']:.6g} "
                              f"tri {e['tri_sonolux']}/{e['tri_peer']}" for e in a["examples"]))
    elapsed = time.perf_counter() - t_start
    data = {
        "benchmark": "bvh",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "sonolux_version": getattr(core, "__version__", "?"),
        "peer": ({"name": peer.name, "version": peer.version, "note": peer_note} if peer else None),
        "machine": {"platform": platform.platform(), "python": platform.python_version(),
                    "cpus": os.cpu_count(),
                    "other_cpu_use_start_end": [busy_start, busy_end]},
        "settings": {"rays": args.rays, "repeats": args.repeats, "seed": args.seed,
                     "threads": list(THREAD_COUNTS), "t_rel_tol": T_REL_TOL},
        "elapsed_s": elapsed,
        "cases": results,
        "target": {"ratio_at_least": TARGET_RATIO, "cases": list(TARGET_CASES),
                   "met": bool(peer is not None and peer.name == "embree" and all(
                       min(r["ratio_rays_per_s"].values()) >= TARGET_RATIO
                       for r in results if r["name"] in TARGET_CASES))},
    }
    write_json(args.out, data)
    log(f"wrote {args.out} ({elapsed:.0f} s in all)")
    worst = min((r["agreement"]["agree"] for r in results if "agreement" in r), default=1.0)
    if worst < 0.999:
        log(f"WARNING: sonolux and {peer.name} agree on only {worst * 100:.3f}% of rays in a "
            "case: the throughput ratios are not comparing like with like")
    return 0


if __name__ == "__main__":
    sys.exit(main())
