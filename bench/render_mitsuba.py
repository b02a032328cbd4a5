#!/usr/bin/env python3
"""Peer check of `itgfx render`: Mitsuba 3 renders the same scene (geometry,
materials, camera, image size) that `itgfx render --export-scene` wrote, in
the same run, and we compare mean radiance, per-pixel relMSE and throughput.

    python3 -m venv /tmp/mtsenv && /tmp/mtsenv/bin/pip install mitsuba numpy
    /tmp/mtsenv/bin/python bench/render_mitsuba.py [--scene cornell-box] [--size 128x128] [--spp 256]

Mitsuba setup matching itgfx: `scalar_rgb`, `path` integrator with unlimited
depth, box reconstruction filter, independent sampler, `twosided` diffuse
(itgfx reflects on both sides), `conductor` with material `none` scaled by
the mirror reflectance, one-sided `area` emitters, face normals (no smoothing).
Throughput is Msamples/s = pixels x spp / seconds, after a warm-up render, with
the image read back before the clock stops; itgfx's comes from its own JSON.
The noise floor is the relMSE between two renders of the same renderer with different
seeds; with independent noise relMSE(itgfx, mitsuba) is about the mean of the two floors.
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/itgfx")
    ap.add_argument("--scene", default="cornell-box")
    ap.add_argument("--size", default="128x128")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--out", default="/tmp/itgfx-render-mitsuba")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    a = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    common = [a.scene, "--size", a.size, "--spp", str(a.spp), "--threads", str(a.threads)]
    j1 = itgfx(a.bin, common + ["--out", f"{a.out}/itgfx-1", "--seed", "1", "--export-scene"])
    j2 = itgfx(a.bin, common + ["--out", f"{a.out}/itgfx-2", "--seed", "2"])
    desc = json.load(open(f"{a.out}/itgfx-1/scene.json"))
    w, h = desc["width"], desc["height"]
    cam = desc["camera"]
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective",
            "fov": cam["fov_y_degrees"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
            "sampler": {"type": "independent", "sample_count": a.spp},
            "film": {"type": "hdrfilm", "width": w, "height": h, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
    }
    for k, m in enumerate(desc["materials"]):
        if m["mirror"]:
            bsdf = {"type": "conductor", "material": "none",
                    "specular_reflectance": {"type": "rgb", "value": m["reflectance"]}}
        else:
            bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["reflectance"]}}
        shape = {"type": "obj", "filename": f"{a.out}/itgfx-1/{m['file']}", "face_normals": True,
                 "bsdf": {"type": "twosided", "bsdf": bsdf}}
        if max(m["radiance"]) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["radiance"]}}
        scene[f"shape{k}"] = shape
    sc = mi.load_dict(scene)
    mi.set_log_level(mi.LogLevel.Warn)
    np.array(mi.render(sc, spp=1))  # warm-up
    t0 = time.perf_counter()
    img = np.array(mi.render(sc, seed=7, spp=a.spp), dtype=np.float64)[:, :, :3]
    secs = time.perf_counter() - t0
    mi.Bitmap(img.astype(np.float32)).write(f"{a.out}/mitsuba.exr")
    img2 = np.array(mi.render(sc, seed=8, spp=a.spp), dtype=np.float64)[:, :, :3]
    i1 = read_exr(mi, f"{a.out}/itgfx-1/image.exr")
    i2 = read_exr(mi, f"{a.out}/itgfx-2/image.exr")
    y1, y2, ym = luminance(i1), luminance(i2), luminance(img)
    n = y1.size
    # Standard error of an image's mean luminance from the two itgfx seeds' difference.
    se = float(np.std(y1 - y2) / np.sqrt(2 * n))
    ms = w * h * a.spp / secs / 1e6
    res = {
        "scene": a.scene, "size": f"{w}x{h}", "spp": a.spp, "threads": a.threads,
        "mean_Y_itgfx_seed1": float(y1.mean()), "mean_Y_itgfx_seed2": float(y2.mean()),
        "mean_Y_mitsuba": float(ym.mean()), "se_mean_Y": se,
        "mitsuba_minus_itgfx_in_se": float((ym.mean() - y1.mean()) / (se * np.sqrt(2))),
        "mean_rgb_itgfx": i1.reshape(-1, 3).mean(0).tolist(), "mean_rgb_mitsuba": img.reshape(-1, 3).mean(0).tolist(),
        "relMSE_itgfx_vs_mitsuba": rel_mse(i1, img), "relMSE_itgfx_seed1_vs_seed2": rel_mse(i1, i2),
        "relMSE_mitsuba_seed7_vs_seed8": rel_mse(img, img2),
        # Independent noise only: relMSE(itgfx, mitsuba) ~ (floor_itgfx + floor_mitsuba) / 2.
        "relMSE_expected_from_noise": (rel_mse(i1, i2) + rel_mse(img, img2)) / 2,
        "Msamples_per_s_itgfx": j1["Msamples_per_s"], "Msamples_per_s_mitsuba_scalar_rgb": ms,
        "ratio_itgfx_over_mitsuba": j1["Msamples_per_s"] / ms,
        "mitsuba_version": mi.__version__,
    }
    json.dump(res, open(f"{a.out}/peer.json", "w"), indent=1)
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    sys.exit(main())
