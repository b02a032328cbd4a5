#!/usr/bin/env python3
"""The scene.xml round trip (issue 25): `itgfx render SCENE --export-scene`
writes scene.xml beside one OBJ per material; Mitsuba 3 renders that file
alone (`mi.load_file`, nothing added here), and its mean is compared with
itgfx's. itgfx also renders the scene.xml it wrote, which must give its own
image mean again (the reader round trip).

    /tmp/mtsenv/bin/python bench/mitsuba_scene_xml.py [--scene cornell-box] [--size 64x64] [--spp 256]
        [--variant scalar_rgb|llvm_ad_rgb]

llvm_ad_rgb needs DRJIT_LIBLLVM_PATH (e.g. /tmp/llvm19/root/usr/lib/x86_64-linux-gnu/libLLVM-19.so).
The standard error of a mean comes from two itgfx seeds' per-pixel difference;
`mitsuba_minus_itgfx_in_se` is the gap in units of the standard error of
the difference of two independent means (|x| < 3 is agreement).
Mitsuba stays out of CI.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np


def itgfx(binary, args):
    out = subprocess.run([binary, "render", *args, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def luminance(img):
    return img[:, :, 0] * 0.2126 + img[:, :, 1] * 0.7152 + img[:, :, 2] * 0.0722


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/itgfx")
    ap.add_argument("--scene", default="cornell-box")
    ap.add_argument("--size", default="64x64")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--out", default="/tmp/itgfx-mitsuba-scene-xml")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    a = ap.parse_args()
    import mitsuba as mi

    mi.set_variant(a.variant)
    common = ["--size", a.size, "--spp", str(a.spp), "--threads", str(a.threads)]
    j1 = itgfx(a.bin, [a.scene, *common, "--out", f"{a.out}/itgfx-1", "--seed", "1", "--export-scene"])
    j2 = itgfx(a.bin, [a.scene, *common, "--out", f"{a.out}/itgfx-2", "--seed", "2"])
    xml = f"{a.out}/itgfx-1/scene.xml"
    jx = itgfx(a.bin, [xml, *common, "--out", f"{a.out}/itgfx-xml", "--seed", "1"])
    scene = mi.load_file(xml)
    img = np.array(mi.render(scene, seed=7), dtype=np.float64)[:, :, :3]
    mi.Bitmap(img.astype(np.float32)).write(f"{a.out}/mitsuba.exr")

    def read(p):
        return np.array(mi.Bitmap(p), dtype=np.float64)[:, :, :3]

    i1, i2 = read(f"{a.out}/itgfx-1/image.exr"), read(f"{a.out}/itgfx-2/image.exr")
    y1, y2, ym = luminance(i1), luminance(i2), luminance(img)
    se = float(np.std(y1 - y2) / np.sqrt(2 * y1.size))
    res = {
        "scene": a.scene, "size": a.size, "spp": a.spp, "variant": a.variant, "mitsuba_version": mi.__version__,
        "mean_rgb_itgfx": i1.reshape(-1, 3).mean(0).tolist(),
        "mean_rgb_mitsuba_from_scene_xml": img.reshape(-1, 3).mean(0).tolist(),
        "mean_Y_itgfx": float(y1.mean()), "mean_Y_itgfx_seed2": float(y2.mean()),
        "mean_Y_mitsuba": float(ym.mean()), "se_mean_Y": se,
        "mitsuba_minus_itgfx_in_se": float((ym.mean() - y1.mean()) / (se * np.sqrt(2))),
        "relative_gap": float(ym.mean() / y1.mean() - 1),
        "itgfx_reads_its_scene_xml_same_mean": jx["mean_radiance"] == j1["mean_radiance"],
    }
    json.dump(res, open(f"{a.out}/scene_xml.json", "w"), indent=1)
    print(json.dumps(res, indent=1))
    return 0 if res["itgfx_reads_its_scene_xml_same_mean"] else 1


if __name__ == "__main__":
    sys.exit(main())
