"""The illuminance map against Radiance: the same room, the same light, the same work plane;
the irradiance both give, and the time each takes to reach 2% noise per cell.

Run with ``.venv/bin/python benchmarks/radiance.py`` (``make bench`` runs it; the peer is
``pyradiance``, whose wheel carries Radiance's programs; installed by the peers' stamp). The
room: 6 × 4 × 3 m, every surface grey and diffuse (ρ = 0.6), a 1 × 1 m light panel of radiance
100 W/m²/sr per channel facing down from the ceiling's centre; the work plane at 0.8 m, cells
every 0.5 m (96 cells).

- sonolux: the light bake (particles from the panel, work plane counting the flux crossing it
  downwards); a cell's irradiance is its flux over its area, averaged over the cell.
- Radiance: ``rtrace -I`` (irradiance) at the cells' centres, facing up, with ambient caching
  off (``-aa 0``: every value is its own Monte Carlo estimate, so its noise can be measured and
  no cache interpolates), ``-ab 20`` ambient bounces (what is left after 20 is ρ²¹ = 2e-5 of
  the light) and Russian roulette below a ray weight of 1e-3 (``-lr -10 -lw 1e-3``: Radiance
  continues a light ray with probability weight / 1e-3 instead of cutting it, so nothing is
  lost on average); the number of ambient divisions ``-ad`` is set by the run.

Noise: each tool runs twice with different seeds at the same effort (Radiance: the same
points in another order, with uncorrelated sampling ``-u+``, so each point draws other random
numbers); two independent runs differ by √2 σ, which gives a cell's relative noise σ; its RMS
over the cells is the run's noise. Each tool's effort
is raised until that noise is at most 2%; the time of that run is the result. Agreement: the
mean over the cells of the two tools' best runs, and the RMS of their cell-by-cell ratio. The
two differ in what a cell is (sonolux: the mean over the cell; Radiance: the value at its
centre); in this smooth field that is well under the noise.
"""

from __future__ import annotations

import json
import math
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

import sonolux
from sonolux.light.bake import bake_light
from sonolux.light.photometry import MAX_LUMINOUS_EFFICACY_LM_PER_W

RESULTS = Path(__file__).resolve().parent / "results" / "radiance.json"
SIZE_M = (6.0, 4.0, 3.0)
RHO = 0.6
RADIANCE_W_M2_SR = 100.0
PANEL_M = 1.0
TARGET_NOISE = 0.02

ROOM_RAD = f"""void plastic grey
0
0
5 {RHO} {RHO} {RHO} 0 0

void light panel_light
0
0
3 {RADIANCE_W_M2_SR} {RADIANCE_W_M2_SR} {RADIANCE_W_M2_SR}

grey polygon floor
0
0
12 0 0 0  0 {SIZE_M[1]} 0  {SIZE_M[0]} {SIZE_M[1]} 0  {SIZE_M[0]} 0 0

grey polygon ceiling
0
0
12 0 0 {SIZE_M[2]}  {SIZE_M[0]} 0 {SIZE_M[2]}  {SIZE_M[0]} {SIZE_M[1]} {SIZE_M[2]}  0 {SIZE_M[1]} {SIZE_M[2]}

grey polygon south
0
0
12 0 0 0  {SIZE_M[0]} 0 0  {SIZE_M[0]} 0 {SIZE_M[2]}  0 0 {SIZE_M[2]}

grey polygon north
0
0
12 0 {SIZE_M[1]} 0  0 {SIZE_M[1]} {SIZE_M[2]}  {SIZE_M[0]} {SIZE_M[1]} {SIZE_M[2]}  {SIZE_M[0]} {SIZE_M[1]} 0

grey polygon west
0
0
12 0 0 0  0 0 {SIZE_M[2]}  0 {SIZE_M[1]} {SIZE_M[2]}  0 {SIZE_M[1]} 0

grey polygon east
0
0
12 {SIZE_M[0]} 0 0  {SIZE_M[0]} {SIZE_M[1]} 0  {SIZE_M[0]} {SIZE_M[1]} {SIZE_M[2]}  {SIZE_M[0]} 0 {SIZE_M[2]}

panel_light polygon panel
0
0
12 2.5 1.5 2.999  2.5 2.5 2.999  3.5 2.5 2.999  3.5 1.5 2.999
"""


def sonolux_scene():
    """The room in sonolux: the panel's flux is π L A per channel (a Lambertian emitter)."""
    return sonolux.load_scene({
        "name": "radiance-room",
        "materials": {"grey": {"absorption": 0.5, "diffuse_rgb": [RHO] * 3, "specular": 0.0}},
        "geometry": [{"type": "shoebox", "size_m": list(SIZE_M), "materials": {"default": "grey"}}],
        "lights": [{"center_m": [3.0, 2.0, 2.999], "size_m": [PANEL_M, PANEL_M],
                    "normal": [0, 0, -1], "tangent": [1, 0, 0],
                    "power_w": math.pi * RADIANCE_W_M2_SR * PANEL_M**2}],
        "workplane": {"height_m": 0.8, "spacing_m": 0.5},
    })


def sonolux_irradiance(scene, particles: int, seed: int) -> tuple[np.ndarray, float]:
    from dataclasses import replace

    s = replace(scene, settings=replace(scene.settings, seed=seed))
    started = time.perf_counter()
    field = bake_light(s, particles=particles, patch_size_m=1.0)
    seconds = time.perf_counter() - started
    # Grey: lux = K × the channel's irradiance.
    return field.workplane.illuminance_lx / MAX_LUMINOUS_EFFICACY_LM_PER_W, seconds


def radiance_irradiance(octree: Path, points: np.ndarray, ad: int, seed: int) -> tuple[np.ndarray, float]:
    import pyradiance as pr

    params = ["-ab", "20", "-ad", str(ad), "-as", "0", "-aa", "0", "-lr", "-10", "-lw", "1e-3"]
    started = time.perf_counter()
    # -u+ makes the sampling uncorrelated; a run's seed is its ray order: shifting the points
    # by a seed-dependent permutation gives an independent run.
    order = np.random.default_rng(seed).permutation(points.shape[0])
    rays = "".join(f"{x} {y} {z} 0 0 1\n" for x, y, z in points[order]).encode()
    out = pr.rtrace(rays, octree, header=False, irradiance=True, uncorrelated=True,
                    params=params, nproc=os.cpu_count() or 1)
    seconds = time.perf_counter() - started
    values = np.array([float(v.split()[0]) for v in out.decode().strip().splitlines()])
    back = np.empty_like(values)
    back[order] = values
    return back, seconds


def noise(a: np.ndarray, b: np.ndarray) -> float:
    """RMS over cells of one run's relative noise: two independent runs differ by √2 σ."""
    return float(np.sqrt(np.mean(((a - b) / (0.5 * (a + b))) ** 2)) / math.sqrt(2))


def main() -> None:
    import pyradiance as pr

    scene = sonolux_scene()
    points = np.asarray(scene.workplane.positions_m, float)
    print(f"room {SIZE_M} m, ρ = {RHO}, panel {PANEL_M} m² of {RADIANCE_W_M2_SR} W/m²/sr, "
          f"{points.shape[0]} work-plane cells at 0.8 m, {os.cpu_count()} cores")
    runs: dict[str, list[dict]] = {"sonolux": [], "radiance": []}
    particles = 50_000
    while True:
        a, ta = sonolux_irradiance(scene, particles, 1)
        b, tb = sonolux_irradiance(scene, particles, 2)
        n = noise(a, b)
        runs["sonolux"].append({"particles": particles, "seconds": (ta + tb) / 2, "noise": n,
                                "mean_w_m2": float((a + b).mean() / 2)})
        print(f"sonolux  {particles:>11,} particles: {(ta + tb) / 2:7.2f} s, noise {n:.2%}")
        if n <= TARGET_NOISE or particles > 50_000_000:
            son = (a + b) / 2
            break
        particles = int(particles * min(8.0, max(1.5, (n / TARGET_NOISE) ** 2 * 1.1)))
    with tempfile.TemporaryDirectory() as tmp:
        rad = Path(tmp) / "room.rad"
        rad.write_text(ROOM_RAD)
        octree = Path(tmp) / "room.oct"
        octree.write_bytes(pr.oconv(str(rad)))
        ad = 16
        while True:
            a, ta = radiance_irradiance(octree, points, ad, 1)
            b, tb = radiance_irradiance(octree, points, ad, 2)
            n = noise(a, b)
            runs["radiance"].append({"ad": ad, "seconds": (ta + tb) / 2, "noise": n,
                                     "mean_w_m2": float((a + b).mean() / 2)})
            print(f"Radiance -ad {ad:>7}: {(ta + tb) / 2:7.2f} s, noise {n:.2%}")
            if n <= TARGET_NOISE or ad >= 65536:
                rad_e = (a + b) / 2
                break
            ad = int(ad * min(8.0, max(1.5, (n / TARGET_NOISE) ** 2 * 1.1)))
    s_best, r_best = runs["sonolux"][-1], runs["radiance"][-1]
    ratio = son / rad_e
    agreement = {"mean_sonolux_w_m2": float(son.mean()), "mean_radiance_w_m2": float(rad_e.mean()),
                 "mean_ratio": float(son.mean() / rad_e.mean()),
                 "rms_cell_ratio_minus_1": float(np.sqrt(np.mean((ratio - 1) ** 2)))}
    speed = r_best["seconds"] / s_best["seconds"]
    print(f"to {TARGET_NOISE:.0%} noise: sonolux {s_best['seconds']:.2f} s, Radiance "
          f"{r_best['seconds']:.2f} s: sonolux {speed:.2f}x Radiance's speed")
    print(f"mean irradiance: sonolux {agreement['mean_sonolux_w_m2']:.2f}, Radiance "
          f"{agreement['mean_radiance_w_m2']:.2f} W/m² (ratio {agreement['mean_ratio']:.4f}); "
          f"cell by cell RMS {agreement['rms_cell_ratio_minus_1']:.2%}")
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps({
        "room_m": SIZE_M, "rho": RHO, "panel_radiance_w_m2_sr": RADIANCE_W_M2_SR,
        "cells": int(points.shape[0]), "target_noise": TARGET_NOISE, "cores": os.cpu_count(),
        "machine": platform.node(), "runs": runs, "agreement": agreement,
        "sonolux_speed_vs_radiance": speed}, indent=2) + "\n")
    print(f"-> {RESULTS}")


if __name__ == "__main__":
    main()
