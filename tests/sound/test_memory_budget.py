"""A whole floor of receivers bakes within its memory budget (sonolux.sound.budget): 16,281
receivers on a 0.5 m grid over a 40.5 × 101 m floor, traced in tiles, the peak resident memory
of the baking process measured by the kernel (getrusage's ru_maxrss)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

FLOOR = """
name = "open-plan floor"
[settings]
sample_rate_hz = 24000
bands_hz = [125, 250, 500, 1000, 2000, 4000]
max_time_s = 1.0
seed = 3
[[geometry]]
type = "shoebox"
size_m = [40.5, 101.0, 3.0]
[geometry.materials]
walls = "plaster-smooth"
floor = "carpet-on-concrete"
ceiling = "concrete-painted"
[[sources]]
name = "talker"
position_m = [20.0, 50.0, 1.6]
power_w = 0.01
[receivers]
type = "grid"
spacing_m = 0.5
height_m = 1.2
radius_m = 0.25
"""

BAKE = """
import json, resource, sys
import sonolux
from sonolux.sound.bake import bake
notes = []
field = bake(sonolux.load_scene(sys.argv[1]), rays=int(sys.argv[2]),
             memory_bytes=int(sys.argv[3]), log=notes.append)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"receivers": field.n_receivers, "tiles": field.stats["tiles"],
                  "estimate": field.stats["memory_estimate_bytes"], "peak": peak,
                  "bytes_per_receiver": field.bytes_per_receiver, "notes": notes}))
"""

BUDGET = 3_000_000_000


@pytest.mark.slow
def test_a_floor_of_16000_receivers_bakes_within_its_budget(tmp_path):
    scene = tmp_path / "floor.toml"
    scene.write_text(FLOOR)
    done = subprocess.run([sys.executable, "-c", BAKE, str(scene), "2000", str(BUDGET)],
                          capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["receivers"] >= 16_000 and out["tiles"] > 1, out
    assert out["estimate"] <= BUDGET, out
    assert out["peak"] <= BUDGET, out
    print(out)


def test_a_budget_too_small_for_a_floor_is_refused_up_front(tmp_path):
    import sonolux
    from sonolux.errors import MemoryLimitError
    from sonolux.sound.bake import bake

    scene = tmp_path / "floor.toml"
    scene.write_text(FLOOR)
    with pytest.raises(MemoryLimitError, match=r"16,281 receivers.*give --memory \d"):
        bake(sonolux.load_scene(str(scene)), rays=100, memory_bytes=500_000_000)
