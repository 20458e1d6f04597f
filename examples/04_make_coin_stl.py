#!/usr/bin/python3
"""Writes a closed, outward-oriented cylinder ("coin") as an ASCII or binary STL.

Usage: 04_make_coin_stl.py DIAMETER_MM HEIGHT_MM OUT.stl [--segments N] [--ascii]
Used for the coins of Table 4 of the UTFPR process-planning study (25, 50, 100 mm); see docs/process.md.
"""
import math
import struct
import sys


def coin(d, h, n):
    r = d / 2.0
    ring = [(r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)) for k in range(n)]
    tris = []
    for k in range(n):
        (x0, y0), (x1, y1) = ring[k], ring[(k + 1) % n]
        tris.append(((0, 0, 0), (x1, y1, 0), (x0, y0, 0)))          # bottom, normal -Z
        tris.append(((0, 0, h), (x0, y0, h), (x1, y1, h)))          # top, normal +Z
        tris.append(((x0, y0, 0), (x1, y1, 0), (x1, y1, h)))        # side
        tris.append(((x0, y0, 0), (x1, y1, h), (x0, y0, h)))
    return tris


def normal(t):
    a, b, c = t
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    l = math.sqrt(sum(x * x for x in n)) or 1.0
    return [x / l for x in n]


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    n = 128
    if "--segments" in sys.argv:
        n = int(sys.argv[sys.argv.index("--segments") + 1])
        args.remove(str(n))
    d, h, out = float(args[0]), float(args[1]), args[2]
    tris = coin(d, h, n)
    if "--ascii" in sys.argv:
        with open(out, "w") as f:
            f.write("solid coin\n")
            for t in tris:
                f.write("facet normal %g %g %g\n outer loop\n" % tuple(normal(t)))
                for p in t:
                    f.write("  vertex %.6f %.6f %.6f\n" % p)
                f.write(" endloop\nendfacet\n")
            f.write("endsolid coin\n")
    else:
        with open(out, "wb") as f:
            f.write(b"coin".ljust(80, b" "))
            f.write(struct.pack("<I", len(tris)))
            for t in tris:
                f.write(struct.pack("<3f", *normal(t)))
                for p in t:
                    f.write(struct.pack("<3f", *p))
                f.write(b"\0\0")


if __name__ == "__main__":
    main()
