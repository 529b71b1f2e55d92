#!/usr/bin/env python3
"""Writes gradient_sky.pfm (run from this folder; plain Python): a small
64 x 32 lat-long map for showcase.xml, Mitsuba 3's convention (u = 0 looks
down -z, u = 0.5 down +z, top row +y). A blue-to-pale sky gradient over a
dim warm ground, and a soft sun low behind the camera's right shoulder so
the mirror sphere shows it. Mitsuba has no procedural sky, so the
showcase carries this map instead of lente's "@sky".
"""
import math
import struct

W, H = 64, 32
SUN = (0.55, 0.5, 0.67)  # direction towards the sun (normalised below)


def pixel(d):
    x, y, z = d
    if y >= 0:
        t = y ** 0.6  # 0 at the horizon, 1 at the zenith
        horizon, zenith = (1.0, 0.95, 0.85), (0.18, 0.35, 0.85)
        c = [h + (z_ - h) * t for h, z_ in zip(horizon, zenith)]
    else:
        t = min(1.0, -y * 4)
        near, far = (0.55, 0.5, 0.42), (0.22, 0.19, 0.16)
        c = [a + (b - a) * t for a, b in zip(near, far)]
    n = math.sqrt(sum(s * s for s in SUN))
    cos = (x * SUN[0] + y * SUN[1] + z * SUN[2]) / n
    sun = 12.0 * math.exp((cos - 1.0) / 0.015)  # a soft disc, ~10 degrees
    return [c[0] + sun, c[1] + 0.9 * sun, c[2] + 0.75 * sun]


rows = []
for j in range(H):
    theta = math.pi * (j + 0.5) / H
    row = []
    for i in range(W):
        phi = 2 * math.pi * (i + 0.5) / W
        d = (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))
        row.append(pixel(d))
    rows.append(row)

with open("gradient_sky.pfm", "wb") as f:
    f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
    for row in reversed(rows):  # PFM stores the bottom row first
        for px in row:
            f.write(struct.pack("<3f", *px))
