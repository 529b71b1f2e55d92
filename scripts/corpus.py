#!/usr/bin/env python3
"""Real scenes as users have them: which ones lente loads and renders, and
whether its images match Mitsuba 3's.

Point it at folders of scene files (clones of public repositories: Mitsuba
3's mitsuba-data, students' Nori forks, ...). For every XML file whose root
is <scene> it records:

  lente     `lente info` loads it (the first error line if not), and a
            1-spp render at a small size writes an image;
  mitsuba   (Mitsuba-dialect files, when this Python has the mitsuba
            wheel) Mitsuba 3.9.1's scalar_rgb loads it;
  match     (--compare, files both load) the two renderers' images agree
            statistically, see below.

Files whose root is <test> are Nori test files (`lente test`), counted
apart; files that name a mesh, image or include that is not in the folder
(large files a mirror left out) are counted as "asset missing", for both
renderers alike.

The statistic. Each renderer renders the scene K times (--renders) with
independent seeds at --spp samples, at --width pixels across (a copy of the
file with its film's width and height changed, next to it, read by both).
The image is cut into 8 x 8 blocks; per block and channel, each render
gives one block mean, so the K renders give a mean and its standard error
for each renderer, whatever the pixel filter correlates within a render.
Welch's t of the difference, with its Welch-Satterthwaite degrees of
freedom, is turned into a two-sided p-value; a scene fails when its
smallest p-value is below the Sidak-corrected level 1 - (1 - 0.01)^(1/m)
for its m block-channels: a 1% false-alarm rate per scene. Scenes whose
images have fewer than 4 blocks, or no light at all, are reported as such.

Two things make a "DIFFER" that is not a bug. Heavy-tailed images (small
bright lights found by BSDF sampling alone) break the t-test's normality at
16 spp: rerun with --spp 256, where mitsuba-data's integrator_direct_*
scenes match. And Mitsuba's scalar variants splat through a filter
tabulated in 31 bins (`eval_discretized`), its JIT variants and lente
through the exact one: their filter tails differ beside sharp edges (the
projector test scenes, 0.01% of the mean); --variant llvm_ad_rgb compares
with the exact filter.

Usage (the Python with the mitsuba wheel; .ci/run makes one):

    target/mitsuba-venv/bin/python scripts/corpus.py DIR... [--compare]
        [--renders 16] [--spp 16] [--width 96] [--only TEXT]
        [--variant scalar_rgb|llvm_ad_rgb]
        [--lente target/release/lente] [--out target/corpus]

It prints one line per file and a summary per folder, and writes the same
as Markdown to OUT/report.md.
"""

import argparse
import math
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

MISSING = re.compile(
    r"No such file or directory|cannot read the included file|does not exist|"
    r"cannot find|not found", re.I)


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def root_tag(text):
    """The root element's name, skipping declarations and comments."""
    text = re.sub(r"<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^>]*>", "", text, flags=re.S)
    m = re.search(r"<\s*([A-Za-z_][\w.-]*)", text)
    return m.group(1) if m else None


def dialect(text):
    """Nori when the file uses Nori's object tags (<mesh>, <camera>) and
    none of Mitsuba's, whatever its version attribute says (students copy
    one into Nori files); Mitsuba when it has Mitsuba's tags or a version."""
    mitsuba_tags = re.search(r"<\s*(shape|sensor|film)\b", text)
    if re.search(r"<\s*(mesh|camera)\b", text) and not mitsuba_tags:
        return "nori"
    if mitsuba_tags or re.search(r"<\s*scene\s[^>]*version\s*=", text):
        return "mitsuba"
    return "nori"


def first_error(stderr):
    for line in stderr.splitlines():
        if line.startswith("error"):
            return line
    lines = [l for l in stderr.splitlines() if l.strip()]
    return lines[-1] if lines else "(no message)"


def lente_load(lente, path, out):
    """(ok, message, (width, height) or None): info, then a tiny render."""
    res = subprocess.run([lente, "info", path], capture_output=True, text=True, timeout=600)
    if res.returncode != 0:
        return False, first_error(res.stderr), None
    m = re.search(r"^image\s+(\d+)x(\d+)", res.stdout, re.M)
    size = (int(m.group(1)), int(m.group(2))) if m else None
    res_arg = []
    if size:
        w = min(size[0], 48)
        res_arg = ["--resolution", "%dx%d" % (w, max(1, round(size[1] * w / size[0])))]
    res = subprocess.run(
        [lente, "render", path, "--spp", "1", "-q", "-o", out] + res_arg,
        capture_output=True, text=True, timeout=600)
    if res.returncode != 0 or not os.path.exists(out + ".exr"):
        return False, "render: " + first_error(res.stderr), size
    return True, "", size


MITSUBA_LOAD = """
import sys, mitsuba as mi
mi.set_variant('scalar_rgb')
mi.set_log_level(mi.LogLevel.Error)
try:
    mi.load_file(sys.argv[1])
except Exception as e:
    print(str(e).strip().splitlines()[-1] if str(e).strip() else repr(e))
    sys.exit(1)
"""


def mitsuba_load(path):
    try:
        res = subprocess.run([sys.executable, "-c", MITSUBA_LOAD, path],
                             capture_output=True, text=True, timeout=600)
    except subprocess.TimeoutExpired:
        return False, "timed out"
    if res.returncode != 0:
        msg = (res.stdout.strip() or res.stderr.strip() or "crashed").splitlines()[-1]
        return False, msg[:200]
    return True, ""


def resized_copy(path, width, size):
    """A copy of the scene next to it whose film is `width` pixels wide
    (the height keeps the aspect): the film is resized in the file, or in
    a copy of the included file that holds it (the copy of the scene then
    includes that). Returns (copy, extra copies), or None when no film is
    found."""
    if size is None:
        return None
    height = max(1, round(size[1] * width / size[0]))

    def resize(film):
        found = set()
        for el in film.findall("integer"):
            if el.get("name") in ("width", "height"):
                el.set("value", str(width if el.get("name") == "width" else height))
                found.add(el.get("name"))
        for name, value in (("width", width), ("height", height)):
            if name not in found:
                ET.SubElement(film, "integer", name=name, value=str(value))

    def copy_name(p):
        return os.path.join(os.path.dirname(p), ".corpus-" + os.path.basename(p))

    tree = ET.parse(path)
    film = tree.getroot().find(".//film")
    extra = []
    if film is not None:
        resize(film)
    else:
        for inc in tree.getroot().iter("include"):
            name = inc.get("filename", "")
            inc_path = os.path.join(os.path.dirname(path), name)
            if "$" in name or not os.path.exists(inc_path):
                continue
            inc_tree = ET.parse(inc_path)
            inc_film = inc_tree.getroot().find(".//film")
            if inc_film is None:
                continue
            resize(inc_film)
            inc_tree.write(copy_name(inc_path))
            extra.append(copy_name(inc_path))
            inc.set("filename", os.path.join(os.path.dirname(name), ".corpus-" + os.path.basename(name)))
            break
        if not extra:
            return None
    tree.write(copy_name(path))
    return copy_name(path), extra


# --- Student's t tail, for Welch's test ------------------------------------

def _betacf(a, b, x):
    """Continued fraction of the incomplete beta function (Lentz)."""
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 300):
        m2 = 2 * m
        aa = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c if abs(c) > tiny else 1.0 + aa / tiny
        h *= d * c
        aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c if abs(c) > tiny else 1.0 + aa / tiny
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-14:
            break
    return h


def betai(a, b, x):
    """The regularized incomplete beta function I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    ln = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
          + a * math.log(x) + b * math.log(1.0 - x))
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(ln) * _betacf(a, b, x) / a
    return 1.0 - math.exp(ln) * _betacf(b, a, 1.0 - x) / b


def t_two_sided_p(t, df):
    return betai(df / 2.0, 0.5, df / (df + t * t))


# --- Comparison -------------------------------------------------------------

def block_means(np, img, block=8):
    h, w, _ = img.shape
    bh, bw = h // block, w // block
    img = img[: bh * block, : bw * block, :3]
    return img.reshape(bh, block, bw, block, 3).mean(axis=(1, 3))


def compare(np, mi, lente, copy, renders, spp, out):
    lente_blocks, mitsuba_blocks = [], []
    for seed in range(renders):
        o = os.path.join(out, "lente-%d" % seed)
        res = subprocess.run([lente, "render", copy, "--spp", str(spp), "--seed", str(seed),
                              "-q", "-o", o], capture_output=True, text=True, timeout=3600)
        if res.returncode != 0:
            return "lente render failed: " + first_error(res.stderr)
        bmp = mi.Bitmap(o + ".exr")
        if bmp.channel_count() > 4:
            bmp = dict(bmp.split())["<root>"]
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
        lente_blocks.append(block_means(np, np.array(bmp)))
    scene = mi.load_file(copy)
    for seed in range(renders):
        img = np.array(mi.render(scene, spp=spp, seed=seed + 1000))
        mitsuba_blocks.append(block_means(np, img))
    a, b = np.array(lente_blocks), np.array(mitsuba_blocks)
    if a.shape != b.shape:
        return "image sizes differ: lente %s, Mitsuba %s" % (a.shape[1:], b.shape[1:])
    if a.shape[1] * a.shape[2] < 4:
        return "too small to compare"
    ma, mb = a.mean(axis=0), b.mean(axis=0)
    if max(abs(ma).max(), abs(mb).max()) == 0:
        return "black in both"
    va, vb = a.var(axis=0, ddof=1) / renders, b.var(axis=0, ddof=1) / renders
    floor = (1e-4 * np.maximum(abs(ma), abs(mb))) ** 2 + 1e-12
    se2 = va + vb + floor
    t = (ma - mb) / np.sqrt(se2)
    df = se2 ** 2 / ((va + floor / 2) ** 2 / (renders - 1) + (vb + floor / 2) ** 2 / (renders - 1))
    m = t.size
    level = 1.0 - (1.0 - 0.01) ** (1.0 / m)
    pmin, worst = 1.0, 0.0
    for tv, dv in zip(t.ravel(), df.ravel()):
        p = t_two_sided_p(float(tv), max(float(dv), 1.0))
        if p < pmin:
            pmin, worst = p, float(tv)
    rel = float(abs(ma.sum() - mb.sum()) / max(abs(mb.sum()), 1e-12))
    verdict = "match" if pmin >= level else "DIFFER"
    return "%s (min p %.2g, Sidak level %.2g over %d, |t| %.1f, mean differs %.2f%%)" % (
        verdict, pmin, level, m, abs(worst), 100 * rel)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--lente", default=os.path.join(ROOT, "target", "release", "lente"))
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "corpus"))
    ap.add_argument("--compare", action="store_true")
    ap.add_argument("--renders", type=int, default=16)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--variant", default="scalar_rgb",
                    help="Mitsuba variant that renders for --compare (llvm_ad_rgb needs "
                         "DRJIT_LIBLLVM_PATH, e.g. Debian's libLLVM-19.so)")
    ap.add_argument("--only", default="",
                    help="only files whose path contains this text (comma-separated: any)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    try:
        import mitsuba as mi
        import numpy as np
        mi.set_variant(args.variant)
        mi.set_log_level(mi.LogLevel.Error)
    except ImportError:
        mi = np = None
        log("no mitsuba wheel in this Python: Mitsuba columns left out")

    rows = []  # (folder, file, dialect, lente, mitsuba, match)
    for top in args.dirs:
        files = []
        for d, _, names in os.walk(top):
            files += [os.path.join(d, n) for n in names
                      if n.endswith(".xml") and not n.startswith(".corpus-")]
        for path in sorted(files):
            if args.only and not any(o in path for o in args.only.split(",")):
                continue
            try:
                text = open(path, encoding="utf-8", errors="replace").read()
            except OSError:
                continue
            tag = root_tag(text)
            if tag not in ("scene", "test"):
                continue
            rel = os.path.relpath(path, top)
            if tag == "test":
                rows.append((top, rel, "nori test", "-", "-", "-"))
                continue
            kind = dialect(text)
            ok, msg, size = lente_load(args.lente, path, os.path.join(args.out, "tiny"))
            lente_col = "ok" if ok else ("asset missing: " if MISSING.search(msg) else "FAIL: ") + msg
            mits_col, match_col = "-", "-"
            if kind == "mitsuba" and mi is not None:
                mok, mmsg = mitsuba_load(path)
                mits_col = "ok" if mok else (
                    "asset missing: " if MISSING.search(mmsg) else "fails: ") + mmsg
                if ok and mok and args.compare:
                    copies = resized_copy(path, args.width, size)
                    if copies is None:
                        match_col = "not compared: no film found to resize"
                    else:
                        try:
                            match_col = compare(np, mi, args.lente, copies[0], args.renders,
                                                args.spp, args.out)
                        except Exception as e:  # a failed render is a finding
                            match_col = "compare failed: %s" % str(e).splitlines()[-1][:150]
                        finally:
                            for c in [copies[0]] + copies[1]:
                                os.remove(c)
            row = (top, rel, kind, lente_col, mits_col, match_col)
            rows.append(row)
            print("%-8s %-60s lente: %s | mitsuba: %s | %s" % (kind, rel, lente_col[:90],
                                                               mits_col[:60], match_col),
                  flush=True)

    lines = ["| folder | files | lente loads | Mitsuba files | Mitsuba loads | both load | "
             "compared | match | Nori files | Nori asset missing |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for top in args.dirs:
        rs = [r for r in rows if r[0] == top and r[2] != "nori test"]
        mits = [r for r in rs if r[2] == "mitsuba"]
        nori = [r for r in rs if r[2] == "nori"]
        both = [r for r in mits if r[3] == "ok" and r[4] == "ok"]
        compared = [r for r in both if r[5].startswith(("match", "DIFFER"))]
        lines.append("| %s | %d | %d | %d | %d | %d | %d | %d | %d | %d |" % (
            os.path.basename(os.path.normpath(top)), len(rs),
            sum(r[3] == "ok" for r in rs), len(mits), sum(r[4] == "ok" for r in mits),
            len(both), len(compared), sum(r[5].startswith("match") for r in compared),
            len(nori), sum(r[3].startswith("asset missing") for r in nori)))
    lines += ["", "| file | dialect | lente | Mitsuba | comparison |", "| --- | --- | --- | --- | --- |"]
    lines += ["| %s | %s | %s | %s | %s |" % (os.path.join(os.path.basename(os.path.normpath(r[0])), r[1]),
                                          r[2], r[3].replace("|", "/"), r[4].replace("|", "/"),
                                          r[5]) for r in rows]
    report = os.path.join(args.out, "report.md")
    with open(report, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines[:2 + len(args.dirs)]))
    log("report: " + report)


if __name__ == "__main__":
    main()
