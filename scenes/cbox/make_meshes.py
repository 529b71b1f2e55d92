#!/usr/bin/env python3
"""Writes the Cornell box meshes of scenes/cbox (run from this folder).

The box spans x in [-1, 1], y in [0, 2], z in [-1, 1] and is open towards +z.
Every quad faces into the box (counter-clockwise seen from inside), so the
diffuse walls are lit from the inside and the light emits downwards. Each
wall is split into a grid of quads so the files also exercise shared
vertices and polygon triangulation (faces are written as quads).
"""

def quad_grid(name, corner, eu, ev, n, normal):
    """OBJ text for an n x n grid of quads spanning corner + s*eu + t*ev."""
    lines = [f"# {name}", f"o {name}"]
    for i in range(n + 1):
        for j in range(n + 1):
            p = [corner[k] + eu[k] * i / n + ev[k] * j / n for k in range(3)]
            lines.append("v %.6f %.6f %.6f" % tuple(p))
    lines.append("vn %.6f %.6f %.6f" % tuple(normal))
    for i in range(n + 1):
        for j in range(n + 1):
            lines.append("vt %.6f %.6f" % (i / n, j / n))
    idx = lambda i, j: i * (n + 1) + j + 1
    # Check the winding against the requested normal.
    cross = [eu[1] * ev[2] - eu[2] * ev[1], eu[2] * ev[0] - eu[0] * ev[2], eu[0] * ev[1] - eu[1] * ev[0]]
    flip = sum(c * m for c, m in zip(cross, normal)) < 0
    for i in range(n):
        for j in range(n):
            q = [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)]
            if flip:
                q.reverse()
            lines.append("f " + " ".join(f"{v}/{v}/1" for v in q))
    return "\n".join(lines) + "\n"


def write(name, *args):
    with open(name + ".obj", "w") as f:
        f.write(quad_grid(name, *args))


write("floor", (-1, 0, -1), (2, 0, 0), (0, 0, 2), 4, (0, 1, 0))
write("ceiling", (-1, 2, -1), (2, 0, 0), (0, 0, 2), 4, (0, -1, 0))
write("back", (-1, 0, -1), (2, 0, 0), (0, 2, 0), 4, (0, 0, 1))
write("left", (-1, 0, -1), (0, 0, 2), (0, 2, 0), 4, (1, 0, 0))
write("right", (1, 0, -1), (0, 0, 2), (0, 2, 0), 4, (-1, 0, 0))
write("light", (-0.25, 1.98, -0.25), (0.5, 0, 0), (0, 0, 0.5), 1, (0, -1, 0))
