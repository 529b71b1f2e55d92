#!/usr/bin/env python3
"""Writes the small assets of the Mitsuba conformance scenes (run from any
folder; files go next to this script). Plain Python, no packages:

- icosphere.obj: a once-subdivided icosahedron (80 faces) without normals,
  so both renderers compute smooth vertex normals;
- prism.ply: a hexagonal prism, binary little-endian, with uvs and
  per-corner normals (flat sides, split vertices);
- stripes.pfm: a 32 x 16 lat-long map whose rows are all equal (it varies
  with the azimuth only; see tests/integration/mitsuba_conformance.rs for why), with a
  bright sector and a colour ramp;
- gems.serialized: Mitsuba's compressed mesh format (version 4), two
  shapes: 0 a flat triangle in single precision; 1 an octahedron in double
  precision with normals (pointing along the position: it shades smooth),
  uvs and vertex colours (read past), the one the scene uses;
- sky_rows.pfm: a 32 x 12 lat-long sky that varies with the elevation
  (zenith blue to a pale horizon, a dark ground, a bright soft sun of 2 x 2
  texels 30-45 degrees up): it shows where each renderer puts texel rows;
- tiles.png: a 16 x 8 8-bit sRGB RGB image (colour tiles and a gradient),
  the colour texture of textures.xml;
- roughness.png: an 8 x 8 8-bit greyscale image, read raw as a
  roughness (0.05 to 0.6 in bands);
- attributes.ply: a 6 x 4 grid of quads, each two triangles (Mitsuba reads
  triangles only) of one weight, on a gentle hump, binary little-endian,
  with per-vertex colours as float `r g b` and a per-face `weight_0`: the
  mesh_attribute scene's `vertex_color` and `face_weight`;
- height.png: a 32 x 32 8-bit greyscale height field (read raw) of rings
  and a ramp, the bump map of bumpmap.xml;
- normals.png: a 32 x 32 8-bit RGB normal map (read raw: colour c is the
  normal 2c - 1) of a field of round bumps, tilted up to ~50 degrees.
- smoke.vol: Mitsuba's voxel grid format (version 3, float32), 12 x 10 x 8
  voxels of one channel: three soft blobs of density up to 1 and a thin
  haze, zero at the border, with the box (-1, 0, -1) .. (1, 1.6, 1) in its
  header (read with use_grid_bbox);
- tint.vol: 6 x 5 x 4 voxels of three channels in [0.2, 0.98], a colour
  ramp per axis with a checker of darker voxels: an albedo, and a
  chromatic extinction.
"""

import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def icosphere():
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
             (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    mid = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mid:
            m = [(verts[a][i] + verts[b][i]) / 2 for i in range(3)]
            n = math.sqrt(sum(x * x for x in m))
            verts.append(tuple(x / n for x in m))
            mid[key] = len(verts) - 1
        return mid[key]

    out = []
    for a, b, c in faces:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    with open(os.path.join(HERE, "icosphere.obj"), "w") as f:
        f.write("# once-subdivided icosahedron, unit radius, no normals\n")
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % v)
        for tri in out:
            f.write("f %d %d %d\n" % tuple(i + 1 for i in tri))


def prism():
    """Hexagonal prism around +z, radius 1, z in [0, 1], outward normals."""
    n = 6
    verts = []  # (x, y, z, nx, ny, nz, u, v)
    faces = []
    ring = [(math.cos(2 * math.pi * i / n), math.sin(2 * math.pi * i / n)) for i in range(n)]
    for i in range(n):
        (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
        nx, ny = (x0 + x1) / 2, (y0 + y1) / 2
        ln = math.hypot(nx, ny)
        nx, ny = nx / ln, ny / ln
        base = len(verts)
        for (x, y, z, u, v) in [(x0, y0, 0, i / n, 0), (x1, y1, 0, (i + 1) / n, 0),
                                (x1, y1, 1, (i + 1) / n, 1), (x0, y0, 1, i / n, 1)]:
            verts.append((x, y, z, nx, ny, 0.0, u, v))
        faces.append((base, base + 1, base + 2, base + 3))
    for z, nz in [(0.0, -1.0), (1.0, 1.0)]:
        base = len(verts)
        for x, y in ring:
            verts.append((x, y, z, 0.0, 0.0, nz, (x + 1) / 2, (y + 1) / 2))
        idx = list(range(base, base + n))
        faces.append(tuple(idx if nz > 0 else idx[::-1]))
    # Triangles only (fans): every PLY reader takes those.
    tris = [(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)]
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment hexagonal prism for the lente/Mitsuba conformance check\n"
        "element vertex %d\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        "property float u\nproperty float v\n"
        "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
        % (len(verts), len(tris))
    )
    with open(os.path.join(HERE, "prism.ply"), "wb") as f:
        f.write(header.encode("ascii"))
        for v in verts:
            f.write(struct.pack("<8f", *v))
        for tri in tris:
            f.write(struct.pack("<B3i", 3, *tri))


def stripes():
    w, h = 32, 16
    row = []
    for i in range(w):
        u = (i + 0.5) / w
        r = 0.3 + 0.5 * u
        g = 0.4 + 0.3 * math.sin(2 * math.pi * u) ** 2
        b = 0.9 - 0.6 * u
        if 5 <= i <= 6:  # a bright sector, 2 texels wide
            r, g, b = 12.0, 10.0, 7.0
        row.append((r, g, b))
    with open(os.path.join(HERE, "stripes.pfm"), "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for _ in range(h):
            for px in row:
                f.write(struct.pack("<3f", *px))


def sky_rows():
    w, h = 32, 12
    rows = []
    for j in range(h):
        t = j / (h - 1)  # 0 at the zenith row, 1 at the nadir row
        row = []
        for i in range(w):
            if t < 0.5:
                k = t / 0.5
                px = (0.15 + 0.75 * k, 0.3 + 0.6 * k, 1.0 - 0.05 * k)
            else:
                k = (t - 0.5) / 0.5
                px = (0.25 - 0.2 * k, 0.2 - 0.17 * k, 0.15 - 0.13 * k)
            if j in (3, 4) and i in (9, 10):
                px = (20.0, 18.0, 14.0)
            row.append(px)
        rows.append(row)
    with open(os.path.join(HERE, "sky_rows.pfm"), "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for row in reversed(rows):  # PFM stores the bottom row first
            for px in row:
                f.write(struct.pack("<3f", *px))


def serialized():
    def shape(flags, fmt, positions, extra, tris, name):
        raw = struct.pack("<I", flags) + name + b"\0"
        raw += struct.pack("<QQ", len(positions) // 3, len(tris) // 3)
        raw += struct.pack("<%d%s" % (len(positions) + len(extra), fmt), *(positions + extra))
        raw += struct.pack("<%dI" % len(tris), *tris)
        return struct.pack("<HH", 0x041C, 4) + zlib.compress(raw)

    tri = shape(0x1000, "f", [0, 0, 0, 1, 0, 0, 0, 1, 0], [], [0, 1, 2], b"triangle")
    octa = [1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1]
    faces = [0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5]
    normals = list(octa)
    uvs = [0.5, 0.5, 0, 0.5, 0.5, 1, 0.5, 0, 1, 1, 0, 0]
    colors = [0.25] * 18
    # has normals, texcoords, colours; double precision
    gem = shape(0x2000 | 0x1 | 0x2 | 0x8, "d", octa, normals + uvs + colors, faces, b"gem")
    with open(os.path.join(HERE, "gems.serialized"), "wb") as f:
        f.write(tri + gem)
        f.write(struct.pack("<QQI", 0, len(tri), 2))


def png(name, width, height, channels, rows):
    """An 8-bit PNG (grey or RGB) from rows of byte values."""
    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    colour_type = 2 if channels == 3 else 0
    ihdr = struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw))
                + chunk(b"IEND", b""))


def tiles():
    palette = [(230, 60, 40), (40, 150, 220), (250, 210, 60), (60, 180, 90)]
    rows = []
    for y in range(8):
        row = []
        for x in range(16):
            if y < 4:
                row += palette[(x // 4 + y // 2) % 4]
            else:
                g = 20 + x * 14
                row += [g, 255 - g, 128]
        rows.append(row)
    png("tiles.png", 16, 8, 3, rows)


def roughness():
    rows = [[int(255 * (0.05 + 0.55 * (x // 2) / 3))] * 1 for x in range(8)]
    png("roughness.png", 8, 8, 1, [[r[0] for r in rows] for _ in range(8)])


def normals():
    rows = []
    for y in range(32):
        row = []
        for x in range(32):
            # h = sin(2 pi x / 16) sin(2 pi y / 16); n ~ (-dh/dx, -dh/dy, 1/k)
            a, b = 2 * math.pi * (x + 0.5) / 16, 2 * math.pi * (y + 0.5) / 16
            n = (-math.cos(a) * math.sin(b), -math.sin(a) * math.cos(b), 0.9)
            length = math.sqrt(sum(c * c for c in n))
            row += [int(round(255 * (c / length + 1) / 2)) for c in n]
        rows.append(row)
    png("normals.png", 32, 32, 3, rows)


def attributes():
    nx, ny = 6, 4
    verts = []
    for j in range(ny + 1):
        for i in range(nx + 1):
            x, y = -1.5 + 3 * i / nx, -1 + 2 * j / ny
            z = 0.3 * math.exp(-(x * x + y * y))
            r = 0.5 + 0.45 * math.sin(2.1 * x)
            g = 0.5 + 0.45 * math.cos(1.7 * y + x)
            b = 0.2 + 0.7 * (i + j) / (nx + ny)
            verts.append((x, y, z, r, g, b))
    faces = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            weight = ((i * 7 + j * 3) % 5) / 4
            faces.append(((a, a + 1, a + nx + 2), weight))
            faces.append(((a, a + nx + 2, a + nx + 1), weight))
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float r\nproperty float g\nproperty float b\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nproperty float weight_0\nend_header\n"
    )
    body = b"".join(struct.pack("<6f", *v) for v in verts)
    body += b"".join(struct.pack("<B3if", 3, *f, w) for f, w in faces)
    with open(os.path.join(HERE, "attributes.ply"), "wb") as out:
        out.write(header.encode() + body)


def height():
    rows = []
    for y in range(32):
        row = []
        for x in range(32):
            r = math.hypot(x - 15.5, y - 15.5)
            h = 0.5 + 0.35 * math.sin(r * 0.9) + 0.1 * (x / 31 - 0.5)
            row.append(int(round(255 * min(max(h, 0), 1))))
        rows.append(row)
    png("height.png", 32, 32, 1, rows)


def vol(name, res, channels, bbox, values):
    nx, ny, nz = res
    header = b"VOL" + bytes([3]) + struct.pack("<5i", 1, nx, ny, nz, channels)
    header += struct.pack("<6f", *bbox)
    with open(os.path.join(HERE, name), "wb") as out:
        out.write(header + struct.pack(f"<{len(values)}f", *values))


def smoke():
    nx, ny, nz = 12, 10, 8
    blobs = [((0.35, 0.3, 0.5), 0.18, 1.0), ((0.65, 0.55, 0.4), 0.15, 0.8),
             ((0.45, 0.75, 0.6), 0.12, 0.6)]
    values = []
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                p = ((x + 0.5) / nx, (y + 0.5) / ny, (z + 0.5) / nz)
                border = x in (0, nx - 1) or y in (0, ny - 1) or z in (0, nz - 1)
                d = 0.0 if border else 0.05
                for c, r, h in blobs:
                    q = sum((p[i] - c[i]) ** 2 for i in range(3))
                    d += h * math.exp(-q / (r * r))
                values.append(0.0 if border else min(d, 1.0))
    vol("smoke.vol", (nx, ny, nz), 1, (-1, 0, -1, 1, 1.6, 1), values)


def tint():
    nx, ny, nz = 6, 5, 4
    values = []
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                dark = 0.4 if (x + y + z) % 2 else 1.0
                rgb = (0.3 + 0.68 * x / (nx - 1), 0.3 + 0.68 * y / (ny - 1),
                       0.98 - 0.68 * z / (nz - 1))
                values += [max(0.2, c * dark) for c in rgb]
    vol("tint.vol", (nx, ny, nz), 3, (0, 0, 0, 1, 1, 1), values)


if __name__ == "__main__":
    smoke()
    tint()
    height()
    attributes()
    normals()
    tiles()
    roughness()
    icosphere()
    prism()
    stripes()
    sky_rows()
    serialized()
