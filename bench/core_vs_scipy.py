#!/usr/bin/env python3
"""Core reductions: itgfx-core against numpy/scipy, measured in the same run.

Usage:  python3 bench/core_vs_scipy.py [--native] [--sizes 1e6,1e7,1e8]

Builds and runs `cargo bench -p itgfx-core --bench measures -- --json`
(default build: portable x86-64 with run-time AVX2 dispatch; with --native
also RUSTFLAGS='-C target-cpu=native'),
then times the scipy equivalents on the same kind of data (uniform weights
normalised, one thread), and prints a Markdown table of throughputs and ratios.
Peers:
  entropy     scipy.stats.entropy(p, base=2)
  kl          scipy.special.rel_entr(p, q).sum() / ln 2
  channel_mi  q = p_x @ P; (p_x[:, None] * rel_entr(P, q)).sum() / ln 2
"""
import argparse, json, os, subprocess, sys, time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import scipy, scipy.stats, scipy.special  # noqa: E402


def best(reps, f):
    t = float("inf")
    for _ in range(reps):
        s = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - s)
    return t


def scipy_rows(sizes):
    rows = []
    rng = np.random.default_rng(1)
    for n in sizes:
        reps = 3 if n >= 10**8 else 7
        p = rng.random(n); p /= p.sum()
        q = rng.random(n); q /= q.sum()
        rows.append(("entropy", n, best(reps, lambda: scipy.stats.entropy(p, base=2))))
        rows.append(("kl", n, best(reps, lambda: scipy.special.rel_entr(p, q).sum() / np.log(2))))
        del q
        r = int(n ** 0.5); c = n // r
        m = rng.random((r, c)); m /= m.sum(axis=1, keepdims=True)
        px = rng.random(r); px /= px.sum()
        def mi():
            qy = px @ m
            return (px[:, None] * scipy.special.rel_entr(m, qy[None, :])).sum() / np.log(2)
        rows.append(("channel_mi", n, best(reps, mi)))
        del m, p
    return rows


def itgfx_rows(sizes, native):
    env = dict(os.environ, ITGFX_BENCH_SIZES=",".join(str(n) for n in sizes))
    if native:
        env["RUSTFLAGS"] = "-C target-cpu=native"
        env["CARGO_TARGET_DIR"] = "target/native"
    out = subprocess.run(["cargo", "bench", "-q", "-p", "itgfx-core", "--bench", "measures", "--", "--json"],
                         env=env, check=True, capture_output=True, text=True).stdout
    return [(j["case"], j["n"], j["seconds"]) for j in map(json.loads, filter(None, out.splitlines()))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--native", action="store_true", help="also measure a -C target-cpu=native build")
    ap.add_argument("--sizes", default="1e6,1e7,1e8")
    a = ap.parse_args()
    sizes = [int(float(s)) for s in a.sizes.split(",")]
    builds = [("default", itgfx_rows(sizes, False))]
    if a.native:
        builds.append(("native", itgfx_rows(sizes, True)))
    peer = {(c, n): t for c, n, t in scipy_rows(sizes)}
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    print(f"machine: {cpu}, {os.cpu_count()} cores; numpy {np.__version__}, scipy {scipy.__version__}; one thread\n")
    head = "| case | n | scipy Melem/s | " + " | ".join(f"itgfx {b} Melem/s | ratio" for b, _ in builds) + " |"
    print(head)
    print("|" + "---|" * (3 + 2 * len(builds)))
    for (case, n), t in sorted(peer.items(), key=lambda kv: (kv[0][0], kv[0][1])):
        cells = [case, f"1e{len(str(n)) - 1}", f"{n / t / 1e6:.0f}"]
        for _, rows in builds:
            ti = next(s for c, m, s in rows if c == case and m == n)
            cells += [f"{n / ti / 1e6:.0f}", f"{t / ti:.2f}x"]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    sys.exit(main())
