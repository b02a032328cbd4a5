#!/usr/bin/env python3
"""Stacks the renders bench/simplify_table.py left behind into one labelled
picture per mesh and target: rows original, VMI/BLEND (the default: placed
vertex, VMI + quadric order), VMI/ENDPOINT (half-edge), FQMS, QEM; columns the
first four evaluation views (none of them a channel viewpoint).

Usage: simplify_images.py BENCH_OUT MESH TARGET OUT.png   (needs Pillow)
"""

import os
import sys

from PIL import Image, ImageDraw

out_dir, mesh, target, dest = sys.argv[1:5]
base = os.path.join(out_dir, mesh)
rows = [
    ("original", os.path.join(base, "vmi-blend", "original.png")),
    ("VMI/BLEND", os.path.join(base, "vmi-blend", f"simplified_{target}.png")),
    ("VMI/END", os.path.join(base, "vmi-endpoint", f"simplified_{target}.png")),
    ("FQMS", os.path.join(base, "fqms", f"fqms_{target}.png")),
    ("QEM", os.path.join(base, "qem", f"qem_{target}.png")),
]
imgs = [(label, Image.open(p).convert("RGB")) for label, p in rows]
w, h = imgs[0][1].size
pad = 70
sheet = Image.new("RGB", (w + pad, h * len(imgs)), (24, 24, 28))
draw = ImageDraw.Draw(sheet)
for k, (label, img) in enumerate(imgs):
    sheet.paste(img, (pad, k * h))
    draw.text((8, k * h + h // 2 - 6), label, fill=(230, 230, 230))
sheet.save(dest, optimize=True)
