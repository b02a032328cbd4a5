//! Throughput of the core reductions: `cargo bench -p itgfx-core --bench measures`.
//!
//! Prints one line per case: `name n seconds Melem/s` (best of several runs),
//! and, with `--json`, one JSON object per line for `bench/core_vs_scipy.py`.
//! Sizes: `ITGFX_BENCH_SIZES=1e6,1e7,1e8` (default). Single thread.

use std::hint::black_box;
use std::time::Instant;

use itgfx_core::{Base, Channel, entropy, kl_divergence};

fn xorshift(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

fn normalized(mut v: Vec<f64>) -> Vec<f64> {
    let s: f64 = v.iter().sum();
    v.iter_mut().for_each(|x| *x /= s);
    v
}

fn best(reps: usize, mut f: impl FnMut() -> f64) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    best
}

/// Double-double (TwoSum) accumulation, the accuracy reference.
fn dd_sum(xs: impl Iterator<Item = f64>) -> f64 {
    let (mut hi, mut lo) = (0.0f64, 0.0f64);
    for x in xs {
        let s = hi + x;
        let bp = s - hi;
        lo += (hi - (s - bp)) + (x - bp);
        hi = s;
        let t = hi + lo;
        lo -= t - hi;
        hi = t;
    }
    hi + lo
}

/// `--accuracy`: relative error of H(p) against a double-double reference of
/// libm terms, for each size.
fn accuracy(sizes: &[usize]) {
    for &n in sizes {
        let w = xorshift(7, n);
        let total = dd_sum(w.iter().copied());
        let p: Vec<f64> = w.iter().map(|x| x / total).collect();
        let reference = -dd_sum(p.iter().map(|&x| if x > 0.0 { x * libm_log(x) } else { 0.0 }));
        let got = entropy(&p, Base::Nats).unwrap();
        let naive: f64 = -p.iter().map(|&x| if x > 0.0 { x * x.ln() } else { 0.0 }).sum::<f64>();
        println!(
            "accuracy n={n:<10} H={got:.17} nats  relative error {:.2e} (naive left-to-right sum: {:.2e})",
            ((got - reference) / reference).abs(),
            ((naive - reference) / reference).abs()
        );
    }
}

fn libm_log(x: f64) -> f64 {
    // std's ln is correctly rounded to within 1 ulp like libm's.
    x.ln()
}

fn main() {
    let json = std::env::args().any(|a| a == "--json");
    if std::env::args().any(|a| a == "--accuracy") {
        let sizes: Vec<usize> = std::env::var("ITGFX_BENCH_SIZES")
            .unwrap_or_else(|_| "1e6,1e7,1e8".into())
            .split(',')
            .map(|s| s.trim().parse::<f64>().expect("ITGFX_BENCH_SIZES: numbers like 1e6") as usize)
            .collect();
        accuracy(&sizes);
        return;
    }
    let sizes: Vec<usize> = std::env::var("ITGFX_BENCH_SIZES")
        .unwrap_or_else(|_| "1e6,1e7,1e8".into())
        .split(',')
        .map(|s| s.trim().parse::<f64>().expect("ITGFX_BENCH_SIZES: numbers like 1e6") as usize)
        .collect();
    for &n in &sizes {
        let reps = if n >= 100_000_000 { 3 } else { 7 };
        let p = normalized(xorshift(1, n));
        let q = normalized(xorshift(2, n));
        let report = |name: &str, secs: f64| {
            let rate = n as f64 / secs / 1e6;
            if json {
                println!(
                    "{{\"impl\":\"itgfx\",\"case\":\"{name}\",\"n\":{n},\"seconds\":{secs:.6},\"melem_per_s\":{rate:.2}}}"
                );
            } else {
                println!("{name:<12} n={n:<10} {secs:>9.4} s {rate:>9.1} Melem/s");
            }
        };
        let t = best(reps, || entropy(&p, Base::Bits).unwrap());
        report("entropy", t);
        let t = best(reps, || kl_divergence(&p, &q, Base::Bits).unwrap());
        report("kl", t);
        // Channel MI on a square-ish n-element conditional matrix.
        let rows = (n as f64).sqrt() as usize;
        let cols = n / rows;
        let mut m = xorshift(3, rows * cols);
        for r in m.chunks_mut(cols) {
            let s: f64 = r.iter().sum();
            r.iter_mut().for_each(|x| *x /= s);
        }
        let input = normalized(xorshift(4, rows));
        let t = best(reps, || Channel::new(&input, &m, cols).unwrap().measures(Base::Bits).mutual_information);
        report("channel_mi", t);
    }
}
