//! The one error type of the core.

use core::fmt;

/// Why a measure refused its input.
///
/// Checks run in a fixed order: emptiness, shapes and lengths, then each
/// element (`NonFinite` before `Negative`), then the total mass, then the
/// normalisation tolerance. Values the mathematics defines are never errors:
/// `KL(p‖q)` with `p_i > 0 = q_i` is `+∞`, and `0 · log 0 = 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// An input slice was empty.
    Empty,
    /// A slice had `found` elements where `expected` were needed.
    LengthMismatch {
        /// Elements needed.
        expected: usize,
        /// Elements given.
        found: usize,
    },
    /// Element `index` was NaN or infinite.
    NonFinite {
        /// Position of the offending element (row-major for matrices).
        index: usize,
    },
    /// Element `index` was negative.
    Negative {
        /// Position of the offending element (row-major for matrices).
        index: usize,
    },
    /// All weights were zero, so nothing can be normalised.
    ZeroMass,
    /// A probability distribution summed to `sum`, outside the tolerance
    /// [`crate::Real::MASS_TOLERANCE`] around 1.
    NotNormalized {
        /// The compensated sum that was found.
        sum: f64,
    },
    /// Row `row` of a conditional (row-stochastic) matrix summed to `sum`.
    RowNotNormalized {
        /// The offending row.
        row: usize,
        /// Its sum.
        sum: f64,
    },
    /// A scalar parameter was outside its domain.
    InvalidParameter {
        /// The parameter's name as the docs spell it.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A group label was not below the number of groups.
    LabelOutOfRange {
        /// Position of the label.
        index: usize,
        /// The label.
        label: usize,
        /// The number of groups.
        groups: usize,
    },
    /// An iterative method did not reach its tolerance.
    NotConverged {
        /// Iterations spent.
        iterations: usize,
    },
    /// A Markov chain with more than one closed class: state `state` never
    /// reaches the closed class found first, so the stationary distribution
    /// is not unique.
    ReducibleChain {
        /// A state that never reaches the closed class found first.
        state: usize,
    },
    /// An owned helper (`alloc`) could not allocate `bytes` bytes.
    OutOfMemory {
        /// Bytes requested.
        bytes: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::Empty => write!(f, "input is empty"),
            Error::LengthMismatch { expected, found } => {
                write!(f, "length mismatch: expected {expected} values, found {found}")
            }
            Error::NonFinite { index } => write!(f, "value at index {index} is not finite"),
            Error::Negative { index } => write!(f, "value at index {index} is negative"),
            Error::ZeroMass => write!(f, "all values are zero"),
            Error::NotNormalized { sum } => {
                write!(f, "probabilities sum to {sum}, not 1 (unnormalised data are weights: normalise them first)")
            }
            Error::RowNotNormalized { row, sum } => {
                write!(f, "row {row} of the conditional matrix sums to {sum}, not 1")
            }
            Error::InvalidParameter { name, value } => {
                write!(f, "parameter {name} = {value} is outside its domain")
            }
            Error::LabelOutOfRange { index, label, groups } => {
                write!(f, "label {label} at index {index} is not below the number of groups {groups}")
            }
            Error::NotConverged { iterations } => {
                write!(f, "did not converge in {iterations} iterations")
            }
            Error::ReducibleChain { state } => write!(
                f,
                "the Markov chain has more than one closed class (state {state} never reaches the first found), so no unique stationary distribution"
            ),
            Error::OutOfMemory { bytes } => write!(f, "cannot allocate {bytes} bytes"),
        }
    }
}

impl core::error::Error for Error {}
