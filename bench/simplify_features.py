#!/usr/bin/env python3
"""Where a simplified mesh departs from its input: the distance from points
on the input's sharp edges (dihedral angle above 40°: 3 random points per
edge, seed 1) and from centroids of its triangles away from those edges (up
to 3,000) to each simplified surface, in units of the input's bounding-box
half diagonal (the table's unit). Used for docs/SIMPLIFY.md's fandisk row.

Usage: simplify_features.py INPUT.obj SIMPLIFIED.obj...   (needs numpy; never run by CI)
"""

import collections
import sys

import numpy as np


def read(path):
    vs, fs = [], []
    with open(path) as f:
        for line in f:
            s = line.split()
            if s and s[0] == "v":
                vs.append([float(x) for x in s[1:4]])
            elif s and s[0] == "f":
                fs.append([int(x.split("/")[0]) - 1 for x in s[1:4]])
    return np.array(vs), np.array(fs)


def distance(points, a, b, c):
    """Distance from each point to the nearest of the triangles (a, b, c)."""
    p = points[:, None, :]
    a, b, c = a[None], b[None], c[None]
    ab, ac = b - a, c - a
    d1, d2 = (ab * (p - a)).sum(-1), (ac * (p - a)).sum(-1)
    d3, d4 = (ab * (p - b)).sum(-1), (ac * (p - b)).sum(-1)
    d5, d6 = (ab * (p - c)).sum(-1), (ac * (p - c)).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    den = va + vb + vc
    den = np.where(den == 0, 1e-30, den)
    inner = a + ab * (vb / den)[..., None] + ac * (vc / den)[..., None]

    def segment(x, y):
        xy = y - x
        t = np.clip(((p - x) * xy).sum(-1) / np.maximum((xy * xy).sum(-1), 1e-30), 0, 1)
        return ((x + xy * t[..., None] - p) ** 2).sum(-1)

    edge = np.minimum(np.minimum(segment(a, b), segment(b, c)), segment(a, c))
    inside = (va >= 0) & (vb >= 0) & (vc >= 0)
    return np.sqrt(np.where(inside, ((inner - p) ** 2).sum(-1), edge).min(1))


def main():
    v, f = read(sys.argv[1])
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    edges = collections.defaultdict(list)
    for i, t in enumerate(f):
        for a, b in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]:
            edges[(min(a, b), max(a, b))].append(i)
    sharp = [e for e, fs in edges.items() if len(fs) == 2 and np.dot(n[fs[0]], n[fs[1]]) < np.cos(np.radians(40))]
    rng = np.random.default_rng(1)
    on_edges = np.array([v[a] * (1 - t) + v[b] * t for a, b in sharp for t in rng.random(3)])
    near = {x for e in sharp for x in e}
    away = np.array([v[t].mean(0) for t in f if not set(t) & near])
    away = away[rng.choice(len(away), min(3000, len(away)), replace=False)]
    unit = np.linalg.norm(v.max(0) - v.min(0)) / 2
    print(f"{sys.argv[1]}: {len(sharp)} sharp edges, {len(on_edges)} points on them, {len(away)} away")
    for path in sys.argv[2:]:
        w, g = read(path)
        tri = (w[g[:, 0]], w[g[:, 1]], w[g[:, 2]])
        d_edge = np.concatenate([distance(on_edges[i:i + 500], *tri) for i in range(0, len(on_edges), 500)]) / unit
        d_away = np.concatenate([distance(away[i:i + 500], *tri) for i in range(0, len(away), 500)]) / unit
        print(f"{path}: sharp edges mean {d_edge.mean():.5f} p90 {np.percentile(d_edge, 90):.5f} max {d_edge.max():.4f}"
              f" | away mean {d_away.mean():.5f} p90 {np.percentile(d_away, 90):.5f} max {d_away.max():.4f}")


if __name__ == "__main__":
    main()
