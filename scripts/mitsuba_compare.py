#!/usr/bin/env python3
"""lente against Mitsuba 3, side by side, on light sampling.

Renders Mitsuba 3 XML scenes with lente and with Mitsuba 3 (variants
scalar_rgb and llvm_ad_rgb) at equal spp over several seeds, and prints per
scene: the MSE against a high-spp reference (mean over seeds), samples per
second, and the ratios, including equal-time efficiency (MSE x render
time: what halving the error costs). Optionally the same for an older lente
build in the same run (`--base-rev`), for before/after figures on the same
machine. Two sets of scenes:

  envmap  bench/envmap/: probes with a sun, a studio, a sunset over a rough
          conductor, a thin lens under a forest probe
  lights  bench/lights/ and the Cornell box: Veach's MIS scene (with the
          lights seen, and hidden), a big light near a floor, the box

Run it with the Python that has the mitsuba wheel (.ci/run makes one):

    target/mitsuba-venv/bin/python scripts/mitsuba_compare.py [--set envmap]
        [--spp 64] [--seeds 8] [--ref-spp 4096] [--threads 2]
        [--base-rev REV] [--scenes sun_sky,studio] [--probes DIR]
        [--sampler ldsampler]

The probes are read from ../shared/data/envmaps/ (CC0 Poly Haven maps; see
its README) or --probes. The reference is Mitsuba's llvm_ad_rgb (scalar_rgb
without LLVM) at --ref-spp, cached under target/mitsuba-compare/. Mitsuba's
LLVM variant needs libLLVM (DRJIT_LIBLLVM_PATH; Debian's libllvm19 works,
LLVM 15 aborts); without it that column is left out. Mitsuba is timed warm:
one render of each scene compiles its kernels before the timed ones. Times
are of the render alone for both (lente's own report; Mitsuba's render and
evaluation), without loading the scene. The renders run seed by seed, every
renderer in turn, so that a slow spell of a shared machine (their speed
drifted by 20% between runs on the 2-core VM) falls on all of them; the
intervals resample the seeds' errors and times together.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "target", "mitsuba-compare")

# name -> (set, file relative to the repository, extra scene parameters)
SCENES = {
    "sun_sky": ("envmap", "bench/envmap/sun_sky.xml", {}),
    "sun_sky_turned": ("envmap", "bench/envmap/sun_sky.xml", {"angle": "130", "scale": "0.5"}),
    "studio": ("envmap", "bench/envmap/studio.xml", {}),
    "sunset_metal": ("envmap", "bench/envmap/sunset_metal.xml", {}),
    "thinlens_forest": ("envmap", "bench/envmap/thinlens_forest.xml", {}),
    "veach_mis": ("lights", "bench/lights/veach_mis.xml", {}),
    "veach_mis_hidden": ("lights", "bench/lights/veach_mis.xml", {"hide": "true"}),
    "near_light": ("lights", "bench/lights/near_light.xml", {}),
    "cbox": ("lights", "scenes/mitsuba/cbox.xml", {"res": "128"}),
}

LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM.so",
]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def build_lente(rev):
    """Builds lente at `rev` (None: the working tree); returns the binary."""
    if rev is None:
        subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
        return os.path.join(ROOT, "target", "release", "lente")
    # The worktree lives outside the repository: inside it, cargo would take
    # today's Cargo.toml for the workspace of an older revision's package
    # and refuse to build it.
    work = tempfile.mkdtemp(prefix="lente-base-")
    tree = os.path.join(work, "tree")
    subprocess.run(["git", "worktree", "add", "--quiet", "--detach", tree, rev], cwd=ROOT, check=True)
    try:
        env = dict(os.environ, CARGO_TARGET_DIR=os.path.join(OUT, "base-target"))
        subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=tree, env=env, check=True)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", tree], cwd=ROOT)
        shutil.rmtree(work, ignore_errors=True)
    return os.path.join(OUT, "base-target", "release", "lente")


def image_values(mi, path):
    """Linear RGB floats of an image file, row-major. lente's render files
    hold more channels than R, G, B (the film state, AOVs): the image is
    their root layer."""
    bmp = mi.Bitmap(path)
    if bmp.channel_count() > 4:
        bmp = dict(bmp.split())["<root>"]
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    return list(mi.TensorXf(bmp).array)


def mse(a, b):
    return sum((x - y) ** 2 for x, y in zip(a, b)) / len(a)


def bootstrap(runs_l, runs_o, resamples=4000):
    """90% bootstrap intervals of the MSE ratio and of the efficiency ratio
    (other's MSE x time over lente's) of two renderers' per-seed (MSE,
    seconds) runs, resampling the seeds (the same draw for both: their runs
    of one seed ran side by side, so a slow spell of the machine hits both).
    On scenes whose error sits in a few pixels (a directly seen sun, a
    defocused highlight) the per-seed MSE is heavy-tailed, and a ratio from
    a few seeds can be off by half: the intervals say how far."""
    import random
    rng = random.Random(12345)
    n = len(runs_l)
    mses, effs = [], []
    for _ in range(resamples):
        idx = [rng.randrange(n) for _ in range(n)]
        ml = sum(runs_l[i][0] for i in idx)
        mo = sum(runs_o[i][0] for i in idx)
        tl = sum(runs_l[i][1] for i in idx)
        to = sum(runs_o[i][1] for i in idx)
        mses.append(ml / mo if mo > 0 else float("inf"))
        effs.append((mo * to) / (ml * tl) if ml * tl > 0 else float("inf"))
    lo, hi = int(0.05 * resamples), int(0.95 * resamples) - 1
    mses.sort()
    effs.sort()
    return (mses[lo], mses[hi]), (effs[lo], effs[hi])


def lente_run(binary, scene, params, spp, seed, threads):
    """(image file, render seconds) of one lente render."""
    # One file per seed and build: the MSE is taken afterwards.
    out = os.path.join(OUT, "lente-run-%d-%s" % (seed, os.path.basename(os.path.dirname(os.path.dirname(binary)))))
    cmd = [binary, "render", scene, "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads), "-q", "-o", out]
    for k, v in params.items():
        cmd += ["-D", "%s=%s" % (k, v)]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit("lente failed on %s:\n%s" % (scene, res.stderr))
    m = re.search(r"spp, \d+ threads?, ([0-9.]+) s,", res.stdout)
    if not m:
        sys.exit("cannot read lente's render time from:\n" + res.stdout)
    return out + ".exr", float(m.group(1))


def mitsuba_run(mi, dr, scene, spp, seed):
    """(image as a flat list, render seconds) of one warm Mitsuba render."""
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return list(img.array), time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--base-rev", help="also measure lente built at this git revision")
    ap.add_argument("--set", choices=["envmap", "lights", "all"], default="envmap")
    ap.add_argument("--scenes", help="comma-separated scene names (default: those of --set)")
    ap.add_argument("--sampler", choices=["independent", "stratified", "multijitter", "ldsampler", "orthogonal"],
                    help="render the scenes with this Mitsuba sampler (their $sampler; default: independent)."
                         " Non-square counts are rounded up as Mitsuba rounds them, by both renderers")
    ap.add_argument("--probes", default=os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "envmaps")))
    args = ap.parse_args()

    names = args.scenes.split(",") if args.scenes else [
        n for n, (group, _, _) in SCENES.items() if args.set in (group, "all")]
    for n in names:
        if n not in SCENES:
            sys.exit("unknown scene %s (known: %s)" % (n, ", ".join(SCENES)))
    needs_probes = any(SCENES[n][0] == "envmap" for n in names)
    if needs_probes and not os.path.isfile(os.path.join(args.probes, "sky.hdr")):
        sys.exit("no probes in %s (pass --probes DIR with sky.hdr, studio.hdr, sunset.hdr, forest.hdr)" % args.probes)
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        for c in LLVM_CANDIDATES:
            if os.path.exists(c):
                os.environ["DRJIT_LIBLLVM_PATH"] = c
                break
    import drjit as dr
    import mitsuba as mi

    variants = ["scalar_rgb"]
    try:
        mi.set_variant("llvm_ad_rgb")
        variants.append("llvm_ad_rgb")
        dr.set_thread_count(args.threads)
    except Exception as e:  # no LLVM
        log("llvm_ad_rgb unavailable (%s): left out" % e)
    os.makedirs(OUT, exist_ok=True)

    log("building lente")
    lente = build_lente(None)
    builds = [("lente", lente)]
    if args.base_rev:
        log("building lente at %s" % args.base_rev)
        builds.append(("lente@" + args.base_rev, build_lente(args.base_rev)))

    seeds = list(range(1, args.seeds + 1))
    rows = []
    for name in names:
        group, file, extra = SCENES[name]
        scene_path = os.path.join(ROOT, file)
        params = dict(extra, probes=args.probes) if group == "envmap" else dict(extra)
        # Reference.
        ref_variant = variants[-1]
        ref_path = os.path.join(OUT, "ref-%s-%d-%s.exr" % (name, args.ref_spp, ref_variant))
        mi.set_variant(ref_variant)
        if not os.path.exists(ref_path):
            log("%s: reference, %s at %d spp" % (name, ref_variant, args.ref_spp))
            scene = mi.load_file(scene_path, **params)
            img = mi.render(scene, spp=args.ref_spp, seed=10_000)
            mi.Bitmap(img).write(ref_path)
        ref = image_values(mi, ref_path)
        pixels = len(ref) // 3
        row = {"scene": name, "samples": pixels * args.spp}
        # The sampler only for the timed renders: the reference is the same
        # image in expectation, and its cache is shared.
        if args.sampler:
            params = dict(params, sampler=args.sampler)
        # Mitsuba's scenes, one per variant, each rendered once to compile
        # its kernels before the timed renders.
        scenes = {}
        for v in variants:
            mi.set_variant(v)
            if v != "scalar_rgb":
                dr.set_thread_count(args.threads)
            scenes[v] = mi.load_file(scene_path, **dict(params, spp=args.spp))
            mitsuba_run(mi, dr, scenes[v], args.spp, 0)
        # Seed by seed, every renderer in turn (the order turning with the
        # seed), so that a slow spell of the machine does not fall on one
        # renderer's runs only.
        renderers = list(builds) + [(v, None) for v in variants]
        runs = {label: [] for label, _ in renderers}
        log("%s: %d seeds x %s" % (name, len(seeds), ", ".join(l for l, _ in renderers)))
        for k, seed in enumerate(seeds):
            for label, binary in renderers[k % len(renderers):] + renderers[:k % len(renderers)]:
                if binary is not None:
                    f, secs = lente_run(binary, scene_path, params, args.spp, seed, args.threads)
                    runs[label].append((mse(image_values(mi, f), ref), secs))
                else:
                    mi.set_variant(label)
                    img, secs = mitsuba_run(mi, dr, scenes[label], args.spp, seed)
                    runs[label].append((mse(img, ref), secs))
        row.update(runs)
        del scenes
        rows.append(row)

    labels = [b[0] for b in builds] + variants
    print("\n%d x %d spp per renderer and scene (seeds 1..%d), %d threads; reference: Mitsuba %s at %d spp"
          % (len(seeds), args.spp, len(seeds), args.threads, variants[-1], args.ref_spp))
    print("MSE: mean over seeds of the per-render MSE against the reference; efficiency: 1 / (MSE x time),"
          " as a ratio lente / other (> 1: lente reaches the same error sooner); in brackets, 90%"
          " bootstrap intervals over the seeds\n")
    head = ["scene"] + ["%s MSE" % l for l in labels] + ["%s Msamples/s" % l for l in labels]
    others = labels[1:]
    head += ["MSE lente/%s" % o for o in others] + ["efficiency lente/%s" % o for o in others]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    geo = {o: [1.0, 1.0, 0] for o in others}
    mean = lambda xs: sum(xs) / len(xs)
    for r in rows:
        pixels_samples = r["samples"]
        cells = [r["scene"]]
        cells += ["%.3e" % mean([m for m, _ in r[l]]) for l in labels]
        speed = {l: pixels_samples * len(r[l]) / sum(t for _, t in r[l]) for l in labels}
        cells += ["%.2f" % (speed[l] / 1e6) for l in labels]
        ml = mean([m for m, _ in r["lente"]])
        intervals = {o: bootstrap(r["lente"], r[o]) for o in others}
        for o in others:
            (lo, hi), _ = intervals[o]
            cells.append("%.2f [%.2f, %.2f]" % (ml / mean([m for m, _ in r[o]]), lo, hi))
        for o in others:
            mo = mean([m for m, _ in r[o]])
            eff = (mo / speed[o]) / (ml / speed["lente"])  # (MSE x time per sample) ratio
            _, (lo, hi) = intervals[o]
            cells.append("%.2f [%.2f, %.2f]" % (eff, lo, hi))
            geo[o][0] *= ml / mo
            geo[o][1] *= eff
            geo[o][2] += 1
        print("| " + " | ".join(cells) + " |")
    for o in others:
        n = geo[o][2]
        print("geometric mean vs %s: MSE ratio %.2f, efficiency ratio %.2f"
              % (o, geo[o][0] ** (1 / n), geo[o][1] ** (1 / n)))


if __name__ == "__main__":
    main()
