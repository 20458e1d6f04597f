#!/usr/bin/env python3
"""Writes the example models as ASCII STL (no dependencies beyond the standard library).

  boxboss.stl  a 20 x 20 x 8 mm block with a 12 mm diameter, 12 mm tall round boss on top:
               straight walls, a curved wall and a top surface, so the sliced file has
               corners, short curve segments and infill.
(The process-planning study's coins come from examples/04_make_coin_stl.py.)
Usage: make_models.py OUTDIR
"""
import math
import os
import sys


def write_stl(path, name, tris):
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for a, b, c in tris:
            ux, uy, uz = (b[i] - a[i] for i in range(3))
            vx, vy, vz = (c[i] - a[i] for i in range(3))
            n = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
            ln = math.sqrt(sum(x * x for x in n)) or 1.0
            f.write("  facet normal %.6e %.6e %.6e\n    outer loop\n" % tuple(x / ln for x in n))
            for p in (a, b, c):
                f.write("      vertex %.6f %.6f %.6f\n" % p)
            f.write("    endloop\n  endfacet\n")
        f.write(f"endsolid {name}\n")


def box(x0, y0, z0, x1, y1, z1):
    p = [(x, y, z) for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    out = []
    for a, b, c, d in quads:
        out += [(p[a], p[b], p[c]), (p[a], p[c], p[d])]
    return out


def cylinder(cx, cy, z0, z1, r, n, bottom=True):
    out = []
    ring = [(cx + r * math.cos(2 * math.pi * k / n), cy + r * math.sin(2 * math.pi * k / n)) for k in range(n)]
    for k in range(n):
        (x0, y0), (x1, y1) = ring[k], ring[(k + 1) % n]
        out += [((x0, y0, z0), (x1, y1, z0), (x1, y1, z1)), ((x0, y0, z0), (x1, y1, z1), (x0, y0, z1))]
        out.append(((cx, cy, z1), (x0, y0, z1), (x1, y1, z1)))
        if bottom:
            out.append(((cx, cy, z0), (x1, y1, z0), (x0, y0, z0)))
    return out


def boxboss():
    # The boss overlaps the block by 1 mm; slicers union overlapping shells.
    return box(0, 0, 0, 20, 20, 8) + cylinder(10, 10, 7, 20, 6, 96)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "."
    os.makedirs(out, exist_ok=True)
    write_stl(os.path.join(out, "boxboss.stl"), "boxboss", boxboss())


if __name__ == "__main__":
    main()
