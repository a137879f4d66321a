"""Synthetic sound fields with known content, built without the compiled core, for the tests of
parameters, plots and reports."""

from __future__ import annotations

import numpy as np

from sonolux.sound.field import SoundField
from tests.analysis.test_decay import decay_histogram, nonuniform_axis


def stats(bands: int) -> dict:
    """Plausible bake statistics: 1 J emitted per band, all absorbed by the surfaces."""
    zero, one = [0.0] * bands, [1.0] * bands
    return {"rays": 1000, "segments": 5000, "surface_hits": 4990, "escaped_rays": 0,
            "deposits": 100, "max_reflections": 60, "mean_free_path_m": 1.9,
            "free_path_relative_variance": 0.4, "energy_emitted_j": one,
            "energy_absorbed_surfaces_j": one, "energy_absorbed_air_j": zero,
            "energy_escaped_j": zero, "energy_remaining_j": zero, "energy_reweighted_j": zero,
            "escapes": [], "seconds": 0.5, "rays_per_second": 2000.0,
            "segments_per_second": 10000.0, "mean_free_path_theory_m": 1.875,
            "saturated": False, "cancelled": False}


def synthetic_field(energy, start, width, positions_m, *, source_m=(3.0, 1.25, 1.5),
                    power_w=1.0, bands_hz=(500.0, 1000.0), grid_index=None, spacing_m=None,
                    radius_m=0.25, azimuth_bands=8, elevation_bands=1,
                    scene_name="synthetic", scene_origin="<test>") -> SoundField:
    """A SoundField holding ``energy`` float[receiver, direction, band, time]."""
    energy = np.ascontiguousarray(energy, dtype=np.float32)
    settings = {"rays": 1000, "ray_range": [0, 1000], "estimator": "paper", "seed": 1,
                "speed_of_sound_m_s": 343.2, "sample_rate_hz": 48000, "energy_drop_db": 60.0,
                "max_time_s": float(start[-1] + width[-1]), "early_bins": 3840,
                "late_bin_s": 0.001, "azimuth_bands": azimuth_bands,
                "elevation_bands": elevation_bands, "air_attenuation_per_m": [0.0] * len(bands_hz),
                "volume_m3": 30.0, "area_m2": 64.0,
                "air": {"temperature_c": 20.0, "humidity_percent": 50.0, "pressure_kpa": 101.325}}
    return SoundField(
        energy=energy, bin_start_s=np.asarray(start, float), bin_width_s=np.asarray(width, float),
        bands_hz=np.asarray(bands_hz, float), positions_m=np.asarray(positions_m, float),
        radius_m=radius_m, grid_index=None if grid_index is None else np.asarray(grid_index),
        grid_spacing_m=spacing_m, source_positions_m=np.asarray([source_m], float),
        source_powers_w=np.array([power_w]), settings=settings, stats=stats(len(bands_hz)),
        scene_name=scene_name, scene_origin=scene_origin)


def decaying_grid(t60_by_receiver_s, duration_s=3.0, directions=8, bands=2):
    """A 1-row grid along x (receivers at x = 1, 2, ...; y = 1.25 m): receiver k decays with
    T60 t60_by_receiver_s[k] in every band, its energy spread evenly over the directions.
    Returns (field, start, width)."""
    start, width = nonuniform_axis(duration_s)
    n = len(t60_by_receiver_s)
    e = np.stack([decay_histogram(start, width, [(1.0, t)]) for t in t60_by_receiver_s])
    energy = np.broadcast_to(e[:, None, None, :] / directions, (n, directions, bands, e.shape[-1]))
    positions = [(1.0 + k, 1.25, 1.5) for k in range(n)]
    grid_index = [(k, 0) for k in range(n)]
    field = synthetic_field(energy, start, width, positions, source_m=(0.2, 1.25, 1.5),
                            grid_index=grid_index, spacing_m=1.0,
                            bands_hz=(500.0, 1000.0)[:bands] if bands <= 2
                            else tuple(125.0 * 2 ** k for k in range(bands)))
    return field, start, width
