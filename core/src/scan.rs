//! Validating reductions shared by every measure: the dispatched kernels
//! ([`crate::dispatch`] over [`crate::kernels`]) and the checks around them.

pub(crate) use crate::dispatch::{kl_pass, mass, mass_xlnx};
use crate::kernels::Mass;
use crate::math::{ln, xlnx};
use crate::matrix::{MatrixRef, offset};
use crate::sum::Neumaier;
use crate::{Error, Real};

impl<T: Real> MatrixRef<'_, T> {
    /// Checks the matrix is a joint distribution (all entries sum to 1).
    ///
    /// # Errors
    /// As [`crate::Pmf::new`], indices row-major.
    pub fn check_joint(&self) -> Result<(), Error> {
        check_normalized::<T>(mass(self.data())?)
    }

    /// Checks every row is a distribution (a channel's conditional matrix).
    ///
    /// # Errors
    /// [`Error::NonFinite`]/[`Error::Negative`] (row-major index),
    /// [`Error::RowNotNormalized`].
    pub fn check_stochastic(&self) -> Result<(), Error> {
        for i in 0..self.rows() {
            let s = mass(self.row(i)).map_err(|e| offset(e, i * self.cols()))?;
            if !((s - 1.0).abs() <= T::MASS_TOLERANCE) {
                return Err(Error::RowNotNormalized { row: i, sum: s });
            }
        }
        Ok(())
    }
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
