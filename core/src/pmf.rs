//! Validated, borrowed probability distributions.

use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx};
use crate::{Base, Error, Real};

/// A borrowed probability mass function: finite, non-negative, summing to 1
/// within [`Real::MASS_TOLERANCE`].
///
/// Validate once with [`Pmf::new`]; the methods then cannot fail.
///
/// # Examples
/// ```
/// use itgfx_core::{Base, Pmf};
/// let p = Pmf::new(&[0.5f64, 0.25, 0.25]).unwrap();
/// assert!((p.entropy(Base::Bits) - 1.5).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Pmf<'a, T> {
    p: &'a [T],
}

impl<'a, T: Real> Pmf<'a, T> {
    /// Validates `p` as a distribution.
    ///
    /// # Errors
    /// [`Error::Empty`], [`Error::NonFinite`], [`Error::Negative`],
    /// [`Error::ZeroMass`], [`Error::NotNormalized`].
    pub fn new(p: &'a [T]) -> Result<Self, Error> {
        if p.is_empty() {
            return Err(Error::Empty);
        }
        check_normalized::<T>(mass(p)?)?;
        Ok(Self { p })
    }

    /// The probabilities.
    #[must_use]
    pub fn as_slice(&self) -> &'a [T] {
        self.p
    }

    /// Number of outcomes (zeros included).
    #[must_use]
    pub fn len(&self) -> usize {
        self.p.len()
    }

    /// Always false: a `Pmf` has at least one outcome.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Shannon entropy `H(p)` (Part II eq. (2)) in `base`.
    #[must_use]
    pub fn entropy(&self, base: Base) -> f64 {
        // Already validated: the scan cannot fail.
        match mass_xlnx(self.p) {
            Ok(m) => entropy_nats(m) * base.per_nat(),
            Err(_) => f64::NAN,
        }
    }
}
