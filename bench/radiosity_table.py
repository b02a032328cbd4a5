#!/usr/bin/env python3
"""Aggregates bench/radiosity_table.sh's JSON into the markdown table of
docs/RADIOSITY.md: mean and sample standard deviation over seeds; "search s" is
solve_seconds (every bisection trial), "absorbed/emitted" the JSON's balance."""
import glob
import json
import os
import statistics
import sys

out = sys.argv[1]
rows = {}
for f in sorted(glob.glob(os.path.join(out, "*-*-*.json"))):
    d = json.load(open(f))
    name = os.path.basename(f)[:-5]
    oracle, n, seed = name.rsplit("-", 2)
    rows.setdefault((int(n), oracle), []).append(d)
ref = json.load(open(os.path.join(out, "ref.json")))
print(f"reference: {ref['walks_per_pixel']} walks/pixel, {ref['rays']} rays, {ref['seconds']:.0f} s, "
      f"own noise RMSE_a {ref['noise_RMSE_a']:.2f}, RMSE_p {ref['noise_RMSE_p']:.2f} (8-bit)\n")
order = ["power", "ks", "ks-avg", "mi", "kl", "cs", "hl", "variance"]
print("| target | oracle | elements | links | rays | RMSE_a | RMSE_p | PSNR_a | PSNR_p | absorbed/emitted | search s | seeds |")
print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")


def ms(v, digits=2):
    if len(v) > 1:
        return f"{statistics.mean(v):.{digits}f} ± {statistics.stdev(v):.{digits}f}"
    return f"{v[0]:.{digits}f}"


for n in sorted({k[0] for k in rows}):
    for o in order:
        ds = rows.get((n, o))
        if not ds:
            continue
        g = lambda k: [d[k] for d in ds]
        print(f"| {n} | {o} | {statistics.mean(g('elements')):.0f} | {statistics.mean(g('links')):.0f} | "
              f"{statistics.mean(g('rays')):.3g} | {ms(g('RMSE_a'))} | {ms(g('RMSE_p'))} | {ms(g('PSNR_a'))} | "
              f"{ms(g('PSNR_p'))} | {ms(g('balance'), 3)} | {statistics.mean(g('solve_seconds')):.1f} | {len(ds)} |")
