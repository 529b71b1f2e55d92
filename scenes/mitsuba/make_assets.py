#!/usr/bin/env python3
"""Writes gem.ply (an icosahedron subdivided once: 42 vertices, 80
triangles, binary little-endian) for envmap.xml.

sky.pfm is lente's procedural sky, baked with:
    cargo run --release --example bake_sky -- scenes/mitsuba/sky.pfm 3 35 150 128
"""
import math
import struct

t = (1 + 5 ** 0.5) / 2
verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
         (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
         (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
         (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]

def norm(v):
    l = math.sqrt(sum(c * c for c in v))
    return tuple(c / l for c in v)

verts = [norm(v) for v in verts]
cache = {}

def midpoint(a, b):
    key = (min(a, b), max(a, b))
    if key not in cache:
        m = norm(tuple((x + y) / 2 for x, y in zip(verts[a], verts[b])))
        verts.append(m)
        cache[key] = len(verts) - 1
    return cache[key]

sub = []
for a, b, c in faces:
    ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
    sub += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]

with open("gem.ply", "wb") as f:
    f.write(("ply\nformat binary_little_endian 1.0\n"
             "comment an icosahedron subdivided once, for envmap.xml\n"
             f"element vertex {len(verts)}\n"
             "property float x\nproperty float y\nproperty float z\n"
             f"element face {len(sub)}\n"
             "property list uchar int vertex_indices\nend_header\n").encode())
    for v in verts:
        f.write(struct.pack("<3f", *v))
    for tri in sub:
        f.write(struct.pack("<B3i", 3, *tri))
