//! The sealed float trait the core is generic over.
//!
//! Every kernel reads its inputs through [`Real::to_f64`] and accumulates in
//! `f64`, whatever the element type: an `f32` slice gets `f64` logarithms and
//! compensated `f64` sums, and only the final result is rounded back to `f32`
//! by [`Real::from_f64`]. Results for `f32` inputs are therefore the `f64`
//! results of the (exactly representable) `f32` inputs, rounded once: within
//! half an `f32` ulp of the exact value in the tests of `core/tests`.

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A floating-point element type accepted by the core: `f32` or `f64`.
///
/// The trait is sealed so that methods can be added without breaking users.
pub trait Real: sealed::Sealed + Copy + PartialOrd + core::fmt::Debug + Default + Send + Sync + 'static {
    /// How far `Σ p` may stray from 1 before a distribution is refused as
    /// [`crate::Error::NotNormalized`].
    ///
    /// `1e-9` for `f64` and `1e-5` for `f32`: a distribution normalised by
    /// dividing by its sum in the element type lands within about
    /// `n · ε / 2` of 1 only for naive sums; the core sums in compensated `f64`,
    /// so the remaining error is the rounding of each element (relative `ε/2`),
    /// far inside both tolerances.
    const MASS_TOLERANCE: f64;

    /// The value widened to `f64` (exact for both types).
    fn to_f64(self) -> f64;

    /// The nearest value of this type to `v`.
    fn from_f64(v: f64) -> Self;
}

impl Real for f64 {
    const MASS_TOLERANCE: f64 = 1e-9;
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v
    }
}

impl Real for f32 {
    const MASS_TOLERANCE: f64 = 1e-5;
    #[inline(always)]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    #[inline(always)]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
}
