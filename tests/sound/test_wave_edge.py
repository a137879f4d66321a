"""The hybrid's one check at the edge (issue 18, :func:`sonolux.sound.bake.check_waves`): a bake
whose waves would not fit in memory is refused before any ray or pilot is traced, by every entry
that traces rays: the plain bake, ``sonolux.bake`` (checkpointed ranges, the automatic
estimator's pilots), the range baker and the progressive bake, and the command line on each of
its paths (exit 2, the message naming the setting, the value given and what would fit). The
crossover is chosen once there, on the field's own time axis, which must be the one the rays
then have (else the waves could choose another crossover after the rays)."""

from __future__ import annotations

import numpy as np
import pytest

import sonolux
from sonolux import engine
from sonolux.errors import MemoryLimitError
from sonolux.sound import bake as bake_module
from sonolux.sound import wave_memory
from sonolux.sound.options import SoundOptions

pytestmark = pytest.mark.usefixtures("core")

#: A response length that is no whole number of late bins, so that the last bin ends past it.
MAX_TIME_S = 0.1537
SCENE_TOML = ('name = "box"\n[settings]\nbands_hz = [125, 250, 500, 1000]\nseed = 3\n'
              '[materials.m]\nabsorption = 0.15\nscattering = 0.7\n[[geometry]]\n'
              'type = "shoebox"\nsize_m = [5, 4, 3]\n[geometry.materials]\ndefault = "m"\n'
              '[[sources]]\nposition_m = [1.3, 1.1, 1.4]\n[receivers]\ntype = "points"\n'
              'positions_m = [[2.9, 2.1, 1.2], [2.5, 0.7, 1.6]]\nradius_m = 0.3\n')


def room(tmp_path):
    path = tmp_path / "box.toml"
    path.write_text(SCENE_TOML)
    return path, sonolux.load_scene(str(path))


def no_rays(monkeypatch):
    """Every way into the core's tracer and wave solver fails the test."""
    def traced(*args, **kwargs):
        raise AssertionError("a ray (or a wave step) was run before the refusal")

    for name in ("trace_sound", "trace_sound_with", "early_arrivals", "simulate_waves"):
        monkeypatch.setattr(engine, name, traced, raising=False)


@pytest.mark.parametrize("storage, compact_late_bin_s", [
    ("full", "auto"), ("compact", "auto"), ("compact", 0.004)])
def test_the_field_axis_known_before_the_rays_is_the_baked_one(tmp_path, storage,
                                                               compact_late_bin_s):
    """:func:`wave_memory.field_axis` (bins and end, from the settings alone) against a baked
    field's own axis: the same bin count and, bit for bit, the same end that
    :func:`sonolux.sound.bake.wave_part` takes for the waves' duration (exact equality: the
    crossover depends on that duration). The compact cases have several view bins per stored
    bin (4 and the automatic split)."""
    _, scene = room(tmp_path)
    options = SoundOptions(rays=300, storage=storage, compact_late_bin_s=compact_late_bin_s,
                           max_time_s=MAX_TIME_S)
    field = bake_module.bake(scene, options)
    arrays = bake_module.bake_arrays(scene, options)
    early_s, stored_s, split = bake_module.stored_axis(scene, options, arrays)
    assert (split > 1) == (storage == "compact"), split
    bins, end_s = wave_memory.field_axis(early_s, stored_s, split,
                                         float(scene.settings.sample_rate_hz), MAX_TIME_S)
    baked_end = max(MAX_TIME_S, float(np.max(np.asarray(field.bin_start_s)
                                             + np.asarray(field.bin_width_s))))
    assert bins == np.asarray(field.bin_start_s).size
    assert end_s == baked_end and end_s > MAX_TIME_S


def test_the_crossover_chosen_before_the_rays_is_the_waves_own(tmp_path):
    """The automatic crossover of the check (no timing run) is the one the waves then choose on
    the baked field, and the logged estimate is the check's."""
    _, scene = room(tmp_path)
    notes: list[str] = []
    options = SoundOptions(rays=300, waves=True, max_time_s=MAX_TIME_S)
    before = bake_module.check_waves(scene, options, from_ray_zero=False)
    field = bake_module.bake(scene, options, log=notes.append)
    assert before is not None and field.waves is not None
    assert field.waves["crossover_hz"] == before.crossover_hz
    assert field.waves["wave_bands"] == before.wave_bands
    assert any(n.startswith(f"waves: about {wave_memory.gb(before.total_bytes)}") for n in notes)


def too_small(scene, **options) -> int:
    """One byte under the waves' estimate of a bake of ``scene`` with ``options``."""
    memory = bake_module.check_waves(scene, SoundOptions(**{'waves': True, **options}),
                                     from_ray_zero=False)
    assert memory is not None
    return memory.total_bytes - 1


@pytest.mark.parametrize("entry", ["plain", "checkpoint", "pilots", "progressive", "ranges"])
def test_every_library_entry_refuses_waves_that_do_not_fit_before_any_ray(tmp_path, monkeypatch,
                                                                           entry):
    """max_field_bytes one byte under the estimate: each entry raises the usage error
    (MemoryLimitError, a SonoluxError) naming the limit's setting and what fits, and neither the
    tracer, the image sources nor the wave solver is called; no checkpoint is left."""
    from sonolux.sound import baking, progressive
    from sonolux.sound.ranges import SoundRanges

    _, scene = room(tmp_path)
    common = dict(waves=True, crossover_hz=354, max_time_s=MAX_TIME_S)
    limit = too_small(scene, **common)
    no_rays(monkeypatch)
    side = tmp_path / "bake.checkpoint"
    run = {
        "plain": lambda: bake_module.bake(scene, rays=2000, max_field_bytes=limit, **common),
        "checkpoint": lambda: baking.bake(scene, rays=2000, max_field_bytes=limit,
                                          checkpoint=side, **common),
        "pilots": lambda: baking.bake(scene, rays=2000, estimator="auto",
                                      max_field_bytes=limit, **common),
        "progressive": lambda: progressive.bake(
            scene, SoundOptions(max_field_bytes=limit, **common), progressive.Accuracy(0.5),
            checkpoint=side),
        "ranges": lambda: SoundRanges(scene, SoundOptions(rays=2000, ray_range=(0, 1000),
                                                          max_field_bytes=limit, **common)),
    }[entry]
    with pytest.raises(MemoryLimitError) as refused:
        run()
    message = str(refused.value)
    for part in ("before any ray", f"SoundOptions.max_field_bytes = {limit:,}",
                 "a limit of at least", "crossover (--crossover-hz, now 354 Hz)"):
        assert part in message, message
    assert not side.exists()


def test_a_range_without_ray_zero_is_not_held_to_the_waves_memory(tmp_path, monkeypatch):
    """The waves belong to the range from ray 0: a later range does not compute them, so it is
    not refused for their memory (it reaches the rays, here made to fail)."""
    from sonolux.sound.ranges import SoundRanges

    _, scene = room(tmp_path)
    common = dict(waves=True, crossover_hz=354, max_time_s=MAX_TIME_S)
    limit = too_small(scene, **common)
    work = SoundRanges(scene, SoundOptions(rays=2000, ray_range=(1000, 2000),
                                           max_field_bytes=limit, **common))
    assert work.target == (1000, 2000)
    with pytest.raises(MemoryLimitError):
        SoundRanges(scene, SoundOptions(rays=2000, ray_range=(0, 1000), max_field_bytes=limit,
                                        **common))
    no_rays(monkeypatch)
    with pytest.raises(AssertionError, match="before the refusal"):
        bake_module.bake(scene, rays=2000, ray_range=(1000, 2000), max_field_bytes=limit,
                         **common)


@pytest.mark.parametrize("extra", [
    [], ["--no-checkpoint"], ["--range", "0:1000"], ["--estimator", "auto"],
    ["--rays", "auto", "--accuracy", "0.5"]])
def test_the_command_line_refuses_waves_over_its_memory_before_any_ray(tmp_path, capsys,
                                                                       monkeypatch, extra):
    """`sonolux bake --waves --memory 1M` on each of its paths (checkpointed ranges by default,
    plain, one range, the automatic estimator's pilots, progressive): exit 2, one line naming
    --memory, the value given, the estimate and what would fit (beside, at most the estimate's
    note); no ray traced, no output, no checkpoint."""
    from sonolux.cli import main

    path, scene = room(tmp_path)
    estimate = too_small(scene, crossover_hz=354, memory_bytes=10**6) + 1
    assert estimate > 10**6  # the waves need more than the 1 MB given
    no_rays(monkeypatch)
    out = tmp_path / "out.h5"
    code = main(["bake", str(path), "--rays", "2000", "--waves", "--crossover-hz", "354",
                 "--memory", "1M", "--no-light", "--quiet", *extra, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    errors = [line for line in err.splitlines() if line.startswith("sonolux: error:")]
    assert "Traceback" not in err and len(errors) == 1, err
    for part in ("waves of this hybrid bake", f"about {wave_memory.gb(estimate)}",
                 "more than the limit of 0.001 GB (--memory, SoundOptions.memory_bytes = "
                 "1,000,000)", f"a limit of at least {wave_memory.gb(estimate)}",
                 "before any ray"):
        assert part in err, err
    assert not out.exists()
    assert not list(tmp_path.glob("out.h5*")), list(tmp_path.iterdir())
