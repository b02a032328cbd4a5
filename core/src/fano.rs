//! Fano's inequality (Part II eqs. (20)–(22)).

use crate::entropy::binary_entropy_nats;
use crate::math::ln;
use crate::{Base, Error};

/// The left side of Fano's inequality for an error probability `pe` over
/// `n` outcomes, in `base`:
///
/// ```text
/// H(P_e) + P_e log(n − 1)  ≥  H(X|Y)
/// ```
/// This is the sharp form; Part II eq. (21) prints `log n`, which is larger
/// and so also a valid (weaker) bound.
///
/// # Errors
/// [`Error::InvalidParameter`] for `pe ∉ [0, 1]` or `n < 1`.
pub fn fano_bound(pe: f64, n: usize, base: Base) -> Result<f64, Error> {
    if !(0.0..=1.0).contains(&pe) {
        return Err(Error::InvalidParameter { name: "pe", value: pe });
    }
    if n == 0 {
        return Err(Error::InvalidParameter { name: "n", value: 0.0 });
    }
    let tail = if n > 1 { pe * ln((n - 1) as f64) } else { 0.0 };
    Ok((binary_entropy_nats(pe) + tail) * base.per_nat())
}

/// The smallest error probability Fano's inequality allows for a given
/// conditional entropy `H(X|Y)` (in `base`) over `n` outcomes: the least
/// `P_e ∈ [0, (n−1)/n]` with `fano_bound(P_e) ≥ H(X|Y)`.
///
/// The bound is increasing on that interval, so bisection to 1e-15 finds it.
///
/// # Errors
/// [`Error::InvalidParameter`] for a negative or non-finite `h_cond`, or `n < 1`.
pub fn fano_minimum_error(h_cond: f64, n: usize, base: Base) -> Result<f64, Error> {
    if !(h_cond >= 0.0 && h_cond.is_finite()) {
        return Err(Error::InvalidParameter { name: "h_cond", value: h_cond });
    }
    if n == 0 {
        return Err(Error::InvalidParameter { name: "n", value: 0.0 });
    }
    let (mut lo, mut hi) = (0.0f64, (n - 1) as f64 / n as f64);
    if fano_bound(hi, n, base)? < h_cond {
        return Ok(hi);
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if fano_bound(mid, n, base)? >= h_cond {
            hi = mid;
        } else {
            lo = mid;
        }
        if hi - lo < 1e-15 {
            break;
        }
    }
    Ok(hi)
}

/// The weakened Fano bound of Part II eq. (22): `P_e ≥ (H(X|Y) − 1) / log₂ n`,
/// with `H(X|Y)` in bits. May be negative (then it says nothing).
///
/// # Errors
/// [`Error::InvalidParameter`] for `n < 2` or a non-finite `h_cond_bits`.
pub fn fano_weak_bound(h_cond_bits: f64, n: usize) -> Result<f64, Error> {
    if n < 2 {
        return Err(Error::InvalidParameter { name: "n", value: n as f64 });
    }
    if !h_cond_bits.is_finite() {
        return Err(Error::InvalidParameter { name: "h_cond", value: h_cond_bits });
    }
    Ok((h_cond_bits - 1.0) / (ln(n as f64) * Base::Bits.per_nat()))
}
