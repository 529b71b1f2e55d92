"""lente.distributed on a local Dask cluster of worker processes: the image
equals the merge of the same sample ranges rendered in this process, bit
for bit, also when a worker is killed mid-render."""

import os
import signal
import threading
import time

import numpy as np
import pytest

distributed = pytest.importorskip("dask.distributed")

import lente
import lente.distributed


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_sample_ranges_cover_every_sample_once():
    assert lente.distributed.sample_ranges(10, 3) == [(0, 3), (3, 6), (6, 10)]
    assert lente.distributed.sample_ranges(2, 8) == [(0, 1), (1, 2)]
    with pytest.raises(ValueError):
        lente.distributed.sample_ranges(0, 2)


def local_merge(path, spp, tasks, **params):
    scene = lente.load(path, **params)
    ranges = lente.distributed.sample_ranges(spp, tasks)
    return lente.merge(scene.render_film(samples=r, threads=1) for r in ranges)


def test_a_cluster_render_is_the_local_one(client, cbox, tmp_path):
    out = tmp_path / "cbox.exr"
    image = lente.distributed.render(
        cbox, spp=24, params={"res": 32}, tasks=6, client=client, output=out,
        aovs=["albedo"],
    )
    expected = local_merge(cbox, 24, 6, res=32)
    assert np.array_equal(image, expected)
    assert image.spp == 24 and sorted(image.aovs) == ["albedo.B", "albedo.G", "albedo.R"]
    assert np.array_equal(lente.read(out), image)
    # And the single-process render, up to float summation order.
    whole = lente.load(cbox, res=32).render(spp=24, progress=False)
    np.testing.assert_allclose(image, whole, rtol=1e-5, atol=1e-7)


def test_strips_bound_each_tasks_memory_and_change_nothing(client, cbox):
    image = lente.distributed.render(
        cbox, spp=12, params={"res": 40}, tasks=3, strips=3, client=client
    )
    expected = local_merge(cbox, 12, 3, res=40)
    assert image.shape == (40, 40, 3)
    assert np.array_equal(image, expected)


def test_a_killed_worker_changes_nothing(client, cbox):
    spp, tasks = 64, 8
    expected = local_merge(cbox, spp, tasks, res=64)
    result = {}

    def run():
        result["image"] = lente.distributed.render(
            cbox, spp=spp, params={"res": 64}, tasks=tasks, threads_per_task=1, client=client
        )

    t = threading.Thread(target=run)
    t.start()
    # Once a task is running, kill the worker process running it.
    deadline = time.time() + 60
    victim = None
    while victim is None and time.time() < deadline:
        busy = [w for w, keys in client.processing().items() if keys]
        if busy:
            victim = busy[0]
        else:
            time.sleep(0.05)
    assert victim is not None, "no task started"
    pid = client.run(os.getpid, workers=[victim])[victim]
    os.kill(pid, signal.SIGKILL)
    t.join(timeout=300)
    assert not t.is_alive()
    # The worker really died (its nanny started a new one, at a new
    # address) and its task was run again elsewhere.
    assert victim not in client.scheduler_info()["workers"]
    assert np.array_equal(result["image"], expected)
