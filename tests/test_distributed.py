"""The bake on a Dask LocalCluster of 2 worker processes: the same bits as a bake in this process,
also when a worker is killed mid-bake; the command line's --dask local; clear errors."""

from __future__ import annotations

import os
import shutil
import signal

import numpy as np
import pytest

import sonolux
from sonolux.errors import SonoluxError
from sonolux.sound.bake import bake as bake_whole

from .conftest import EXAMPLES

pytestmark = pytest.mark.usefixtures("core")
distributed = pytest.importorskip("distributed")
RAYS = 24000


@pytest.fixture(scope="module")
def client():
    from sonolux.distributed import connect

    with connect("local", workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def small():
    return sonolux.load_scene("paper-small")


@pytest.fixture(scope="module")
def whole(small):
    return bake_whole(small, rays=RAYS)


def test_dask_bake_has_the_bits_of_a_local_bake(client, small, whole):
    seen = []
    field = sonolux.bake(small, rays=RAYS, client=client, tasks=5,
                         progress=lambda done, total, s: seen.append((done, total)) or True)
    assert np.array_equal(field.energy, whole.energy)
    assert field.counts is None and field.settings["ray_range"] == [0, RAYS]
    assert field.stats["rays"] == RAYS
    assert len(seen) == 5 and seen[-1] == (RAYS, RAYS)


def test_a_worker_killed_mid_bake_changes_no_bit(client, small, whole):
    killed = []

    def kill_a_busy_worker(done, total, seconds):
        if not killed:
            busy = [w for w, keys in client.processing().items() if keys]
            pids = client.run(os.getpid, workers=busy[:1])
            for pid in pids.values():
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
        return True

    field = sonolux.bake(small, rays=RAYS, client=client, tasks=8, progress=kill_a_busy_worker)
    assert killed, "no worker was busy when the first task finished"
    assert np.array_equal(field.energy, whole.energy)
    assert field.stats["rays"] == RAYS  # the lost task's rays were counted once


def test_dask_bake_with_a_checkpoint_resumes_on_the_cluster(client, small, whole, tmp_path):
    path = tmp_path / "f.h5.checkpoint"
    part = sonolux.bake(small, rays=RAYS, ray_range=(0, 6000))
    from sonolux.checkpoint import write
    from sonolux.sound.ranges import SoundRanges, SoundSum

    work = SoundRanges(small, sonolux.SoundOptions(rays=RAYS))
    meta, arrays = work.encode(SoundSum.of(part))
    write(path, {"kind": "sound", "fingerprint": work.fingerprint, "stamp": work.stamp,
                 "target": [0, RAYS], "done": [[0, 6000]], "meta": meta}, arrays)
    field = sonolux.bake(small, rays=RAYS, client=client, checkpoint=path, resume=True)
    assert np.array_equal(field.energy, whole.energy)
    assert not path.exists()


def test_a_mesh_scene_travels_with_the_tasks(client, tmp_path):
    """The workers never see the mesh file: the tasks carry the triangles it resolved to."""
    for name in ("mesh_room.toml", "l_room.obj", "l_room.mtl"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    scene = sonolux.load_scene(tmp_path / "mesh_room.toml")
    here = bake_whole(scene, rays=4000)
    for name in ("l_room.obj", "l_room.mtl"):
        (tmp_path / name).unlink()
    field = sonolux.bake(scene, rays=4000, client=client, tasks=3)
    assert np.array_equal(field.energy, here.energy)


def test_dask_light_bake_has_the_bits_of_a_local_bake(client, small):
    from sonolux.light.bake import bake_light

    whole = bake_light(small, particles=30_000)
    field = sonolux.bake_light(small, particles=30_000, client=client, tasks=3)
    assert np.array_equal(field.flux_w, whole.flux_w) and np.array_equal(field.hits, whole.hits)
    assert field.stats["flux_absorbed_w"] == whole.stats["flux_absorbed_w"]


def test_cli_dask_local_both_senses(tmp_path, capsys):
    from sonolux import cli
    from sonolux.light.bake import bake_light

    out = tmp_path / "f.h5"
    code = cli.main(["bake", "paper-small", "--rays", "6000", "--particles", "20000", "-q",
                     "-o", str(out), "--dask", "local", "--dask-workers", "1"])
    assert code == 0, capsys.readouterr().err
    small = sonolux.load_scene("paper-small")
    assert np.array_equal(sonolux.open(out).energy, bake_whole(small, rays=6000).energy)
    assert np.array_equal(sonolux.open_light_field(out).flux_w,
                          bake_light(small, particles=20000).flux_w)
    assert not list(tmp_path.glob("*.checkpoint"))


def test_cli_dask_local(tmp_path, capsys):
    from sonolux import cli

    out = tmp_path / "f.h5"
    code = cli.main(["bake", "paper-small", "--rays", "6000", "--no-light", "-q", "-o", str(out),
                     "--dask", "local", "--dask-workers", "1"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert np.array_equal(sonolux.open(out).energy, bake_whole(sonolux.load_scene("paper-small"),
                                                               rays=6000).energy)
    assert cli.main(["bake", "paper-small", "-o", str(out), "--dask-workers", "2"]) == 2
    assert "--dask-workers is for --dask local" in capsys.readouterr().err


def test_an_unreachable_scheduler_is_one_clear_error():
    from sonolux.distributed import connect

    with pytest.raises(SonoluxError, match="cannot reach a Dask scheduler"):
        with connect("tcp://127.0.0.1:9", timeout_s=1):
            pass
