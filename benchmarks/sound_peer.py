"""pyroomacoustics' side of benchmarks/sound.py: installing it, building the same shoebox, timing
its ray tracer alone, and counting its wall hits per ray with a numpy copy of its bounce rule.
A benchmark-only peer, never a runtime dependency of sonolux."""

from __future__ import annotations

import time
import warnings

import numpy as np
from common import load_peer

ENERGY_THRES = 1e-6  # pyroomacoustics' stop: 60 dB, as sonolux's energy_drop_db = 60
HIST_BIN_S = 0.001  # pyroomacoustics' histogram bins = sonolux's late bins


def log(msg: str) -> None:
    print(f"[sound {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def load_pra(allow_install: bool):
    """(pyroomacoustics module or None, note), installing it into this interpreter if allowed."""
    return load_peer("pyroomacoustics", _import_pra, allow_install, log)


def _import_pra():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import pyroomacoustics
    return pyroomacoustics


def shoebox_of(scene) -> dict:
    """The shoebox's size, source and per-face energy absorption / scattering, read from the
    sonolux scene (so both engines are given the very same room)."""
    size = np.asarray(scene.mesh_report["bbox_max"], float) - np.asarray(scene.mesh_report["bbox_min"], float)
    bands = scene.settings.band_set  # the scene's bands (the materials' values converted to them)
    faces = {}
    for name in ("west", "east", "south", "north", "floor", "ceiling"):
        mats = {int(m) for m, tag in zip(scene.material_index, scene.surface_tag) if tag == name}
        assert len(mats) == 1, f"face {name}: {len(mats)} materials"
        m = scene.materials[mats.pop()]
        a, s = m.absorption_in(bands), m.scattering_in(bands)
        assert np.ptp(a) == 0 and np.ptp(s) == 0, "the peer is given one band: flat materials only"
        faces[name] = (float(a[0]), float(s[0]))
    return {"size_m": size, "source_m": np.asarray(scene.sources[0].position_m, float), "faces": faces}


def pra_room(pra, box: dict, mics: np.ndarray, n_rays: int, time_thres: float, radius: float):
    mats = {name: pra.Material(energy_absorption=a, scattering=s) for name, (a, s) in box["faces"].items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        room = pra.ShoeBox(box["size_m"], fs=48000, materials=mats, max_order=-1,
                           ray_tracing=True, air_absorption=False)
        room.set_ray_tracing(n_rays=int(n_rays), receiver_radius=radius, energy_thres=ENERGY_THRES,
                             time_thres=time_thres, hist_bin_size=HIST_BIN_S)
    room.add_source(box["source_m"])
    room.add_microphone_array(np.asarray(mics, float).reshape(-1, 3).T)
    return room


def pra_trace(room) -> float:
    """Seconds of room.ray_tracing() alone (the RIR synthesis of compute_rir() is left out)."""
    t0 = time.perf_counter()
    room.ray_tracing()
    return time.perf_counter() - t0


def pra_hits_per_ray(box: dict, time_thres: float, c: float, n: int = 4000, seed: int = 5) -> float:
    """Wall hits per ray of libroom's simul_ray rule, replayed in numpy on the shoebox: the
    energy times (1 - absorption) at each hit; stop below ENERGY_THRES or past time_thres; the
    new direction = s * Lambert + (1 - s) * specular, normalised (a blend, not a choice)."""
    rng = np.random.default_rng(seed)
    names = ("west", "east", "south", "north", "floor", "ceiling")  # axis 0 low/high, 1, 2
    alpha = np.array([box["faces"][k][0] for k in names])
    scat = np.array([box["faces"][k][1] for k in names])
    size = box["size_m"]
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    p = np.tile(box["source_m"], (n, 1))
    e, dist, hits = np.ones(n), np.zeros(n), np.zeros(n)
    alive = np.arange(n)
    max_dist = time_thres * c
    while alive.size:
        pa, da = p[alive], d[alive]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(da > 0, (size - pa) / da, np.where(da < 0, -pa / da, np.inf))
        ax = np.argmin(t, axis=1)
        k = np.arange(alive.size)
        tk = t[k, ax]
        high = da[k, ax] > 0
        face = 2 * ax + high
        pa = pa + da * tk[:, None]
        dist[alive] += tk
        hits[alive] += 1
        e[alive] *= 1 - alpha[face]
        da[k, ax] *= -1  # specular
        inward = np.where(high, -1.0, 1.0)
        u1, u2 = rng.random(alive.size), rng.random(alive.size)
        r, phi = np.sqrt(u1), 2 * np.pi * u2
        lam = np.empty_like(da)
        lam[k, ax] = inward * np.sqrt(np.maximum(0.0, 1 - u1))
        lam[k, (ax + 1) % 3] = r * np.cos(phi)
        lam[k, (ax + 2) % 3] = r * np.sin(phi)
        s = scat[face][:, None]
        da = s * lam + (1 - s) * da
        da /= np.linalg.norm(da, axis=1)[:, None]
        p[alive], d[alive] = pa, da
        keep = (e[alive] >= ENERGY_THRES) & (dist[alive] <= max_dist)
        alive = alive[keep]
    return float(hits.mean())


# --------------------------------------------------------------------------- 1: sonolux rates
