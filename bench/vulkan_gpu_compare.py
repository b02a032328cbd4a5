#!/usr/bin/env python3
"""Reads the folder bench/vulkan_gpu.sh wrote: checks that every step's JSON is the same on each backend
(the keys that are timings, the backend's name, memory estimates and the host's share of rays aside) and prints
a Markdown table of wall and CPU seconds with the Vulkan backend's speed against the CPU backend's.

    python3 bench/vulkan_gpu_compare.py OUT
"""
import json
import sys
from pathlib import Path

VOLATILE = ("seconds", "backend", "memory_estimate", "vulkan_rays_finished_on_host")


def flat(o, p=""):
    if isinstance(o, dict):
        for k, v in o.items():
            yield from flat(v, p + "." + k)
    elif isinstance(o, list):
        for i, v in enumerate(o):
            yield from flat(v, f"{p}[{i}]")
    else:
        yield p, o


def stable(path):
    d = dict(flat(json.loads(path.read_text())))
    return {k: v for k, v in d.items() if not any(w in k for w in VOLATILE)}


def main():
    out = Path(sys.argv[1])
    rows = {}
    for line in (out / "times.tsv").read_text().splitlines():
        name, rc, wall, user, sys_ = line.split("\t")
        rows[name] = (int(rc), float(wall), user, sys_)
    steps = sorted({n.rsplit(".", 1)[0] for n in rows if "." in n and not n.startswith("vulkan_bench")})
    print("| work | backend | wall s | user + sys CPU s | JSON/image as cpu, 2 threads | Vulkan's speed-up |")
    print("|---|---|---|---|---|---|")
    for s in steps:
        backs = [n.rsplit(".", 1)[1] for n in rows if n.rsplit(".", 1)[0] == s]
        ref = None
        vk = rows.get(f"{s}.vulkan")
        for b in backs:
            rc, wall, user, sys_ = rows[f"{s}.{b}"]
            same = ""
            if rc != 0:
                same = f"exit {rc}"
            elif s == "render":
                a = (out / "render.cpu2" / "image.exr").read_bytes()
                same = "identical" if (out / f"render.{b}" / "image.exr").read_bytes() == a else "DIFFERENT"
            else:
                j = stable(out / f"{s}.{b}.out")
                if ref is None:
                    ref = stable(out / f"{s}.cpu2.out")
                diff = sorted(k for k in set(j) | set(ref) if j.get(k) != ref.get(k))
                same = "identical" if not diff else f"DIFFERENT: {', '.join(diff[:4])}"
            speed = ""
            if vk and vk[0] == 0 and b != "vulkan" and rc == 0:
                speed = f"{wall / vk[1]:.2f}x"
            try:
                cpu = f"{float(user) + float(sys_):.2f}"
            except ValueError:
                cpu = "?"
            print(f"| {s} | {b} | {wall:.2f} | {cpu} | {same} | {speed} |")


if __name__ == "__main__":
    main()
