//! Validating reduction kernels shared by every measure.
//!
//! Each kernel walks its slice once, in blocks of [`BLOCK`] elements with
//! four partial sums (see [`crate::sum`]). Validity (finite and non-negative)
//! is folded into the same pass as a flag; only a block whose flag is raised
//! is scanned again to name the first offending index.

use crate::math::{ln, xlnx};
use crate::sum::{BLOCK, Neumaier};
use crate::{Error, Real};

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

/// Checks every element is finite and non-negative; returns the compensated sum.
pub(crate) fn mass<T: Real>(xs: &[T]) -> Result<f64, Error> {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if crate::dispatch::avx2() {
        return crate::dispatch::mass(xs);
    }
    mass_body(xs)
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

/// Checks every element and returns `Σ x` and `Σ x ln x` in one pass.
pub(crate) fn mass_xlnx<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if crate::dispatch::avx2() {
        return crate::dispatch::mass_xlnx(xs);
    }
    mass_xlnx_body(xs)
}

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

/// Entropy in nats of non-negative weights `w / Σw`, robust to scale:
/// totals outside `[2^-900, 2^900]` (subnormal weights lose digits in
/// `x ln x`; huge ones overflow `Σw`) are recomputed after an exact
/// power-of-two rescaling by the largest weight. `None` for zero mass.
pub(crate) fn weights_entropy_nats<T: Real>(xs: &[T]) -> Result<Option<f64>, Error> {
    let m = mass_xlnx(xs)?;
    if m.sum == 0.0 {
        return Ok(None);
    }
    const LO: f64 = 1.0e-271; // ≈ 2^-900
    const HI: f64 = 1.0e271;
    if m.sum >= LO && m.sum <= HI {
        return Ok(Some(entropy_nats(m)));
    }
    let max = xs.iter().map(|x| x.to_f64()).fold(0.0, f64::max);
    // 2^-e with e the binary exponent of max (max is finite and positive).
    let e = libm::ilogb(max);
    let mut sum = Neumaier::new();
    let mut ent = Neumaier::new();
    for x in xs {
        // Per element: 2^-e itself may not be representable (e < -1023).
        let y = libm::scalbn(x.to_f64(), -e);
        sum.add(y);
        ent.add(xlnx(y));
    }
    Ok(Some(entropy_nats(Mass { sum: sum.value(), xlnx: ent.value() })))
}

/// Refuses zero mass and sums outside `T::MASS_TOLERANCE` of 1.
pub(crate) fn check_normalized<T: Real>(sum: f64) -> Result<(), Error> {
    if sum == 0.0 {
        return Err(Error::ZeroMass);
    }
    if !((sum - 1.0).abs() <= T::MASS_TOLERANCE) {
        return Err(Error::NotNormalized { sum });
    }
    Ok(())
}

/// Nats of entropy from a validated [`Mass`]: `ln S − (Σ x ln x)/S`.
///
/// The form divides out the residual normalisation error of `Σ x`, and is
/// exactly the entropy of the weights `x / S`.
#[inline]
pub(crate) fn entropy_nats(m: Mass) -> f64 {
    let h = ln(m.sum) - m.xlnx / m.sum;
    // Rounding can leave -1e-17 for a point mass; H ≥ 0 is exact maths.
    if h < 0.0 { 0.0 } else { h }
}

/// `x ln(x/y)` summed over two validated slices in one pass, with
/// `Σ x` and `Σ y` (nats). Conventions of Part II eq. (8).
pub(crate) fn kl_pass<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if crate::dispatch::avx2() {
        return crate::dispatch::kl_pass(p, q);
    }
    kl_pass_body(p, q)
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

/// Checks two slices have equal, non-zero lengths.
pub(crate) fn same_len(a: usize, b: usize) -> Result<(), Error> {
    if a == 0 || b == 0 {
        return Err(Error::Empty);
    }
    if a != b {
        return Err(Error::LengthMismatch { expected: a, found: b });
    }
    Ok(())
}

/// Checks a slice is non-empty.
pub(crate) fn non_empty(n: usize) -> Result<(), Error> {
    if n == 0 { Err(Error::Empty) } else { Ok(()) }
}
