"""Write drum.stl: a closed drum about the y axis (radius 50 mm, from y = -20 to 20 mm):
the side as 48 flat panels (96 triangles) and each end cap as a fan of 48 triangles.
    python3 cases/meshes/make_drum.py   (from the repository root)
"""
import math
from pathlib import Path

R, Y0, Y1, N = 0.05, -0.02, 0.02, 48


def point(k, y):
    a = 2 * math.pi * k / N
    return (R * math.cos(a), y, R * math.sin(a))


tris = []
for k in range(N):
    a0, a1 = point(k, Y0), point(k + 1, Y0)
    b0, b1 = point(k, Y1), point(k + 1, Y1)
    tris += [(a0, a1, b1), (a0, b1, b0)]
    tris += [((0.0, Y0, 0.0), a1, a0), ((0.0, Y1, 0.0), b0, b1)]
lines = ["solid drum"]
for a, b, c in tris:
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    s = math.sqrt(sum(x * x for x in n))
    lines.append("  facet normal %.9e %.9e %.9e" % tuple(x / s for x in n))
    lines.append("    outer loop")
    for p in (a, b, c):
        lines.append("      vertex %.12e %.12e %.12e" % p)
    lines.append("    endloop")
    lines.append("  endfacet")
lines.append("endsolid drum")
Path(__file__).with_name("drum.stl").write_text("\n".join(lines) + "\n")
