#!/usr/bin/env python3
"""Viewpoint-driven simplification (itgfx simplify, VMI and VE) against QEM
(meshoptimizer's simplify, the Python binding) on the shared meshes.

Never run by CI or the Rust tests; meshoptimizer is not a workspace
dependency. Needs `pip install meshoptimizer numpy` (bench/simplify_table.sh
makes a virtual environment) and a built `itgfx` (release recommended).

For every mesh and target: itgfx simplifies by VMI and by VE (one --sweep
run each, so the time of a target is the time to reach it), writes the
welded and repaired input it started from (input.obj); meshoptimizer
simplifies that same input.obj to the same triangle count (target_error 1,
no error bound: the count decides), and `itgfx simplify --evaluate` measures
QEM's result with the same code as the others: image RMSE over 24 views
none of the channel's viewpoints, silhouette RMSE, symmetric Hausdorff and
mean distance (units of the bounding box's half diagonal).

Usage: simplify_table.py ITGFX OUTDIR MESH.obj... [--targets 10%,2%] [--viewpoints 42]
Prints a Markdown table and writes OUTDIR/simplify_table.json.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
import meshoptimizer


def read_obj(path):
    vs, fs = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vs.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
                for k in range(1, len(idx) - 1):
                    fs.append([idx[0], idx[k], idx[k + 1]])
    return np.array(vs, dtype=np.float32), np.array(fs, dtype=np.uint32).reshape(-1)


def write_obj(path, v, idx):
    with open(path, "w") as f:
        f.write("# meshoptimizer simplify (QEM)\n")
        for p in v:
            f.write(f"v {float(p[0])!r} {float(p[1])!r} {float(p[2])!r}\n")
        used = idx.reshape(-1, 3)
        for t in used:
            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


def itgfx(exe, args):
    r = subprocess.run([exe] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"itgfx {' '.join(args)}: {r.stderr.strip()}")
    return json.loads(r.stdout)


def qem(vertices, indices, target_triangles):
    dest = np.zeros(len(indices), dtype=np.uint32)
    err = np.zeros(1, dtype=np.float32)
    t0 = time.perf_counter()
    n = meshoptimizer.simplify(
        dest,
        indices,
        vertices,
        target_index_count=3 * target_triangles,
        target_error=1.0,
        result_error=err,
    )
    return dest[:n], time.perf_counter() - t0, float(err[0])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("itgfx")
    ap.add_argument("out")
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--targets", default="10%,2%")
    ap.add_argument("--viewpoints", default="42")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for mesh in a.meshes:
        name = os.path.splitext(os.path.basename(mesh))[0]
        runs = {}
        for metric in ["vmi", "ve"]:
            d = os.path.join(a.out, name, metric)
            runs[metric] = itgfx(
                a.itgfx,
                ["simplify", mesh, "--sweep", a.targets, "--metric", metric, "--viewpoints", a.viewpoints,
                 "--out", d, "--json"],
            )
        n = runs["vmi"]["triangles"]
        inp = os.path.join(a.out, name, "vmi", "input.obj")
        v, idx = read_obj(inp)
        for k, res in enumerate(runs["vmi"]["results"]):
            target = int(res["name"])
            q_idx, q_sec, q_err = qem(v, idx, target)
            qobj = os.path.join(a.out, name, f"qem_{target}.obj")
            write_obj(qobj, v, q_idx)
            q = itgfx(a.itgfx, ["simplify", mesh, "--evaluate", qobj, "--out", os.path.join(a.out, name, "qem"),
                                "--json"])["results"][0]
            ve = runs["ve"]["results"][k]
            rows.append({
                "mesh": name, "triangles_in": n, "target": target,
                "vmi": res, "ve": ve, "qem": {**q, "seconds": q_sec, "meshopt_error": q_err},
            })
    with open(os.path.join(a.out, "simplify_table.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("| mesh | tris in → target | image RMSE VMI / VE / QEM | silhouette RMSE VMI / VE / QEM "
          "| Hausdorff VMI / VE / QEM | mean dist. VMI / VE / QEM | seconds VMI / VE / QEM | VMI ÷ QEM time |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        m = [r["vmi"], r["ve"], r["qem"]]

        def three(key, fmt):
            return " / ".join(format(x[key], fmt) for x in m)

        tris = " / ".join(str(x["triangles"]) for x in m)
        print(f"| {r['mesh']} | {r['triangles_in']} → {r['target']} ({tris}) | {three('image_rmse', '.4f')} "
              f"| {three('silhouette_rmse', '.4f')} | {three('hausdorff', '.4f')} | {three('mean_distance', '.5f')} "
              f"| {m[0]['seconds']:.2f} / {m[1]['seconds']:.2f} / {m[2]['seconds']:.4f} "
              f"| {m[0]['seconds'] / max(m[2]['seconds'], 1e-9):.0f}× |")


if __name__ == "__main__":
    main()
