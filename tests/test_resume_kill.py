"""Kill tests: ``sonolux bake`` killed with SIGKILL at random moments (and once in the middle of
writing its checkpoint), resumed each time with ``--resume``, ends with the same bits as one
uninterrupted bake."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import sonolux
from sonolux import checkpoint as side

pytestmark = pytest.mark.usefixtures("core")
BAKE = ["bake", "paper-small", "--rays", "40000", "--no-light", "-q", "--range-rays", "2500",
        "--checkpoint-every", "0"]
KILLS = 5


def sonolux_cmd(*argv):
    return [sys.executable, "-c", "import sys; from sonolux.cli import main; sys.exit(main())",
            *map(str, argv)]


def start(out, env=None):
    return subprocess.Popen(sonolux_cmd(*BAKE, "-o", out, "--resume"), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, env=env)


def kill_at(proc, seconds):
    """SIGKILL after ``seconds``; True if it was still running then."""
    try:
        proc.wait(timeout=seconds)
        return False
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        return True


def _wait(found, seconds):
    deadline = time.monotonic() + seconds
    while not found() and time.monotonic() < deadline:
        time.sleep(0.02)
    return bool(found())


def test_sigkill_at_random_moments_then_resume_gives_the_same_bits(tmp_path):
    reference = tmp_path / "reference.h5"
    started = time.perf_counter()
    done = subprocess.run(sonolux_cmd(*BAKE, "-o", reference), capture_output=True, text=True)
    uninterrupted_s = time.perf_counter() - started
    assert done.returncode == 0, done.stderr
    out = tmp_path / "killed.h5"
    ckpt = side.side_file(out)

    # First, one kill in the middle of a checkpoint write (the write pauses after its header),
    # once a first checkpoint exists: the last good checkpoint must be left untouched.
    proc = start(out)
    assert _wait(ckpt.exists, 60), "no checkpoint was written"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = ckpt.read_bytes()
    proc = start(out, env=dict(os.environ, **{side.PAUSE_ENV: "30"}))
    assert _wait(lambda: list(tmp_path.glob(f".{ckpt.name}.*.tmp")), 60), \
        "the checkpoint write never started"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert ckpt.read_bytes() == before

    # Then KILLS kills at random moments, each run resuming the one before.
    rng = random.Random(20)
    kills, runs = 0, 0
    while kills < KILLS and runs < 4 * KILLS:
        runs += 1
        if kill_at(start(out), rng.uniform(0.2, 0.9) * uninterrupted_s):
            kills += 1
            side.read(ckpt)  # whatever moment the kill came, the checkpoint is whole
        elif out.exists():  # finished before the kill: bake it again, from a checkpoint
            out.unlink()
            ckpt.write_bytes(before)
    assert kills == KILLS

    final = subprocess.run(sonolux_cmd(*BAKE, "-o", out, "--resume"), capture_output=True,
                           text=True)
    assert final.returncode == 0, final.stderr
    assert "resuming from" in final.stderr
    assert not ckpt.exists() and not list(tmp_path.glob(".*.tmp"))
    a, b = sonolux.open(reference), sonolux.open(out)
    assert np.array_equal(a.energy, b.energy)
    assert a.settings["ray_range"] == b.settings["ray_range"] == [0, 40000]


def test_without_resume_an_existing_checkpoint_gives_a_hint(tmp_path):
    out = tmp_path / "f.h5"
    ckpt = side.side_file(out)
    proc = subprocess.Popen(sonolux_cmd(*BAKE, "-o", out), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while not ckpt.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert ckpt.exists()
    again = subprocess.run(sonolux_cmd(*BAKE, "-o", out), capture_output=True, text=True)
    assert again.returncode == 2
    assert "add --resume to continue it, or --restart" in again.stderr
    assert "Traceback" not in again.stderr


def test_a_light_bake_killed_and_resumed_gives_the_same_bits(tmp_path):
    bake = ["bake", "paper-small", "--no-sound", "--particles", "2000000", "-q",
            "--range-rays", "100000", "--checkpoint-every", "0"]
    reference = tmp_path / "reference.h5"
    started = time.perf_counter()
    done = subprocess.run(sonolux_cmd(*bake, "-o", reference), capture_output=True, text=True)
    uninterrupted_s = time.perf_counter() - started
    assert done.returncode == 0, done.stderr
    out = tmp_path / "killed.h5"
    ckpt = side.side_file(str(out) + ".light")
    rng = random.Random(21)
    kills = 0
    for _ in range(20):
        proc = subprocess.Popen(sonolux_cmd(*bake, "-o", out, "--resume"),
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if kill_at(proc, rng.uniform(0.4, 0.9) * uninterrupted_s):
            kills += 1
            if kills >= 3 and ckpt.exists():  # (a kill before the first write leaves none)
                break
        elif out.exists():
            out.unlink()
    assert kills >= 3 and ckpt.exists()
    final = subprocess.run(sonolux_cmd(*bake, "-o", out, "--resume"), capture_output=True,
                           text=True)
    assert final.returncode == 0, final.stderr
    assert "resuming from" in final.stderr and not ckpt.exists()
    a, b = sonolux.open_light_field(reference), sonolux.open_light_field(out)
    assert np.array_equal(a.flux_w, b.flux_w) and np.array_equal(a.hits, b.hits)
