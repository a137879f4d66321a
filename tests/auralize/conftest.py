"""Small synthetic sound fields with known arrivals, so the auralization tests have exact answers
and need neither the compiled core nor a bake."""

from __future__ import annotations

import numpy as np
import pytest

from sonolux.sound.field import SoundField, direction_names

FS = 48000


def synthetic_field(positions_xy, arrivals, bands_hz=(1000.0,), duration_s=0.05,
                    n_elevation: int = 1, spacing_m: float = 1.0) -> SoundField:
    """A field of receivers at positions_xy (a grid of ``spacing_m``) on one-sample bins.

    arrivals: {(receiver, direction name or index): [(time_s, energy J/m²), ...]}, the same
    energy in every band. With one band, each arrival is one positive spike of amplitude
    sqrt(energy · fs) in the direction's response."""
    n_dir = 8 * n_elevation
    names = direction_names(8, n_elevation)
    n_t = int(round(duration_s * FS))
    e = np.zeros((len(positions_xy), n_dir, len(bands_hz), n_t), np.float32)
    for (r, d), hits in arrivals.items():
        d = names.index(d) if isinstance(d, str) else d
        for t, energy in hits:
            e[r, d, :, int(round(t * FS))] += energy
    pos = np.column_stack([np.asarray(positions_xy, float), np.full(len(positions_xy), 1.5)])
    settings = {"sample_rate_hz": FS, "azimuth_bands": 8, "elevation_bands": n_elevation,
                "volume_m3": 100.0, "speed_of_sound_m_s": 343.0, "rays": 1, "seed": 1,
                "estimator": "rain", "early_bins": n_t, "late_bin_s": 0.001,
                "max_time_s": duration_s}
    return SoundField(energy=e, bin_start_s=np.arange(n_t) / FS, bin_width_s=np.full(n_t, 1 / FS),
                      bands_hz=np.asarray(bands_hz, float), positions_m=pos, radius_m=0.25,
                      grid_index=None, grid_spacing_m=spacing_m,
                      source_positions_m=np.array([[0.0, 0.0, 1.5]]),
                      source_powers_w=np.array([1.0]), settings=settings, stats={},
                      scene_name="synthetic")


@pytest.fixture
def one_arrival():
    """One receiver at (0.5, 0.5); a single arrival from ``direction`` at 5 ms."""

    def make(direction="right", energy=1e-4, **kw):
        return synthetic_field([(0.5, 0.5)], {(0, direction): [(0.005, energy)]}, **kw)

    return make
