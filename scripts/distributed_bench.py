"""Wall time of one scene rendered in this process and by 1 and 2 local
Dask workers (one thread each), the overhead per task, and how far the
merged image is from the single render. Run after `pip install ".[distributed]"`:

    python scripts/distributed_bench.py [SCENE] [--spp N] [--res R]
"""

import argparse
import time

import numpy as np
from dask.distributed import Client, LocalCluster

import lente
import lente.distributed


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="scenes/mitsuba/cbox.xml")
    ap.add_argument("--spp", type=int, default=128)
    ap.add_argument("--res", type=int, default=256)
    args = ap.parse_args()
    params = {"res": args.res}
    scene = lente.load(args.scene, **params)
    scene.render(spp=1, threads=1, progress=False)  # warm
    t = time.perf_counter()
    single = scene.render(spp=args.spp, threads=1, progress=False)
    t_single1 = time.perf_counter() - t
    t = time.perf_counter()
    scene.render(spp=args.spp, threads=2, progress=False)
    t_single2 = time.perf_counter() - t
    print(f"{args.scene} at {args.res}px, {args.spp} spp")
    print(f"single process, 1 thread:  {t_single1:.2f} s")
    print(f"single process, 2 threads: {t_single2:.2f} s")
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            lente.distributed.render(args.scene, spp=workers, params=params, tasks=workers,
                                     threads_per_task=1, client=client)  # load on workers
            for tasks in (2 * workers, 16):
                t = time.perf_counter()
                image = lente.distributed.render(args.scene, spp=args.spp, params=params,
                                                 tasks=tasks, threads_per_task=1, client=client)
                took = time.perf_counter() - t
                rel = float(np.max(np.abs(image - single) / np.maximum(np.abs(single), 1e-6)))
                ideal = t_single1 / workers
                print(f"{workers} worker(s), {tasks:2d} tasks: {took:.2f} s "
                      f"(overhead per task {(took - ideal) / tasks * 1e3:+.0f} ms), "
                      f"max relative difference from the single render {rel:.1e}")


if __name__ == "__main__":
    main()
