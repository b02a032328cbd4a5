#!/usr/bin/env python3
"""Rigid 3D MI registration of volumes: itgfx against SimpleITK (Euler3DTransform, Mattes MI), in the same run.

Usage:  python3 bench/imaging3d_vs_simpleitk.py [--itgfx target/debug/itgfx] [--pairs 20]
            [--size 64,64,64] [--max-angle 10] [--max-shift 5] [--noise 0.02] [--bias 0.1]
            [--bins 32] [--sigmas 2,1,0.5] [--itgfx-metric default] [--threads 1] [--csv out.csv]

For pair k (seed k = 1..pairs) a true transform is drawn with Python's random.Random(k):
three angles ~ U[-max_angle, max_angle] degrees (about x, y, z; R = Rz Ry Rx) and a
shift ~ U[-max_shift, max_shift]^3 voxels (spacing 1); `itgfx phantom --dims 3` renders
the two-modality pair (noise, bias field, seed k) as NRRD and writes transform.json.
Both registrations start from the identity (the draws are random starting offsets: the
capture range) with the same pyramid (shrink 4,2,1; Gaussian sigma --sigmas voxels at
full resolution, then shrinking), the same bins and every voxel sampled:
  itgfx      `itgfx register FIXED.nrrd MOVING.nrrd --bins B --levels 4:s1,2:s2,1:s3`
             (Parzen joint histogram, Powell with Brent line searches)
  SimpleITK  Mattes MI (B bins, sampling NONE), linear interpolation, Euler3DTransform
             (ComputeZYX on: itgfx's convention) about the volume centre
             (CenteredTransformInitializer GEOMETRY), regular-step gradient descent with
             ITK ImageRegistration4's settings (max step 2, min step 0.001, 200 iterations,
             relaxation 0.8), scales from physical shift.
Errors are computed here, the same way for both, from each system's rotation matrix and
translation: rotation error = angle of R_found R_true^T, translation error = |t_found -
t_true| in voxels. Success: rotation error < --success-deg (1) and translation error <
--success-voxels (1), as `itgfx register`'s `success` for volumes; the counts at 0.5 degree /
0.5 voxel are printed too.
Time: itgfx's in-process registration seconds (its JSON `seconds`, NRRD I/O excluded) and
the whole process; SimpleITK's Execute() only, limited to --threads threads (itgfx's
registration is single-threaded).
"""
import argparse, json, math, random, statistics, sys, tempfile, time

import SimpleITK as sitk

from imaging_vs_simpleitk import run, sitk_method


def zyx(angles_deg):
    """R = Rz(c) Ry(b) Rx(a), rows."""
    a, b, c = (math.radians(v) for v in angles_deg)
    rx = [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]
    ry = [[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]]
    rz = [[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]]
    mul = lambda p, q: [[sum(p[i][k] * q[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return mul(rz, mul(ry, rx))


def rotation_error(ra, rb):
    tr = sum(ra[i][k] * rb[i][k] for i in range(3) for k in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2))))


def itgfx_register(exe, d, bins, sigmas, metric):
    levels = ",".join(f"{s}:{g:g}" for s, g in zip([4, 2, 1], sigmas))
    # "default": no --metric, what a user running `itgfx register` on volumes gets.
    chosen = [] if metric == "default" else ["--metric", metric]
    t = time.perf_counter()
    out = run([exe, "register", f"{d}/fixed.nrrd", f"{d}/moving.nrrd", "--truth", f"{d}/transform.json",
               "--out", f"{d}/itgfx", "--bins", str(bins), "--levels", levels, "--json"] + chosen)
    wall = time.perf_counter() - t
    v = json.loads(out)
    return zyx(v["rotation_deg"]), v["translation"], v["seconds"], wall, v["iterations"]


def sitk_register(d, bins, sigmas):
    fixed = sitk.ReadImage(f"{d}/fixed.nrrd", sitk.sitkFloat32)
    moving = sitk.ReadImage(f"{d}/moving.nrrd", sitk.sitkFloat32)
    e = sitk.Euler3DTransform()
    e.SetComputeZYX(True)
    tx = sitk.CenteredTransformInitializer(fixed, moving, e, sitk.CenteredTransformInitializerFilter.GEOMETRY)
    r = sitk_method(bins, sigmas)
    r.SetInitialTransform(tx, inPlace=False)
    t = time.perf_counter()
    out = r.Execute(fixed, moving)
    secs = time.perf_counter() - t
    e = sitk.Euler3DTransform(out.GetNthTransform(0) if out.GetName() == "CompositeTransform" else out)
    m = e.GetMatrix()
    rot = [list(m[0:3]), list(m[3:6]), list(m[6:9])]
    # itgfx's centre is the volume centre with origin 0, as GEOMETRY's: same translation.
    centre = fixed.TransformContinuousIndexToPhysicalPoint([(n - 1) / 2 for n in fixed.GetSize()])
    assert max(abs(a - b) for a, b in zip(e.GetCenter(), centre)) < 1e-6
    return rot, list(e.GetTranslation()), secs, r.GetOptimizerIteration()


def summary(rows, key, ok_deg, ok_vox):
    rot = [r[key]["rot"] for r in rows]
    tr = [r[key]["trans"] for r in rows]
    ok = [a < ok_deg and b < ok_vox for a, b in zip(rot, tr)]
    ok1 = sum(a < 0.5 and b < 0.5 for a, b in zip(rot, tr))
    okr = [a for a, s in zip(rot, ok) if s]
    okt = [b for b, s in zip(tr, ok) if s]
    se = lambda v: statistics.stdev(v) / math.sqrt(len(v)) if len(v) > 1 else float("nan")
    mean = lambda v: statistics.mean(v) if v else float("nan")
    return dict(success=sum(ok), success1=ok1, n=len(rows), rot=mean(rot), rot_med=statistics.median(rot),
                trans=mean(tr), trans_med=statistics.median(tr), rot_ok=mean(okr), rot_ok_se=se(okr),
                trans_ok=mean(okt), trans_ok_se=se(okt), secs=mean([r[key]["secs"] for r in rows]),
                iters=mean([r[key]["iters"] for r in rows]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--itgfx", default="target/debug/itgfx")
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--size", default="64,64,64")
    ap.add_argument("--max-angle", type=float, default=10.0)
    ap.add_argument("--max-shift", type=float, default=5.0)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--bias", type=float, default=0.1)
    ap.add_argument("--bins", type=int, default=32)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--sigmas", default="2,1,0.5",
                    help="Gaussian sigma per level (shrink 4,2,1), voxels; 2,1,0.5 is itgfx's default for volumes")
    ap.add_argument("--itgfx-metric", default="default", choices=["default", "mi", "nmi", "ecc", "mi-over-joint"],
                    help="default: no --metric (nmi for volumes)")
    ap.add_argument("--success-deg", type=float, default=1.0)
    ap.add_argument("--success-voxels", type=float, default=1.0)
    ap.add_argument("--csv")
    a = ap.parse_args()
    sitk.ProcessObject.SetGlobalDefaultNumberOfThreads(a.threads)
    sig = [float(x) for x in a.sigmas.split(",")]
    assert len(sig) == 3, "--sigmas needs three values"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(1, a.pairs + 1):
            g = random.Random(k)
            ang = [g.uniform(-a.max_angle, a.max_angle) for _ in range(3)]
            sh = [g.uniform(-a.max_shift, a.max_shift) for _ in range(3)]
            d = f"{tmp}/{k}"
            run([a.itgfx, "phantom", "--dims", "3", "--out", d, "--size", a.size,
                 "--rotation", ",".join(f"{v:.6f}" for v in ang), "--shift", ",".join(f"{v:.6f}" for v in sh),
                 "--noise", str(a.noise), "--bias", str(a.bias), "--seed", str(k), "--json"])
            truth = json.load(open(f"{d}/transform.json"))
            rt, tt = zyx(truth["rotation_deg"]), truth["translation"]
            err = lambda r, t: (rotation_error(r, rt), math.dist(t, tt))
            ir, it, isecs, iwall, iit = itgfx_register(a.itgfx, d, a.bins, sig, a.itgfx_metric)
            sr, st, ssecs, sit = sitk_register(d, a.bins, sig)
            (ie, ite), (se_, ste) = err(ir, it), err(sr, st)
            rows.append(dict(seed=k, angles=ang, shift=sh,
                             itgfx=dict(rot=ie, trans=ite, secs=isecs, wall=iwall, iters=iit),
                             sitk=dict(rot=se_, trans=ste, secs=ssecs, iters=sit)))
            print(f"{k:3d} truth ({ang[0]:+6.2f},{ang[1]:+6.2f},{ang[2]:+6.2f} deg; {sh[0]:+5.2f},{sh[1]:+5.2f},"
                  f"{sh[2]:+5.2f})  itgfx {ie:.3f} deg {ite:.3f} vox {isecs:.2f}s | SimpleITK {se_:.3f} deg "
                  f"{ste:.3f} vox {ssecs:.2f}s", file=sys.stderr, flush=True)
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("seed,ax,ay,az,sx,sy,sz,itgfx_rot,itgfx_trans,itgfx_s,sitk_rot,sitk_trans,sitk_s\n")
            for r in rows:
                f.write(",".join([str(r["seed"])] + [f"{v:.4f}" for v in r["angles"] + r["shift"]] +
                                 [f"{r[s][q]:.5f}" for s in ("itgfx", "sitk") for q in ("rot", "trans", "secs")]) + "\n")
    i = summary(rows, "itgfx", a.success_deg, a.success_voxels)
    s = summary(rows, "sitk", a.success_deg, a.success_voxels)
    iw = statistics.mean(r["itgfx"]["wall"] for r in rows)
    print(f"{a.pairs} pairs {a.size} voxels, angles U[-{a.max_angle},{a.max_angle}]^3 deg, shift "
          f"U[-{a.max_shift},{a.max_shift}]^3 voxels, noise {a.noise}, bias {a.bias}, {a.bins} bins, itgfx metric "
          f"{a.itgfx_metric}, shrink 4,2,1 with sigma {a.sigmas}, SimpleITK {sitk.Version.VersionString()} on "
          f"{a.threads} thread(s)\n")
    print(f"| system | success (<{a.success_deg:g} deg & <{a.success_voxels:g} vox) | within 0.5 deg & 0.5 vox | "
          "mean rot. err. (deg) | median rot. err. | mean transl. err. (vox) | median transl. err. | "
          "successes: rot. ± s.e. | successes: transl. ± s.e. | iterations | s / pair |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, v, extra in [("itgfx", i, f" ({iw:.2f} whole process)"), ("SimpleITK", s, "")]:
        print(f"| {name} | {v['success']}/{v['n']} | {v['success1']}/{v['n']} | {v['rot']:.3f} | {v['rot_med']:.3f} | "
              f"{v['trans']:.3f} | {v['trans_med']:.3f} | {v['rot_ok']:.3f} ± {v['rot_ok_se']:.3f} | "
              f"{v['trans_ok']:.3f} ± {v['trans_ok_se']:.3f} | {v['iters']:.1f} | {v['secs']:.2f}{extra} |")


if __name__ == "__main__":
    main()
