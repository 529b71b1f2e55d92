#!/usr/bin/env python3
"""Renders a Mitsuba 3 scene K times with independent seeds (variant
scalar_rgb) and writes the per-pixel mean and the variance of that mean.

    mitsuba_render.py SCENE.xml --spp N --renders K --out PREFIX [-D name=value ...]

writes PREFIX-mean.pfm and PREFIX-var.pfm (3-channel little-endian PFM,
linear RGB): mean = (1/K) sum_k x_k, var = sample variance of the x_k / K.
Used by tests/integration/mitsuba_conformance.rs; needs only the mitsuba wheel (no
numpy). Seeds are 1, 3, 5, ...: in scalar variants Mitsuba seeds pixel i of
block b with seed * W * H + b * B * B + i (B = block size), so the blocks of
seed s can reach into seed s + 1's range when the image is not a multiple
of B; odd seeds two apart never overlap for films of at least B x B pixels.
"""

import argparse
import struct
import sys
import time


def write_pfm(path, width, height, data):
    """data: row-major from the top row, 3 floats per pixel."""
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (width, height))
        for y in reversed(range(height)):
            row = data[3 * width * y : 3 * width * (y + 1)]
            f.write(struct.pack("<%df" % len(row), *row))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--renders", type=int, required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("-D", action="append", default=[], metavar="NAME=VALUE")
    args = ap.parse_args()
    if args.renders < 2:
        sys.exit("need at least 2 renders to estimate a variance")

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    params = {"spp": args.spp}
    for d in args.D:
        name, _, value = d.partition("=")
        params[name] = value
    t0 = time.time()
    scene = mi.load_file(args.scene, **params)
    t1 = time.time()

    n = args.renders
    mean = None
    m2 = None
    width = height = 0
    for k in range(n):
        img = mi.render(scene, seed=2 * k + 1)
        height, width, channels = img.shape
        if channels < 3:
            sys.exit("expected an RGB film, found %d channels" % channels)
        flat = list(img.array)
        vals = [flat[i * channels + c] for i in range(width * height) for c in range(3)]
        if mean is None:
            mean = [0.0] * len(vals)
            m2 = [0.0] * len(vals)
        # Welford's running mean and sum of squared deviations.
        for i, x in enumerate(vals):
            d = x - mean[i]
            mean[i] += d / (k + 1)
            m2[i] += d * (x - mean[i])
    t2 = time.time()
    var_of_mean = [m / ((n - 1) * n) for m in m2]
    write_pfm(args.out + "-mean.pfm", width, height, mean)
    write_pfm(args.out + "-var.pfm", width, height, var_of_mean)
    print(
        "mitsuba %s: %dx%d, %d renders x %d spp, load %.2f s, render %.2f s"
        % (mi.__version__, width, height, n, args.spp, t1 - t0, t2 - t1)
    )


if __name__ == "__main__":
    main()
