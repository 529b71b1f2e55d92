#!/usr/bin/env python3
"""Mitsuba 3's side of `lente bench`: times Mitsuba renders of scene files.

    python scripts/mitsuba_bench.py --spp 64 --threads 1,2 \
        [--variants scalar_rgb,llvm_ad_rgb] [--repeat 3] SCENE[::NAME=VALUE,...]...

For every scene, variant and thread count it prints one JSON line:
{"scene", "variant", "threads", "compile_s", "render_s", "samples"}. Mitsuba
is timed warm: the first render of a loaded scene (which compiles its
kernels in the LLVM variant) is timed apart as compile_s; render_s is the
fastest of --repeat renders that follow (other seeds), each render plus its
evaluation, without loading the scene. Variants that cannot start (no
libLLVM) print {"variant", "error"} once.

One thread: Dr.Jit's LLVM backend hung here with set_thread_count(1), so
for one thread the script keeps two workers and pins the process to one
core (sched_setaffinity): one core's throughput, which is what per-core
figures need. The LLVM variant needs libLLVM (DRJIT_LIBLLVM_PATH; Debian's
libllvm19 works, LLVM 15 aborts); the script looks in the usual places.
"""

import argparse
import json
import os
import sys
import time

LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM.so",
]


def use_libllvm():
    """Points Dr.Jit at a libLLVM it can use (DRJIT_LIBLLVM_PATH) unless the
    caller already did. Call before importing drjit."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        for c in LLVM_CANDIDATES:
            if os.path.exists(c):
                os.environ["DRJIT_LIBLLVM_PATH"] = c
                break


def parse_scene(arg):
    """'path::a=1,b=2' -> (path, {'a': '1', 'b': '2'})."""
    path, _, params = arg.partition("::")
    kv = dict(p.split("=", 1) for p in params.split(",") if p)
    return path, kv


def emit(record):
    print(json.dumps(record), flush=True)


def time_render(mi, dr, scene, spp, seed):
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts")
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("scenes", nargs="+")
    args = ap.parse_args()

    use_libllvm()
    import drjit as dr
    import mitsuba as mi

    all_cores = os.sched_getaffinity(0)
    for variant in args.variants.split(","):
        try:
            mi.set_variant(variant)
        except Exception as e:  # e.g. no libLLVM for llvm_ad_rgb
            emit({"variant": variant, "error": str(e).splitlines()[0] if str(e) else repr(e)})
            continue
        for threads in [int(t) for t in args.threads.split(",")]:
            if threads == 1:
                os.sched_setaffinity(0, {min(all_cores)})
                dr.set_thread_count(2)
            else:
                os.sched_setaffinity(0, all_cores)
                dr.set_thread_count(threads)
            for arg in args.scenes:
                path, params = parse_scene(arg)
                scene = mi.load_file(path, **params)
                compile_s = time_render(mi, dr, scene, args.spp, 0)
                render_s = min(time_render(mi, dr, scene, args.spp, seed) for seed in range(1, args.repeat + 1))
                film = scene.sensors()[0].film()
                size = film.crop_size()
                emit({
                    "scene": arg,
                    "variant": variant,
                    "threads": threads,
                    "compile_s": compile_s,
                    "render_s": render_s,
                    "samples": int(size[0]) * int(size[1]) * args.spp,
                })
        os.sched_setaffinity(0, all_cores)


if __name__ == "__main__":
    sys.exit(main())
