//! The kernel bodies: each walks its slices once, in blocks of
//! [`BLOCK`] elements with several partial sums (see [`crate::sum`]).
//! Validity (finite and non-negative) is folded into the same pass as a
//! flag; only a block whose flag is raised is scanned again to name the
//! first offending index.
//!
//! Nothing here chooses a build: [`crate::dispatch`], the layer above, runs
//! each body compiled for the widest SIMD the CPU has, and the measures call
//! the dispatch layer (through [`crate::scan`]).

use crate::math::{ln, xlnx};
use crate::matrix::{MatrixRef, for_column_blocks};
use crate::sum::{BLOCK, Neumaier};
use crate::{Error, Real};

/// `out[i] = ln(xs[i])` over the shorter slice, element by element (what
/// [`crate::dispatch::ln_into`] compiles per build).
#[inline(always)]
pub(crate) fn ln_into_body(xs: &[f64], out: &mut [f64]) {
    for (o, &x) in out.iter_mut().zip(xs) {
        *o = ln(x);
    }
}

/// `out[i] = kl_term(x[i], y[i])` ([`kl_term`]) over the shortest slice:
/// first `x ln(x/y)` on every element without branches (the lanes where
/// [`kl_term`] takes that path: `x, y > 0` and `x/y` positive and finite),
/// then [`kl_term`] itself on the other lanes. What
/// [`crate::dispatch::kl_terms_into`] compiles per build.
#[inline(always)]
pub(crate) fn kl_terms_body(x: &[f64], y: &[f64], out: &mut [f64]) {
    let fast = |x: f64, y: f64, r: f64| x > 0.0 && y > 0.0 && r > 0.0 && r <= f64::MAX;
    for ((o, &x), &y) in out.iter_mut().zip(x).zip(y) {
        let r = x / y;
        *o = x * ln(if fast(x, y, r) { r } else { 1.0 });
    }
    for ((o, &x), &y) in out.iter_mut().zip(x).zip(y) {
        if !fast(x, y, x / y) {
            *o = kl_term(x, y);
        }
    }
}

/// `Σ x` and `Σ x ln x` of a validated slice (nats).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Mass {
    pub sum: f64,
    pub xlnx: f64,
}

// `&` rather than `contains` (which short-circuits): branch-free in the lanes.
#[allow(clippy::manual_range_contains)]
#[inline(always)]
fn bad(x: f64) -> bool {
    // NaN fails both comparisons; +inf fails the second; negatives the first.
    !((x >= 0.0) & (x <= f64::MAX))
}

/// The first invalid element of `xs`, as an error, offset by `base`.
pub(crate) fn first_invalid<T: Real>(xs: &[T], base: usize) -> Result<(), Error> {
    for (i, x) in xs.iter().enumerate() {
        let x = x.to_f64();
        if !x.is_finite() {
            return Err(Error::NonFinite { index: base + i });
        }
        if x < 0.0 {
            return Err(Error::Negative { index: base + i });
        }
    }
    Ok(())
}

#[inline(always)]
pub(crate) fn mass_body<T: Real>(xs: &[T]) -> Result<f64, Error> {
    let mut total = Neumaier::new();
    for (b, block) in xs.chunks(BLOCK).enumerate() {
        let mut acc = [0.0f64; 4];
        let mut flag = false;
        let mut quads = block.chunks_exact(4);
        for q in &mut quads {
            for l in 0..4 {
                let x = q[l].to_f64();
                flag |= bad(x);
                acc[l] += x;
            }
        }
        for x in quads.remainder() {
            let x = x.to_f64();
            flag |= bad(x);
            acc[0] += x;
        }
        if flag {
            first_invalid(block, b * BLOCK)?;
        }
        total.add((acc[0] + acc[1]) + (acc[2] + acc[3]));
    }
    Ok(total.value())
}

/// Whether `r` is a positive normal double (branch-free).
#[allow(clippy::manual_range_contains)]
#[inline(always)]
fn normal_ratio(r: f64) -> bool {
    (r >= f64::MIN_POSITIVE) & (r <= f64::MAX)
}

/// Lanes of the unrolled inner loops: wide enough for the SLP vectoriser
/// to fill 2- to 8-wide registers and hide the latency of `ln`.
const LANES: usize = 8;

#[inline(always)]
pub(crate) fn mass_xlnx_body<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    let mut sum = Neumaier::new();
    let mut ent = Neumaier::new();
    for (b, block) in xs.chunks(BLOCK).enumerate() {
        let mut s = [0.0f64; LANES];
        let mut h = [0.0f64; LANES];
        let mut flag = [false; LANES];
        let mut lanes = block.chunks_exact(LANES);
        for q in &mut lanes {
            let mut x = [0.0f64; LANES];
            for l in 0..LANES {
                x[l] = q[l].to_f64();
            }
            for l in 0..LANES {
                flag[l] |= bad(x[l]);
                s[l] += x[l];
                h[l] += xlnx(x[l]);
            }
        }
        for x in lanes.remainder() {
            let x = x.to_f64();
            flag[0] |= bad(x);
            s[0] += x;
            h[0] += xlnx(x);
        }
        if flag.iter().any(|&f| f) {
            first_invalid(block, b * BLOCK)?;
        }
        sum.add(lane_sum(&s));
        ent.add(lane_sum(&h));
    }
    Ok(Mass { sum: sum.value(), xlnx: ent.value() })
}

#[inline(always)]
fn lane_sum(a: &[f64; LANES]) -> f64 {
    ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))
}

#[inline(always)]
pub(crate) fn kl_pass_body<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    let mut sp = Neumaier::new();
    let mut sq = Neumaier::new();
    let mut d = Neumaier::new();
    for (b, (bp, bq)) in p.chunks(BLOCK).zip(q.chunks(BLOCK)).enumerate() {
        let mut a = [0.0f64; LANES];
        let mut c = [0.0f64; LANES];
        let mut k = [0.0f64; LANES];
        let mut inf = [false; LANES];
        let mut odd = [false; LANES];
        let mut flag = [false; LANES];
        let mut lanes = bp.chunks_exact(LANES).zip(bq.chunks_exact(LANES));
        for (xs, ys) in &mut lanes {
            let mut x = [0.0f64; LANES];
            let mut y = [0.0f64; LANES];
            for l in 0..LANES {
                x[l] = xs[l].to_f64();
                y[l] = ys[l].to_f64();
            }
            for l in 0..LANES {
                flag[l] |= bad(x[l]) | bad(y[l]);
                a[l] += x[l];
                c[l] += y[l];
                // Branch-free x ln(x/y): one division and one logarithm.
                // p > 0 = q is flagged (+∞); a ratio outside the normal
                // range sends the block to the two-logarithm path below.
                let xp = x[l] > 0.0;
                let yp = y[l] > 0.0;
                inf[l] |= xp & !yp;
                let both = xp & yp;
                let r = if both { x[l] / y[l] } else { 1.0 };
                odd[l] |= !normal_ratio(r);
                k[l] += if both { x[l] * ln(r) } else { 0.0 };
            }
        }
        if odd.iter().any(|&f| f) {
            // Rare: recompute the whole block with exact per-term handling.
            k = [0.0; LANES];
            let done = bp.len() - bp.len() % LANES;
            for (x, y) in bp[..done].iter().zip(&bq[..done]) {
                k[0] += kl_term(x.to_f64(), y.to_f64());
            }
        }
        let done = bp.len() - bp.len() % LANES;
        for (x, y) in bp[done..].iter().zip(&bq[done..]) {
            let (x, y) = (x.to_f64(), y.to_f64());
            flag[0] |= bad(x) | bad(y);
            a[0] += x;
            c[0] += y;
            k[0] += kl_term(x, y);
        }
        if flag.iter().any(|&f| f) {
            first_invalid(bp, b * BLOCK)?;
            first_invalid(bq, b * BLOCK)?;
        }
        sp.add(lane_sum(&a));
        sq.add(lane_sum(&c));
        d.add(if inf.iter().any(|&f| f) { f64::INFINITY } else { lane_sum(&k) });
    }
    Ok((sp.value(), sq.value(), d.value()))
}

/// One term `x ln(x/y)` of the Kullback–Leibler divergence (Part II
/// eq. (5)), infallible: 0 for `x ≤ 0` (`0 ln(0/y) = 0`), `+∞` for `x > 0`
/// and `y ≤ 0`; one logarithm of the ratio where it is a positive finite
/// double, two logarithms otherwise (ratios that under- or overflow).
#[inline(always)]
pub fn kl_term(x: f64, y: f64) -> f64 {
    if x > 0.0 {
        if y > 0.0 {
            let r = x / y;
            if r > 0.0 && r <= f64::MAX { x * ln(r) } else { x * (ln(x) - ln(y)) }
        } else {
            f64::INFINITY
        }
    } else {
        0.0
    }
}

#[inline(always)]
pub(crate) fn mixture_body<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    #[cfg(feature = "alloc")]
    if m.cols() > crate::matrix::COL_BLOCK {
        return mixture_streaming(w, m);
    }
    mixture_blocked(w, m)
}

/// Row-streaming form of [`mixture_body`] for wide matrices (`alloc`): the
/// mixture `m_j` and `ln m_j` go to heap buffers in one contiguous pass, the
/// terms in a second. The blocked form reads 256-column strips of every row
/// instead, which for a 10^4 × 10^4 matrix touches a new page per row and
/// strip.
#[cfg(feature = "alloc")]
#[inline(always)]
fn mixture_streaming<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    let cols = m.cols();
    let mut mix = alloc::vec![0.0f64; cols];
    for (i, wi) in w.iter().enumerate() {
        let wi = wi.to_f64();
        if wi != 0.0 {
            for (acc, x) in mix.iter_mut().zip(m.row(i)) {
                *acc += wi * x.to_f64();
            }
        }
    }
    let mut h = Neumaier::new();
    let lnm: alloc::vec::Vec<f64> = mix
        .iter()
        .map(|&x| {
            h.add(-xlnx(x));
            if x > 0.0 { ln(x) } else { 0.0 }
        })
        .collect();
    let mut d = Neumaier::new();
    let mut rows = Neumaier::new();
    for (i, wi) in w.iter().enumerate() {
        let wi = wi.to_f64();
        if wi == 0.0 {
            continue;
        }
        let (xl, xm) = row_terms(m.row(i), &lnm);
        d.add(wi * (xl - xm));
        rows.add(-wi * xl);
    }
    let v = d.value();
    (if v < 0.0 { 0.0 } else { v }, h.value(), rows.value())
}

/// `(Σ x ln x, Σ x ln m_j)` over one row segment, 8 lanes.
#[inline(always)]
fn row_terms<T: Real>(row: &[T], lnm: &[f64]) -> (f64, f64) {
    let mut xl = [0.0f64; 8];
    let mut xm = [0.0f64; 8];
    let mut lanes = row.chunks_exact(8).zip(lnm.chunks_exact(8));
    for (xs, ls) in &mut lanes {
        for l in 0..8 {
            let x = xs[l].to_f64();
            xl[l] += xlnx(x);
            xm[l] += x * ls[l];
        }
    }
    let done = row.len() - row.len() % 8;
    for (x, l) in row[done..].iter().zip(&lnm[done..]) {
        let x = x.to_f64();
        xl[0] += xlnx(x);
        xm[0] += x * l;
    }
    (xl.iter().sum(), xm.iter().sum())
}

#[inline(always)]
pub(crate) fn mixture_blocked<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    let mut d = Neumaier::new();
    let mut h = Neumaier::new();
    let mut rows = Neumaier::new();
    let mut lnm = [0.0f64; crate::matrix::COL_BLOCK];
    for_column_blocks(m, Some(w), |c0, mix| {
        for (l, &x) in lnm.iter_mut().zip(mix) {
            *l = if x > 0.0 { ln(x) } else { 0.0 };
            h.add(-xlnx(x));
        }
        let width = mix.len();
        for (i, wi) in w.iter().enumerate() {
            let wi = wi.to_f64();
            if wi == 0.0 {
                continue;
            }
            // x > 0 implies mix_j ≥ w_i x > 0, so ln mix_j is finite where used.
            let (xl, xm) = row_terms(&m.row(i)[c0..c0 + width], &lnm[..width]);
            d.add(wi * (xl - xm));
            rows.add(-wi * xl);
        }
    });
    let v = d.value();
    (if v < 0.0 { 0.0 } else { v }, h.value(), rows.value())
}
