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

#[inline(always)]
fn bad(x: f64) -> bool {
    // NaN fails both comparisons; +inf fails the second; negatives the first.
    !(x >= 0.0 && x <= f64::MAX)
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

/// Checks every element and returns `Σ x` and `Σ x ln x` in one pass.
pub(crate) fn mass_xlnx<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    let mut sum = Neumaier::new();
    let mut ent = Neumaier::new();
    for (b, block) in xs.chunks(BLOCK).enumerate() {
        let mut s = [0.0f64; 4];
        let mut h = [0.0f64; 4];
        let mut flag = false;
        let mut quads = block.chunks_exact(4);
        for q in &mut quads {
            for l in 0..4 {
                let x = q[l].to_f64();
                flag |= bad(x);
                s[l] += x;
                h[l] += xlnx(x);
            }
        }
        for x in quads.remainder() {
            let x = x.to_f64();
            flag |= bad(x);
            s[0] += x;
            h[0] += xlnx(x);
        }
        if flag {
            first_invalid(block, b * BLOCK)?;
        }
        sum.add((s[0] + s[1]) + (s[2] + s[3]));
        ent.add((h[0] + h[1]) + (h[2] + h[3]));
    }
    Ok(Mass { sum: sum.value(), xlnx: ent.value() })
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
    let mut sp = Neumaier::new();
    let mut sq = Neumaier::new();
    let mut d = Neumaier::new();
    for (b, (bp, bq)) in p.chunks(BLOCK).zip(q.chunks(BLOCK)).enumerate() {
        let mut a = [0.0f64; 2];
        let mut c = [0.0f64; 2];
        let mut k = [0.0f64; 2];
        let mut flag = false;
        let mut pairs = bp.chunks_exact(2).zip(bq.chunks_exact(2));
        for (x2, y2) in &mut pairs {
            for l in 0..2 {
                let (x, y) = (x2[l].to_f64(), y2[l].to_f64());
                flag |= bad(x) | bad(y);
                a[l] += x;
                c[l] += y;
                k[l] += kl_term(x, y);
            }
        }
        let done = bp.len() & !1;
        for (x, y) in bp[done..].iter().zip(&bq[done..]) {
            let (x, y) = (x.to_f64(), y.to_f64());
            flag |= bad(x) | bad(y);
            a[0] += x;
            c[0] += y;
            k[0] += kl_term(x, y);
        }
        if flag {
            first_invalid(bp, b * BLOCK)?;
            first_invalid(bq, b * BLOCK)?;
        }
        sp.add(a[0] + a[1]);
        sq.add(c[0] + c[1]);
        d.add(k[0] + k[1]);
    }
    Ok((sp.value(), sq.value(), d.value()))
}

/// One term `x ln(x/y)`: one logarithm of the ratio where it is a positive
/// finite double, two logarithms otherwise (ratios that under- or overflow).
#[inline(always)]
pub(crate) fn kl_term(x: f64, y: f64) -> f64 {
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
