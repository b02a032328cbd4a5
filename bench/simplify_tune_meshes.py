#!/usr/bin/env python3
"""The meshes the placement and λ of `itgfx simplify` were chosen on, none
of them the benchmark table's (suzanne, spot, teapot, fandisk):

* torus6k.obj: a bumpy, flattened torus of 75 × 40 quads (6,000 triangles);
* open6k.obj: the same torus of 75 × 54 quads with a band of 75 × 14
  quads of its tube left out (75 × 40 kept, 6,000 triangles): open, two
  long boundary loops, for the boundary rules;
* bunny6k.obj: stanford-bunny.obj reduced to 6,000 triangles by
  fast-simplification (needs `pip install fast-simplification numpy`).

Usage: simplify_tune_meshes.py STANFORD_BUNNY.obj OUTDIR   (never run by CI)
"""

import math
import os
import sys

import numpy as np
import fast_simplification

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from simplify_table import read_obj  # noqa: E402  (one OBJ reader for the bench scripts)


def torus(path, u=75, v=40, keep=None):
    lines = []
    for i in range(u):
        for j in range(v):
            a, b = 2 * math.pi * i / u, 2 * math.pi * j / v
            r = 0.35 * (1 + 0.3 * max(math.cos(3 * a), 0)) + 0.03 * math.sin(7 * a) * math.cos(5 * b)
            big = 1 + 0.15 * math.sin(2 * a)
            z = r * math.sin(b) * (1.4 if j < v // 2 else 1.0)
            lines.append(f"v {(big + r * math.cos(b)) * math.cos(a)} {(big + r * math.cos(b)) * math.sin(a)} {z}")

    def idx(i, j):
        return (i % u) * v + (j % v) + 1

    for i in range(u):
        for j in range(v if keep is None else keep):
            p, q, r, t = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            lines.append(f"f {p} {q} {r}\nf {p} {r} {t}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def reduced(src, path, count):
    vs, idx = read_obj(src, dtype=np.float64)
    fs = idx.reshape(-1, 3).astype(np.int64)
    v, f = fast_simplification.simplify(vs, fs, target_count=count)
    with open(path, "w") as out:
        for q in v:
            out.write(f"v {float(q[0])!r} {float(q[1])!r} {float(q[2])!r}\n")
        for t in f:
            out.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


if __name__ == "__main__":
    bunny, out = sys.argv[1:3]
    os.makedirs(out, exist_ok=True)
    torus(os.path.join(out, "torus6k.obj"))
    torus(os.path.join(out, "open6k.obj"), v=54, keep=40)
    reduced(bunny, os.path.join(out, "bunny6k.obj"), 6000)
