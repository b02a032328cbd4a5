//! Entropy rate and excess entropy of stationary Markov chains (Part II §4).

use crate::matrix::MatrixRef;
use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx, same_len};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// Stationary distribution `w = wP` of an `n × n` row-stochastic matrix by
/// the Grassmann–Taksar–Heyman state reduction (GTH), written into `out`.
///
/// A direct method: `O(n³)` operations, no iteration and no tolerance, and
/// no subtraction anywhere (the diagonal is never read), so each `w_i` has a
/// small relative error even for nearly-decomposable chains whose
/// off-diagonal entries are 1e-12, which power iteration cannot resolve.
/// `scratch` holds the `n²` working copy of the matrix (row-major), so the
/// function allocates nothing. For a scene's form-factor matrix the answer is
/// the relative areas (Part III eq. (35)).
///
/// Which chains: the elimination needs every state to reach state 0 (then
/// the chain has exactly one closed class, it contains state 0, and `w` is
/// unique, with `w_i = 0` on transient states). Periodic chains are fine:
/// `w` is their unique solution of `w = wP`, though `X_t` does not converge
/// to it. A chain in which some state cannot reach state 0 (several closed
/// classes, or state 0 transient) is refused with
/// [`Error::ReducibleChain`], never iterated.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`] (also for `scratch.len() ≠ n²`),
/// the errors of [`MatrixRef::check_stochastic`], [`Error::ReducibleChain`].
pub fn stationary_distribution_into<T: Real>(
    transition: &[T],
    n: usize,
    out: &mut [f64],
    scratch: &mut [f64],
) -> Result<(), Error> {
    let p = MatrixRef::new(transition, n, n)?;
    p.check_stochastic()?;
    same_len(n, out.len())?;
    // n·n cannot overflow: MatrixRef checked transition.len() == n·n.
    same_len(n * n, scratch.len())?;
    for (dst, src) in scratch.iter_mut().zip(transition) {
        *dst = src.to_f64();
    }
    let a = scratch;
    // Reduce states n−1, …, 1: censor the chain on {0, …, k−1}.
    for k in (1..n).rev() {
        let (upper, lower) = a.split_at_mut(k * n);
        let row_k = &lower[..n];
        // Probability of leaving k for a lower state (no 1 − P_kk).
        let mut s = Neumaier::new();
        row_k[..k].iter().for_each(|&x| s.add(x));
        let s = s.value();
        if !(s > 0.0) {
            return Err(Error::ReducibleChain { state: k });
        }
        for i in 0..k {
            let row_i = &mut upper[i * n..i * n + n];
            let f = row_i[k] / s;
            row_i[k] = f;
            if f != 0.0 {
                for (x, &y) in row_i[..k].iter_mut().zip(&row_k[..k]) {
                    *x += f * y;
                }
            }
        }
    }
    // Back substitution: w_k = Σ_{i<k} w_i a_ik, all terms non-negative.
    out[0] = 1.0;
    for k in 1..n {
        let mut w = Neumaier::new();
        for i in 0..k {
            w.add(out[i] * a[i * n + k]);
        }
        out[k] = w.value();
        if out[k] > 1e250 {
            // Keep the unnormalised weights finite (w_0 tiny against w_k).
            out[..=k].iter_mut().for_each(|x| *x *= 1e-250);
        }
    }
    let mut total = Neumaier::new();
    out.iter().for_each(|&x| total.add(x));
    let total = total.value();
    out.iter_mut().for_each(|x| *x /= total);
    Ok(())
}

/// [`stationary_distribution_into`] with its `n²` scratch allocated here
/// (`alloc`); the allocation is requested fallibly.
///
/// # Errors
/// As [`stationary_distribution_into`], and [`Error::OutOfMemory`] if the
/// `8 n²`-byte scratch cannot be had.
#[cfg(feature = "alloc")]
pub fn stationary_distribution<T: Real>(transition: &[T], n: usize) -> Result<alloc::vec::Vec<f64>, Error> {
    MatrixRef::new(transition, n, n)?;
    let mut scratch = alloc::vec::Vec::new();
    let bytes = (n * n).saturating_mul(core::mem::size_of::<f64>());
    scratch.try_reserve_exact(n * n).map_err(|_| Error::OutOfMemory { bytes })?;
    scratch.resize(n * n, 0.0);
    let mut out = alloc::vec![0.0; n];
    stationary_distribution_into(transition, n, &mut out, &mut scratch)?;
    Ok(out)
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
        if wi > 0.0
            && let Ok(m) = mass_xlnx(p.row(i))
        {
            acc.add(wi * entropy_nats(m));
        }
    }
    acc.value()
}

/// Excess entropy of a stationary first-order Markov chain (Part II eq. (14)).
///
/// For such a chain `H(X_1..X_n) = H(w) + (n−1) h`, so the limit of
/// `H(X_1..X_n) − n h` is reached at every `n ≥ 1`: `E = H(w) − h`, the
/// mutual information between consecutive states. Closed form, one pass over
/// the matrix (`O(n²)`): no block entropies and no limit are computed.
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
