#!/usr/bin/env python3
"""Viewpoint-driven simplification (itgfx simplify: VMI, VE, IVO, VKL) against
two QEM implementations (meshoptimizer's simplify, the Python binding, and
fast-simplification, the Fast-Quadric-Mesh-Simplification binding) on the
shared meshes.

Never run by CI or the Rust tests; the peers are not workspace
dependencies. Needs `pip install meshoptimizer fast-simplification numpy`
(bench/simplify_table.sh makes a virtual environment) and a built `itgfx`
(release recommended).

For every mesh and target: itgfx simplifies by each metric and placement
(one --sweep run each, so the time of a target is the time to reach it),
writes the welded and repaired input it started from (input.obj);
meshoptimizer simplifies that same input.obj to the same triangle count
(target_error 1, no error bound: the count decides), fast-simplification
too (target_reduction from the count), and `itgfx simplify --evaluate`
measures the peers' results (faces with no area left out by its reader)
with the same code as the others: image RMSE over 24 views
none of the channel's viewpoints, silhouette RMSE, symmetric Hausdorff and
mean distance (units of the bounding box's half diagonal).

Usage: simplify_table.py ITGFX OUTDIR MESH.obj... [--targets 10%,2%] [--viewpoints 42] [--runs vmi/quadric,...]
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
import fast_simplification

# itgfx's runs, METRIC/PLACEMENT: collapse costs per-view VMI, viewpoint
# entropy, the channel's I(V;O), per-view KL distance to the actual areas;
# placements quadric (the quadric's minimiser), best (least viewpoint cost
# of a few positions), blend, endpoint (half-edge collapses, the paper's).
RUNS = "vmi/blend,vkl/blend,vmi/quadric,vmi/endpoint,ve/endpoint"
PEERS = ["qem", "fqms"]


def read_obj(path, dtype=np.float32):
    vs, fs = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vs.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(w.split("/")[0]) - 1 for w in line.split()[1:]]
                for k in range(1, len(idx) - 1):
                    fs.append([idx[0], idx[k], idx[k + 1]])
    return np.array(vs, dtype=dtype), np.array(fs, dtype=np.uint32).reshape(-1)


def write_obj(path, v, idx, what):
    """Writes a peer's triangles as they are (`itgfx simplify --evaluate`
    leaves out those with no area, with a warning); returns how many have
    no area."""
    tris = idx.reshape(-1, 3)
    p = v.astype(np.float64)
    area2 = np.linalg.norm(np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]]), axis=1)
    with open(path, "w") as f:
        f.write(f"# {what}\n")
        for q in v:
            f.write(f"v {float(q[0])!r} {float(q[1])!r} {float(q[2])!r}\n")
        for t in tris:
            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")
    return int((area2 <= 0.0).sum())


def itgfx(exe, args, cache=None):
    """Runs itgfx --json; with `cache`, reuses (or saves) its output there."""
    if cache and os.path.exists(cache):
        with open(cache) as f:
            return json.load(f)
    r = subprocess.run([exe] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"itgfx {' '.join(args)}: {r.stderr.strip()}")
    if cache:
        os.makedirs(os.path.dirname(cache), exist_ok=True)
        with open(cache, "w") as f:
            f.write(r.stdout)
    return json.loads(r.stdout)


def qem(vertices, indices, target_triangles):
    dest = np.zeros(len(indices), dtype=np.uint32)
    err = np.zeros(1, dtype=np.float32)
    t0, c0 = time.perf_counter(), time.process_time()
    n = meshoptimizer.simplify(
        dest,
        indices,
        vertices,
        target_index_count=3 * target_triangles,
        target_error=1.0,
        result_error=err,
    )
    return dest[:n], time.perf_counter() - t0, time.process_time() - c0, float(err[0])


def fqms(vertices, indices, target_triangles):
    """fast-simplification (Fast Quadric Mesh Simplification) to `target_triangles`."""
    faces = indices.reshape(-1, 3).astype(np.int64)
    t0, c0 = time.perf_counter(), time.process_time()
    reduction = 1.0 - target_triangles / len(faces)
    v, f = fast_simplification.simplify(vertices.astype(np.float64), faces, target_reduction=reduction)
    return (np.asarray(v, dtype=np.float32), np.asarray(f, dtype=np.uint32).reshape(-1),
            time.perf_counter() - t0, time.process_time() - c0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("itgfx")
    ap.add_argument("out")
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--targets", default="10%,2%")
    ap.add_argument("--viewpoints", default="42")
    ap.add_argument("--runs", default=RUNS, help="itgfx runs, METRIC/PLACEMENT,... (default %(default)s)")
    a = ap.parse_args()
    methods = a.runs.split(",")
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for mesh in a.meshes:
        name = os.path.splitext(os.path.basename(mesh))[0]
        runs = {}
        for m in methods:
            metric, placement = m.split("/")
            d = os.path.join(a.out, name, f"{metric}-{placement}")
            runs[m] = itgfx(
                a.itgfx,
                ["simplify", mesh, "--sweep", a.targets, "--metric", metric, "--placement", placement,
                 "--viewpoints", a.viewpoints, "--out", d, "--json"],
                cache=os.path.join(d, "run.json"),
            )
        first = methods[0]
        n = runs[first]["triangles"]
        inp = os.path.join(a.out, name, first.replace("/", "-"), "input.obj")
        v, idx = read_obj(inp)
        for k, res in enumerate(runs[first]["results"]):
            target = int(res["name"])
            q_idx, q_sec, q_cpu, q_err = qem(v, idx, target)
            qobj = os.path.join(a.out, name, f"qem_{target}.obj")
            zero = write_obj(qobj, v, q_idx, "meshoptimizer simplify (QEM)")
            q = itgfx(a.itgfx, ["simplify", mesh, "--evaluate", qobj, "--out", os.path.join(a.out, name, "qem"),
                                "--json"])["results"][0]
            row = {"mesh": name, "triangles_in": n, "target": target}
            for m in methods:
                row[m] = runs[m]["results"][k]
            row["qem"] = {**q, "seconds": q_sec, "cpu_seconds": q_cpu, "meshopt_error": q_err, "zero_area": zero}
            f_v, f_idx, f_sec, f_cpu = fqms(v, idx, target)
            fobj = os.path.join(a.out, name, f"fqms_{target}.obj")
            f_zero = write_obj(fobj, f_v, f_idx, "fast-simplification (FQMS)")
            fq = itgfx(a.itgfx, ["simplify", mesh, "--evaluate", fobj, "--out", os.path.join(a.out, name, "fqms"),
                                 "--json"])["results"][0]
            row["fqms"] = {**fq, "seconds": f_sec, "cpu_seconds": f_cpu, "zero_area": f_zero}
            rows.append(row)
    with open(os.path.join(a.out, "simplify_table.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("| mesh | triangles in → target | method | triangles | image RMSE | silhouette RMSE | Hausdorff "
          "| mean distance | wall s | CPU s |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        for method in methods + PEERS:
            x = r[method]
            best = min(r[m]["image_rmse"] for m in methods + PEERS)
            rmse = f"{x['image_rmse']:.4f}"
            if x["image_rmse"] == best:
                rmse = f"**{rmse}**"
            print(f"| {r['mesh']} | {r['triangles_in']} → {r['target']} | {method.upper()} | {x['triangles']} | {rmse} "
                  f"| {x['silhouette_rmse']:.4f} | {x['hausdorff']:.4f} | {x['mean_distance']:.5f} "
                  f"| {x['seconds']:.3g} | {x.get('cpu_seconds') or 0:.3g} |")


if __name__ == "__main__":
    main()
