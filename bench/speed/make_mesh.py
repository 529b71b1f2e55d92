#!/usr/bin/env python3
"""Writes blob.ply: a bumpy closed sphere of 102,400 triangles (binary PLY),
the >= 100k-triangle mesh of the speed suite (`lente bench`): big enough
that traversal, not shading, decides its speed. Deterministic; no numpy."""

import math
import os
import struct

RINGS, SEGMENTS = 161, 320  # 2 * SEGMENTS * (RINGS - 1) = 102,400 triangles


def radius(theta, phi):
    return 1.0 + 0.06 * math.sin(7 * phi) * math.sin(5 * theta) + 0.03 * math.sin(23 * phi + 11 * theta)


def main():
    verts = [(0.0, radius(0.0, 0.0), 0.0)]  # north pole
    for i in range(1, RINGS):
        theta = math.pi * i / RINGS
        for j in range(SEGMENTS):
            phi = 2 * math.pi * j / SEGMENTS
            r = radius(theta, phi)
            verts.append((r * math.sin(theta) * math.cos(phi), r * math.cos(theta), r * math.sin(theta) * math.sin(phi)))
    verts.append((0.0, -radius(math.pi, 0.0), 0.0))  # south pole
    south = len(verts) - 1

    def ring(i, j):
        return 1 + (i - 1) * SEGMENTS + j % SEGMENTS

    faces = []
    for j in range(SEGMENTS):
        faces.append((0, ring(1, j + 1), ring(1, j)))
        faces.append((south, ring(RINGS - 1, j), ring(RINGS - 1, j + 1)))
    for i in range(1, RINGS - 1):
        for j in range(SEGMENTS):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            faces.append((a, b, c))
            faces.append((a, c, d))
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blob.ply")
    with open(path, "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\ncomment lente bench/speed/make_mesh.py\n")
        f.write(b"element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
        f.write(b"element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
        for v in verts:
            f.write(struct.pack("<3f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))
    print("wrote %s: %d vertices, %d triangles" % (path, len(verts), len(faces)))


if __name__ == "__main__":
    main()
