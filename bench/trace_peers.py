#!/usr/bin/env python3
"""All crossings of the same global lines with Embree and Mitsuba 3, for BENCHMARKS.md.

Usage:  python3 bench/trace_peers.py DIR [--lines N] [--no-mitsuba] [--entry-exit] [--repeat R]
DIR holds scene.obj and lines.f32 written by
  cargo bench -p itgfx-backends --bench trace -- SCENE N --export DIR
Each peer finds every crossing of each line by repeated closest-hit queries
(the ray restarted just past each hit), which is the job itgfx's tracer does
in one traversal. Prints one JSON line per peer: seconds, lines/s, crossings
found (to check all tracers saw the same crossings). For Embree "seconds" is
the slower process's time inside `scene.run` alone (Embree's tracing);
"with_driver_s" adds this driver's numpy gathers and scatters between the
queries (~60% of the loop: not Embree's cost), "cpu_s" is both processes'
CPU seconds with that bookkeeping.

Embree: embreex (Embree 4 through its Python binding; one thread per process,
so the 2-core figure runs two processes on halves of the lines).
Mitsuba 3: the llvm_ad_rgb variant (Embree-backed packet tracing on all cores).
"""
import json, os, sys, time
import numpy as np

# Restart offset past a hit: 1e-6 re-hits the same triangle in f32; 1e-4 is
# also obvhs's near cutoff, so all tracers skip the same near crossings.
EPS = 1e-4


def load(d, n=None):
    import trimesh
    mesh = trimesh.load(os.path.join(d, "scene.obj"), process=False, force="mesh")
    raw = np.fromfile(os.path.join(d, "lines.f32"), dtype="<f4").reshape(-1, 7)
    if n:
        raw = raw[:n]
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64), raw


def embree_worker(args):
    d, lo, hi, depth, repeat = args
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
    v, f, raw = load(d)
    raw = raw[lo:hi]
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, v[f].astype(np.float32))
    t0, c0 = time.perf_counter(), time.process_time()
    crossings, traced = 0, 0.0
    for _ in range(repeat):
        org = raw[:, 0:3].astype(np.float32).copy()
        dirs = raw[:, 3:6].astype(np.float32).copy()
        tmax = raw[:, 6].astype(np.float32)
        tnear = np.zeros(len(raw), dtype=np.float32)
        alive = np.arange(len(raw))
        queries = 0
        while len(alive) and queries < depth:
            o, di, dist = org[alive], dirs[alive], tmax[alive] - tnear[alive]
            # Embree's own time: the scene.run calls alone; the numpy
            # bookkeeping around them (gathers, scatters, the next origins)
            # is this driver's, ~60% of the loop on cube-enclosure:30.
            a = time.perf_counter()
            res = scene.run(o, di, output=1, dists=dist)
            traced += time.perf_counter() - a
            queries += 1
            hit = res["geomID"] >= 0
            crossings += int(hit.sum())
            idx = alive[hit]
            t = res["tfar"][hit]
            org[idx] += dirs[idx] * (t + EPS)[:, None]
            tnear[idx] += t + EPS
            alive = idx
    return traced, time.perf_counter() - t0, time.process_time() - c0, crossings


def embree(d, n, procs=2, depth=1 << 30, repeat=1):
    from multiprocessing import Pool
    with Pool(procs) as p:
        cuts = [n * k // procs for k in range(procs + 1)]
        t0 = time.perf_counter()
        out = p.map(embree_worker, [(d, cuts[k], cuts[k + 1], depth, repeat) for k in range(procs)])
        wall = time.perf_counter() - t0
    # (slower process's scene.run time, slower process's loop with the numpy
    # bookkeeping, pool wall with loading, CPU s of both, crossings)
    return (max(r[0] for r in out), max(r[1] for r in out), wall, sum(r[2] for r in out), sum(r[3] for r in out))


def mitsuba(d, n):
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import drjit as dr
    scene = mi.load_dict({"type": "scene", "m": {"type": "obj", "filename": os.path.join(d, "scene.obj"), "face_normals": True}})
    _, _, raw = load(d, n)
    def run():
        o = mi.Point3f(*[mi.Float(raw[:, k].copy()) for k in range(3)])
        dd = mi.Vector3f(*[mi.Float(raw[:, 3 + k].copy()) for k in range(3)])
        tmax = mi.Float(raw[:, 6].copy())
        crossings = 0
        active = dr.full(mi.Bool, True, len(raw))
        for _ in range(64):
            ray = mi.Ray3f(o, dd, tmax)
            si = scene.ray_intersect_preliminary(ray, active)
            hit = active & si.is_valid()
            c = dr.count(hit)
            dr.eval(c)
            c = int(c[0]) if hasattr(c, "__len__") else int(c)
            if c == 0:
                break
            crossings += c
            step = dr.select(hit, si.t + EPS, 0.0)
            o = o + dd * step
            tmax = tmax - step
            active = hit
            dr.eval(o, tmax, active)
        return crossings
    run()  # JIT warm-up (kernel compilation is not tracing)
    t0 = time.perf_counter()
    c = run()
    return time.perf_counter() - t0, c


def main():
    d = sys.argv[1]
    n = int(float(sys.argv[sys.argv.index("--lines") + 1])) if "--lines" in sys.argv else None
    _, _, raw = load(d, n)
    n = len(raw)
    # --entry-exit: at most two closest hits per line (the entry and the exit
    # of a closed scene: issue 27's Embree figure); --repeat R: the lines
    # traced R times over (10^9 lines from 10^7 exported, 28 bytes a line).
    depth = 2 if "--entry-exit" in sys.argv else 1 << 30
    repeat = int(float(sys.argv[sys.argv.index("--repeat") + 1])) if "--repeat" in sys.argv else 1
    t, loop, wall, cpu, c = embree(d, n, depth=depth, repeat=repeat)
    kind = "entry and exit" if depth == 2 else "every crossing"
    print(json.dumps({"impl": f"embree (embreex, 2 processes, {kind})", "lines": n * repeat, "seconds": round(t, 3), "with_driver_s": round(loop, 3), "wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "mlines_per_s": round(n * repeat / t / 1e6, 2), "crossings": c}))
    if "--no-mitsuba" in sys.argv:
        return
    t, c = mitsuba(d, n)
    print(json.dumps({"impl": "mitsuba3 llvm_ad_rgb", "lines": n, "seconds": round(t, 3), "mlines_per_s": round(n / t / 1e6, 2), "crossings": c}))


if __name__ == "__main__":
    main()
