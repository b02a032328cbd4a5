//! The unit of logarithmic measures.

/// The base of the logarithm a measure is reported in.
///
/// Kernels compute in nats and convert once. The default is bits, the unit
/// of the tutorial (Part II eq. (2)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Base {
    /// Base 2: bits (shannons).
    #[default]
    Bits,
    /// Base e: nats.
    Nats,
    /// Base 10: hartleys (bans).
    Hartleys,
}

impl Base {
    /// The factor that converts nats into this unit (`1 / ln b`).
    #[must_use]
    #[inline]
    pub const fn per_nat(self) -> f64 {
        match self {
            Base::Bits => core::f64::consts::LOG2_E,
            Base::Nats => 1.0,
            Base::Hartleys => core::f64::consts::LOG10_E,
        }
    }

    /// `ln b`, the size of one unit in nats.
    #[must_use]
    #[inline]
    pub const fn nats(self) -> f64 {
        match self {
            Base::Bits => core::f64::consts::LN_2,
            Base::Nats => 1.0,
            Base::Hartleys => core::f64::consts::LN_10,
        }
    }

    /// `log_b(x)` for `x > 0`.
    #[must_use]
    #[inline]
    pub fn log(self, x: f64) -> f64 {
        libm::log(x) * self.per_nat()
    }

    /// Short unit name: `"bits"`, `"nats"` or `"hartleys"`.
    #[must_use]
    pub const fn unit(self) -> &'static str {
        match self {
            Base::Bits => "bits",
            Base::Nats => "nats",
            Base::Hartleys => "hartleys",
        }
    }
}
