#!/usr/bin/env python3
"""Writes the Cornell box of `itgfx complexity cornell-box` as an OBJ, with
variants that test why its I_S^c differs from Part III Table 4 (docs/TABLES.md):

  (no option)  the built-in box: 17 one-sided patches, front closed
  open         without the front wall
  lightback    the light's back side (facing the ceiling 1 mm above) is a surface too
  inside       each block is a closed solid whose inside is a surface too
               (inner faces 0.01% inside the outer ones, bottoms included):
               segments inside the blocks count, as with two-sided faces

Usage: bench/cornell_variants.py [open] [lightback] [inside] > box.obj
       itgfx complexity box.obj --lines 1e6 --seed 1
"""
import sys


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def mean(ps):
    return tuple(sum(c) / len(ps) for c in zip(*ps))


def facing(poly, ref, towards):
    """Orders `poly` so its normal points towards `ref` (or away from it)."""
    n = cross(sub(poly[1], poly[0]), sub(poly[2], poly[0]))
    away = dot(n, sub(mean(poly), ref)) > 0
    return poly if away != towards else poly[::-1]


CENTRE = (278.0, 274.4, 279.6)
WALLS = [
    ("floor", [(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]),
    ("ceiling", [(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)]),
    ("back", [(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)]),
    ("right", [(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]),
    ("left", [(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)]),
    ("front", [(0, 0, 0), (552.8, 0, 0), (556, 548.8, 0), (0, 548.8, 0)]),
]
LIGHT = [(343, 547.8, 227), (343, 547.8, 332), (213, 547.8, 332), (213, 547.8, 227)]
BLOCKS = [
    ("short", [(130, 65), (82, 225), (240, 272), (290, 114)], 165.0),
    ("tall", [(423, 247), (265, 296), (314, 456), (472, 406)], 330.0),
]


def main(opts):
    polys = []
    for name, q in WALLS:
        if not (name == "front" and "open" in opts):
            polys.append((name, facing(q, CENTRE, True)))
    below = (278, 0, 279.6)
    polys.append(("light", facing(LIGHT, below, True)))
    if "lightback" in opts:
        polys.append(("light back", facing([(x, y + 0.01, z) for x, y, z in LIGHT], below, False)))
    for name, fp, h in BLOCKS:
        top = [(x, h, z) for x, z in fp]
        bottom = [(x, 0.0, z) for x, z in fp]
        sides = [[bottom[i], bottom[(i + 1) % 4], top[(i + 1) % 4], top[i]] for i in range(4)]
        c = mean(top + bottom)
        for i, q in enumerate([top] + sides):
            polys.append((f"{name} block {i}", facing(q, c, False)))
        if "inside" in opts:
            shrink = lambda p: tuple(ci + (pi - ci) * (1 - 1e-4) for pi, ci in zip(p, c))
            for i, q in enumerate([top, bottom] + sides):
                polys.append((f"{name} block inside {i}", facing([shrink(p) for p in q], c, True)))
    lines, faces = [], []
    for name, q in polys:
        faces.append(f"g {name}")
        first = len(lines) + 1
        lines.extend(f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in q)
        faces.append("f " + " ".join(str(first + k) for k in range(len(q))))
    print("\n".join(lines + faces))


if __name__ == "__main__":
    bad = set(sys.argv[1:]) - {"open", "lightback", "inside"}
    if bad:
        sys.exit(f"cornell_variants.py: unknown option {sorted(bad)[0]}")
    main(set(sys.argv[1:]))
