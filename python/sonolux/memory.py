"""Memory estimated before a large allocation, so that a run too large for this machine is
refused at once with the estimate, what the machine has, the settings that drive it and the
largest setting that fits, instead of aborting half way (or being killed by the system).

Who estimates what:
- the sound field (receivers × directions × bands × time bins): the core itself, against
  ``SoundOptions.max_field_bytes`` (default: :func:`budget_bytes`);
- the light's patches (one per k² sub-triangle of every triangle): :func:`patch_count`, in
  :func:`sonolux.light.bake.bake_light`, before the pilot run;
- a rendered picture (pixels × samples²): :mod:`sonolux.light.view`.
"""

from __future__ import annotations

import math

import numpy as np

from sonolux.errors import MemoryLimitError

#: What one light patch costs, end to end: in the core its area (8 B), three fixed-point flux
#: counters and a hit counter (32 B), the result's flux and hits (32 B); in Python the copies of
#: those (48 B) and the field's radiance (24 B). Rounded up.
BYTES_PER_PATCH = 160
#: What one camera ray costs in a render that keeps its samples: the ray's linear RGB (24 B),
#: its tone-mapped copy (24 B) and the look-up's temporaries (about 48 B).
BYTES_PER_RENDER_SAMPLE = 96
#: The largest patch edge count per triangle the core allows (``k`` of k² patches).
MAX_PATCHES_PER_EDGE = 4096


def available_bytes() -> int:
    """Memory this process may still take: MemAvailable of /proc/meminfo where there is one,
    else half of the machine's memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    from sonolux.engine import physical_memory_bytes

    return physical_memory_bytes() // 2


def budget_bytes() -> int:
    """What one large array of a run may take: 80% of :func:`available_bytes` (the rest is
    for everything else the run holds at the same time)."""
    return int(0.8 * available_bytes())


def gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB"


def check_memory(estimate_bytes: float, what: str, drivers: str, fits: str = "") -> None:
    """Raises :class:`MemoryLimitError` when ``estimate_bytes`` is above :func:`budget_bytes`::

        the light bake would need about 20.5 GB for its patches (128,042,092 patches of
        patch_size_m = 0.001 m), more than the 16.1 GB this machine can give it
        (80% of 20.1 GB available); patch_size_m = 0.0031 m or more fits
    """
    budget = budget_bytes()
    if estimate_bytes <= budget:
        return
    message = (f"{what} would need about {gb(estimate_bytes)} ({drivers}), more than the "
               f"{gb(budget)} this machine can give it (80% of {gb(available_bytes())} "
               f"available)")
    raise MemoryLimitError(message + (f"; {fits}" if fits else ""))


def patch_count(vertices_m: np.ndarray, triangles: np.ndarray, patch_size_m: float) -> int:
    """How many patches the core will make: k² per triangle with
    k = clamp(ceil(sqrt(2 A) / patch_size_m), 1, MAX_PATCHES_PER_EDGE)."""
    v = np.asarray(vertices_m, np.float64)[np.asarray(triangles, np.int64)]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    k = np.clip(np.ceil(np.sqrt(2.0 * area) / patch_size_m), 1, MAX_PATCHES_PER_EDGE)
    return int(np.sum(k * k))


def check_patches(vertices_m: np.ndarray, triangles: np.ndarray, patch_size_m: float) -> int:
    """The patch count, after :func:`check_memory` of what they take (the smallest patch size
    that fits is found from the count growing as 1 / size²)."""
    n = patch_count(vertices_m, triangles, patch_size_m)
    need = n * BYTES_PER_PATCH
    fits = patch_size_m * math.sqrt(need / max(budget_bytes(), 1)) * 1.05
    check_memory(need, "the light bake", f"{n:,} patches of patch_size_m = {patch_size_m:g} m",
                 f"patch_size_m = {fits:.2g} m or more fits")
    return n


def check_render(width: int, height: int, samples: int) -> None:
    """Refuses a picture whose rays would not fit (width × height × samples²)."""
    rays = width * height * samples * samples
    need = rays * BYTES_PER_RENDER_SAMPLE
    fit_samples = int(math.sqrt(budget_bytes() / (BYTES_PER_RENDER_SAMPLE * width * height)))
    fits = (f"--samples {fit_samples} fits at this size" if fit_samples >= 1
            else "a smaller --size is needed")
    check_memory(need, "the picture", f"{width}×{height} pixels × {samples}² samples", fits)
