#!/usr/bin/env python3
"""Writes the showcase stand (run from this folder): column.obj and base.obj.

The stand is a slender column on a wide, low round base, both closed
cylinders centred on the y axis with the base's bottom at y = 0:

  base    radius 2.6, height 0.4      (y from 0 to 0.4)
  column  radius 0.3, height 5.6      (y from 0.4 to 6.0)

The sphere (radius 2) rests on the column top, centre at y = 8.0. Sides get
smooth normals; caps get their own vertices with flat normals, so the edges
stay crisp. Faces are counter-clockwise seen from outside.
"""
import math

SEGMENTS = 96


def cylinder(name, radius, y0, y1, segments=SEGMENTS):
    v, vn, f = [], [], []
    # Side: two rings sharing smooth normals.
    for k in range(segments):
        a = 2 * math.pi * k / segments
        x, z = radius * math.cos(a), radius * math.sin(a)
        v += [(x, y0, z), (x, y1, z)]
        vn.append((math.cos(a), 0.0, math.sin(a)))
    for k in range(segments):
        k2 = (k + 1) % segments
        b0, t0, b1, t1 = 2 * k + 1, 2 * k + 2, 2 * k2 + 1, 2 * k2 + 2
        n0, n1 = k + 1, k2 + 1
        # Outward: (b0, t0, t1, b1) is counter-clockwise seen from outside.
        f.append([(b0, n0), (t0, n0), (t1, n1), (b1, n1)])
    # Caps: a centre vertex and their own ring, flat normals.
    for y, ny in ((y1, 1.0), (y0, -1.0)):
        vn.append((0.0, ny, 0.0))
        n = len(vn)
        centre = len(v) + 1
        v.append((0.0, y, 0.0))
        ring = len(v) + 1
        for k in range(segments):
            a = 2 * math.pi * k / segments
            v.append((radius * math.cos(a), y, radius * math.sin(a)))
        for k in range(segments):
            a, b = ring + k, ring + (k + 1) % segments
            tri = [(centre, n), (b, n), (a, n)] if ny > 0 else [(centre, n), (a, n), (b, n)]
            f.append(tri)
    lines = [f"# {name}: closed cylinder r={radius}, y in [{y0}, {y1}], {segments} segments",
             f"o {name}"]
    lines += ["v %.6f %.6f %.6f" % p for p in v]
    lines += ["vn %.6f %.6f %.6f" % n for n in vn]
    lines += ["f " + " ".join(f"{a}//{b}" for a, b in face) for face in f]
    with open(name + ".obj", "w") as out:
        out.write("\n".join(lines) + "\n")


cylinder("base", 2.6, 0.0, 0.4)
cylinder("column", 0.3, 0.4, 6.0)
