#!/usr/bin/env python3
"""How much Mitsuba 3's LLVM variant owes to its SIMD width on this CPU.

    python scripts/llvm_lanes.py 8,4,8,4 SCENE[::NAME=VALUE,...]...

Dr.Jit compiles every kernel to the CPU's widest vectors (8 float lanes
with AVX2, 16 with AVX-512F). This script renders each scene with
`llvm_ad_rgb` at each given vector width in turn (Dr.Jit's
`jit_llvm_set_target`, same CPU and features), on one core (two workers
pinned to it, as scripts/mitsuba_bench.py does), 64 spp, warm, best of 3,
and prints one JSON line per width and scene with M samples/s. Comparing 4
with 8 lanes on an AVX2 CPU bounds what 16 lanes could give Dr.Jit on an
AVX-512 one, which `lente bench` cannot measure where there is none.
"""

import ctypes
import json
import os
import sys

from mitsuba_bench import parse_scene, time_render, use_libllvm

use_libllvm()
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    mi.set_variant("llvm_ad_rgb")
    core = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    # The C++ entry points of drjit-core (no Python binding for them).
    target_cpu = core._Z19jit_llvm_target_cpuv
    target_features = core._Z24jit_llvm_target_featuresv
    vector_width = core._Z21jit_llvm_vector_widthv
    set_target = core._Z19jit_llvm_set_targetPKcS0_j
    target_cpu.restype = target_features.restype = ctypes.c_char_p
    vector_width.restype = ctypes.c_uint32
    cpu, features = target_cpu(), target_features()
    print(json.dumps({"cpu": cpu.decode(), "default_width": vector_width()}), flush=True)
    # Pinned before the pool is resized, so that its workers inherit the
    # one core (pinning after it leaves them free to use every core).
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    dr.set_thread_count(2)
    for width in [int(w) for w in sys.argv[1].split(",")]:
        set_target(cpu, features, ctypes.c_uint32(width))
        for arg in sys.argv[2:]:
            path, params = parse_scene(arg)
            scene = mi.load_file(path, **params)
            compile_s = time_render(mi, dr, scene, 64, 0)
            best = min(time_render(mi, dr, scene, 64, seed) for seed in range(1, 4))
            w, h = scene.sensors()[0].film().crop_size()
            print(json.dumps({
                "width": vector_width(),
                "scene": arg,
                "compile_s": round(compile_s, 2),
                "M_samples_per_s": round(int(w) * int(h) * 64 / best / 1e6, 3),
            }), flush=True)


if __name__ == "__main__":
    main()
