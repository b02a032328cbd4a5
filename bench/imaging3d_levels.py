#!/usr/bin/env python3
"""itgfx alone, 3D registration variants on seeded phantom pairs drawn as in imaging3d_vs_simpleitk.py.

Usage:  /tmp/sitkenv/bin/python bench/imaging3d_levels.py ITGFX FIRST_SEED LAST_SEED NAME=METRIC:LEVELS ...
        (it imports the benchmark script, hence SimpleITK) e.g. ... target/debug/itgfx 21 30 A=nmi:4:2,2:1,1:1 B=nmi:4:2,2:1,1:1,1:0 C=nmi:4:2,2:1,1:0.5
METRIC "default" passes no --metric. Pair k: random.Random(k) draws three angles in +-10 deg and a
shift in +-5 voxels; `itgfx phantom --dims 3` renders 64^3, noise 0.02, bias 0.1, seed k. Prints each
pair's rotation error (deg), translation error (voxels) and registration seconds per variant, then
success (<1 deg and <1 voxel), the count within 0.5/0.5, mean and median rotation error per variant.
Used to choose the volume defaults on seeds outside the benchmark's 1-20 (docs/IMAGING.md).
"""
import sys, os, json, math, random, statistics, tempfile, subprocess
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from imaging3d_vs_simpleitk import zyx, rotation_error
exe = sys.argv[1]; seeds = range(int(sys.argv[2]), int(sys.argv[3]) + 1)
variants = [v.split("=") for v in sys.argv[4:]]  # name=metric:levels
res = {n: [] for n, _ in variants}
with tempfile.TemporaryDirectory() as tmp:
    for k in seeds:
        g = random.Random(k)
        ang = [g.uniform(-10, 10) for _ in range(3)]; sh = [g.uniform(-5, 5) for _ in range(3)]
        d = f"{tmp}/{k}"
        subprocess.run([exe, "phantom", "--dims", "3", "--out", d, "--size", "64,64,64", "--rotation", ",".join(f"{v:.6f}" for v in ang),
            "--shift", ",".join(f"{v:.6f}" for v in sh), "--noise", "0.02", "--bias", "0.1", "--seed", str(k), "--json"], check=True, capture_output=True)
        truth = json.load(open(f"{d}/transform.json")); rt, tt = zyx(truth["rotation_deg"]), truth["translation"]
        line = f"{k:3d}"
        for n, spec in variants:
            metric, levels = spec.split(":", 1)
            cmd = [exe, "register", f"{d}/fixed.nrrd", f"{d}/moving.nrrd", "--out", f"{d}/{n}", "--levels", levels, "--json"]
            if metric != "default": cmd += ["--metric", metric]
            v = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            e = (rotation_error(zyx(v["rotation_deg"]), rt), math.dist(v["translation"], tt), v["seconds"])
            res[n].append(e); line += f" | {n} {e[0]:.3f} {e[1]:.3f} {e[2]:.1f}s"
        print(line, flush=True)
for n, r in res.items():
    rot = [a for a, _, _ in r]; tr = [b for _, b, _ in r]
    print(f"{n}: success {sum(a<1 and b<1 for a,b,_ in r)}/{len(r)} <0.5 {sum(a<0.5 and b<0.5 for a,b,_ in r)} mean rot {statistics.mean(rot):.3f} median {statistics.median(rot):.3f} mean tr {statistics.mean(tr):.3f} s {statistics.mean(c for *_, c in r):.1f}")
