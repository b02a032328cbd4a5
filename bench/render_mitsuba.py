#!/usr/bin/env python3
"""Peer check of `itgfx render` against Mitsuba 3: the same scene (geometry,
materials, camera, image size, written by `itgfx render --export-scene`),
rendered by both in the same run; prints per scene the speed of each, the
noise floor of each and the efficiency, and the mean radiance of both.

Setup (Mitsuba 3.9.1; its fast CPU variant `llvm_ad_rgb` needs libLLVM,
any version Dr.Jit accepts; 19 is known to work):

    python3 -m venv /tmp/mtsenv && /tmp/mtsenv/bin/pip install mitsuba numpy
    apt-get download libllvm19 && dpkg-deb -x libllvm19_*.deb /tmp/llvm19/root
    export DRJIT_LIBLLVM_PATH=/tmp/llvm19/root/usr/lib/x86_64-linux-gnu/libLLVM-19.so
    cargo build --release --locked
    /tmp/mtsenv/bin/python bench/render_mitsuba.py [--scenes cornell-box,mirror-room]
        [--size 256x256] [--spp 256] [--threads 2] [--variant llvm_ad_rgb|scalar_rgb] [--json]

Mitsuba setup matching itgfx: `path` integrator with unlimited depth (its
Russian roulette from depth 5, as itgfx's), box reconstruction filter,
`independent` sampler, `twosided` diffuse (itgfx reflects on both sides),
`conductor` with material `none` scaled by the mirror reflectance, one-sided
`area` emitters, face normals (no smoothing).

Timing, the same way for both: the wall time of the render alone, scene
loading and acceleration-structure builds excluded, the better of the two
seeds' renders. Mitsuba's clock runs from `mi.render` until the image is read
back into numpy, after a warm-up render of the same scene (the llvm variant
JIT-compiles its kernels on the first render); itgfx's is the `seconds` of its
`--json` (from the start of the pixel loop until the frame is in memory,
before files are written). Both run on `--threads` threads (Mitsuba through
`drjit.set_thread_count`). Msamples/s = pixels x spp / seconds.

Noise floor = relMSE between two renders of the same renderer with different
seeds (relMSE = mean (a - b)^2 / (b^2 + 0.01) over pixels and channels);
efficiency = (itgfx Msamples/s / Mitsuba Msamples/s) x (Mitsuba's floor /
itgfx's floor): above 1, itgfx reaches a given image quality sooner. With
independent noise relMSE(itgfx, Mitsuba) is about the mean of the two floors,
and the mean luminances agree within a few standard errors.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np


def itgfx(binary, args):
    out = subprocess.run([binary, "render", *args, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def read_exr(mi, path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def rel_mse(a, b):
    return float(np.mean((a - b) ** 2 / (b * b + 0.01)))


def luminance(img):
    return img[:, :, 0] * 0.2126 + img[:, :, 1] * 0.7152 + img[:, :, 2] * 0.0722


def mitsuba_scene(mi, desc, folder, spp):
    cam = desc["camera"]
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective",
            "fov": cam["fov_y_degrees"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": desc["width"], "height": desc["height"],
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
    }
    for k, m in enumerate(desc["materials"]):
        if m["mirror"]:
            bsdf = {"type": "conductor", "material": "none",
                    "specular_reflectance": {"type": "rgb", "value": m["reflectance"]}}
        else:
            bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["reflectance"]}}
        shape = {"type": "obj", "filename": f"{folder}/{m['file']}", "face_normals": True,
                 "bsdf": {"type": "twosided", "bsdf": bsdf}}
        if max(m["radiance"]) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["radiance"]}}
        scene[f"shape{k}"] = shape
    return mi.load_dict(scene)


def timed_render(mi, sc, seed, spp):
    t0 = time.perf_counter()
    img = np.array(mi.render(sc, seed=seed, spp=spp), dtype=np.float64)[:, :, :3]
    return img, time.perf_counter() - t0


def compare(mi, a, scene):
    common = [scene, "--size", a.size, "--spp", str(a.spp), "--threads", str(a.threads)]
    out = f"{a.out}/{scene}"
    j1 = itgfx(a.bin, common + ["--out", f"{out}/itgfx-1", "--seed", "1", "--export-scene"])
    j2 = itgfx(a.bin, common + ["--out", f"{out}/itgfx-2", "--seed", "2"])
    desc = json.load(open(f"{out}/itgfx-1/scene.json"))
    w, h = desc["width"], desc["height"]
    sc = mitsuba_scene(mi, desc, f"{out}/itgfx-1", a.spp)
    np.array(mi.render(sc, seed=0, spp=a.spp))  # warm-up: JIT compilation, caches
    img, s1 = timed_render(mi, sc, 7, a.spp)
    img2, s2 = timed_render(mi, sc, 8, a.spp)
    mi.Bitmap(img.astype(np.float32)).write(f"{out}/mitsuba.exr")
    i1 = read_exr(mi, f"{out}/itgfx-1/image.exr")
    i2 = read_exr(mi, f"{out}/itgfx-2/image.exr")
    y1, y2, ym = luminance(i1), luminance(i2), luminance(img)
    # Standard error of an image's mean luminance from the two itgfx seeds' difference.
    se = float(np.std(y1 - y2) / np.sqrt(2 * y1.size))
    samples = w * h * a.spp
    speed_i = samples / min(j1["seconds"], j2["seconds"]) / 1e6
    speed_m = samples / min(s1, s2) / 1e6
    floor_i, floor_m = rel_mse(i1, i2), rel_mse(img, img2)
    return {
        "scene": scene, "size": f"{w}x{h}", "spp": a.spp, "threads": a.threads, "variant": a.variant,
        "Msamples_per_s_itgfx": speed_i, "Msamples_per_s_mitsuba": speed_m,
        "seconds_itgfx": [j1["seconds"], j2["seconds"]], "seconds_mitsuba": [s1, s2],
        "speed_ratio": speed_i / speed_m,
        "noise_floor_itgfx": floor_i, "noise_floor_mitsuba": floor_m,
        "efficiency": speed_i / speed_m * floor_m / floor_i,
        "mean_Y_itgfx_seed1": float(y1.mean()), "mean_Y_itgfx_seed2": float(y2.mean()),
        "mean_Y_mitsuba": float(ym.mean()), "se_mean_Y": se,
        "mitsuba_minus_itgfx_in_se": float((ym.mean() - y1.mean()) / (se * np.sqrt(2))),
        "mean_rgb_itgfx": i1.reshape(-1, 3).mean(0).tolist(), "mean_rgb_mitsuba": img.reshape(-1, 3).mean(0).tolist(),
        "relMSE_itgfx_vs_mitsuba": rel_mse(i1, img),
        "relMSE_expected_from_noise": (floor_i + floor_m) / 2,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default="target/release/itgfx")
    ap.add_argument("--scenes", "--scene", default="cornell-box,mirror-room", help="comma-separated scenes")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant (llvm_ad_rgb, scalar_rgb, ...)")
    ap.add_argument("--out", default="/tmp/itgfx-render-mitsuba")
    ap.add_argument("--json", action="store_true", help="one JSON object on stdout instead of the table")
    a = ap.parse_args()
    if a.spp < 1 or a.threads < 1:
        print("render_mitsuba: --spp and --threads must be at least 1", file=sys.stderr)
        return 2
    if "llvm" in a.variant and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        print("render_mitsuba: note: DRJIT_LIBLLVM_PATH is not set (see the docstring)", file=sys.stderr)
    import drjit as dr
    import mitsuba as mi

    try:
        mi.set_variant(a.variant)
    except Exception as e:  # an unknown variant, or libLLVM not found
        print(f"render_mitsuba: variant {a.variant}: {e}", file=sys.stderr)
        return 2
    dr.set_thread_count(a.threads)
    mi.set_log_level(mi.LogLevel.Warn)
    rows = [compare(mi, a, s) for s in a.scenes.split(",") if s]
    res = {"mitsuba_version": mi.__version__, "variant": a.variant, "scenes": rows}
    os.makedirs(a.out, exist_ok=True)
    json.dump(res, open(f"{a.out}/peer.json", "w"), indent=1)
    if a.json:
        print(json.dumps(res, indent=1))
        return 0
    print(f"Mitsuba {mi.__version__} {a.variant}, {a.size}, {a.spp} spp, {a.threads} threads")
    print(f"{'scene':13s} {'itgfx Ms/s':>10s} {'Mitsuba Ms/s':>12s} {'speed':>6s} "
          f"{'floor itgfx':>11s} {'floor Mitsuba':>13s} {'efficiency':>10s} {'mean Y itgfx / Mitsuba (SE)':>30s}")
    for r in rows:
        print(f"{r['scene']:13s} {r['Msamples_per_s_itgfx']:10.3f} {r['Msamples_per_s_mitsuba']:12.3f} "
              f"{r['speed_ratio']:5.2f}x {r['noise_floor_itgfx']:11.5f} {r['noise_floor_mitsuba']:13.5f} "
              f"{r['efficiency']:9.2f}x {r['mean_Y_itgfx_seed1']:>14.5f} / {r['mean_Y_mitsuba']:.5f} "
              f"({r['mitsuba_minus_itgfx_in_se']:+.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
