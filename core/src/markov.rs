//! Entropy rate and excess entropy of stationary Markov chains (Part II §4).

use crate::matrix::MatrixRef;
use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx, same_len};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// Stationary distribution `w = wP` of an `n × n` transition matrix, by
/// power iteration on the lazy chain `(I + P)/2` (same fixed points, never
/// periodic), written into `out`; `scratch` must also hold `n` values.
///
/// Stops when the L1 change of an iteration falls below `tol`.
/// For a scene's form-factor matrix the answer is the relative areas
/// (Part III eq. (35)).
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`], the errors of
/// [`MatrixRef::check_stochastic`], [`Error::InvalidParameter`] for a bad
/// `tol`, and [`Error::NotConverged`] after `max_iter` iterations.
pub fn stationary_distribution_into<T: Real>(
    transition: &[T],
    n: usize,
    tol: f64,
    max_iter: usize,
    out: &mut [f64],
    scratch: &mut [f64],
) -> Result<usize, Error> {
    let p = MatrixRef::new(transition, n, n)?;
    p.check_stochastic()?;
    same_len(n, out.len())?;
    same_len(n, scratch.len())?;
    if !(tol > 0.0 && tol.is_finite()) {
        return Err(Error::InvalidParameter { name: "tol", value: tol });
    }
    let uniform = 1.0 / n as f64;
    out.iter_mut().for_each(|w| *w = uniform);
    for it in 1..=max_iter {
        scratch.iter_mut().for_each(|v| *v = 0.0);
        for (i, &wi) in out.iter().enumerate() {
            if wi != 0.0 {
                for (v, pij) in scratch.iter_mut().zip(p.row(i)) {
                    *v += wi * pij.to_f64();
                }
            }
        }
        let mut change = 0.0;
        let mut total = 0.0;
        for (w, v) in out.iter_mut().zip(scratch.iter()) {
            let next = 0.5 * (*w + *v);
            change += (next - *w).abs();
            *w = next;
            total += next;
        }
        out.iter_mut().for_each(|w| *w /= total);
        if change < tol {
            return Ok(it);
        }
    }
    Err(Error::NotConverged { iterations: max_iter })
}

/// Entropy rate of a stationary Markov chain (Part II eq. (13)):
///
/// ```text
/// h = H(X_2|X_1) = − Σ_i w_i Σ_j P_ij log P_ij
/// ```
/// `stationary` is `w`; for a scene it is the relative areas and `h` is the
/// scene visibility entropy `H_S` (Part III eq. (39)).
///
/// # Errors
/// As [`crate::Channel::new`] with `w` as input.
pub fn entropy_rate<T: Real>(transition: &[T], stationary: &[T], base: Base) -> Result<T, Error> {
    let n = stationary.len();
    let p = MatrixRef::new(transition, n, n)?;
    check_normalized::<T>(mass(stationary)?)?;
    p.check_stochastic()?;
    Ok(T::from_f64(rate_nats(&p, stationary) * base.per_nat()))
}

fn rate_nats<T: Real>(p: &MatrixRef<'_, T>, w: &[T]) -> f64 {
    let mut acc = Neumaier::new();
    for (i, wi) in w.iter().enumerate() {
        let wi = wi.to_f64();
        if wi > 0.0 {
            if let Ok(m) = mass_xlnx(p.row(i)) {
                acc.add(wi * entropy_nats(m));
            }
        }
    }
    acc.value()
}

/// Excess entropy of a stationary first-order Markov chain (Part II eq. (14)).
///
/// For such a chain `H(X_1..X_n) = H(w) + (n−1) h`, so the limit of
/// `H(X_1..X_n) − n h` is reached at every `n ≥ 1`: `E = H(w) − h`, the
/// mutual information between consecutive states.
///
/// # Errors
/// As [`entropy_rate`].
pub fn markov_excess_entropy<T: Real>(transition: &[T], stationary: &[T], base: Base) -> Result<T, Error> {
    let h = entropy_rate(transition, stationary, Base::Nats)?.to_f64();
    let hw = entropy_nats(mass_xlnx(stationary)?);
    let e = hw - h;
    Ok(T::from_f64(if e < 0.0 { 0.0 } else { e * base.per_nat() }))
}

/// Finite-block estimate of the excess entropy (Part II eq. (14)) from the
/// block entropies `H_n = H(X_1..X_n)`, `n = 1..=N` (`blocks[n-1] = H_n`):
///
/// ```text
/// h_N = H_N − H_{N−1},   E_N = H_N − N h_N
/// ```
/// Returns `(h_N, E_N)`. With a single block, `h_1 = H_1` and `E_1 = 0`.
///
/// # Errors
/// [`Error::Empty`], [`Error::NonFinite`], [`Error::Negative`].
pub fn excess_entropy_from_blocks(blocks: &[f64]) -> Result<(f64, f64), Error> {
    crate::scan::non_empty(blocks.len())?;
    mass(blocks)?;
    let n = blocks.len();
    let hn = blocks[n - 1];
    let h = if n == 1 { hn } else { hn - blocks[n - 2] };
    Ok((h, hn - n as f64 * h))
}
