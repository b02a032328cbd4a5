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
/// Which chains: those with exactly one closed class, where `w` is unique,
/// with `w_i = 0` on transient states. The elimination needs every state to
/// reach the state it keeps last, so a state `r` of the closed class is
/// found first (by reachability over the edges `P_ij > 0`, `O(n²)` per
/// step, `recurrent_state`) and the chain is reduced with `r` and state 0
/// swapped; `r = 0` whenever every state reaches state 0, the common case.
/// Periodic chains are fine: `w` is their unique solution of `w = wP`,
/// though `X_t` does not converge to it. A chain with several closed
/// classes is refused with [`Error::ReducibleChain`], never iterated.
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
    let r = recurrent_state(transition, n, out, scratch)?;
    // π swaps 0 and r: the chain reduced is P'_ij = P_π(i)π(j).
    let pi = |i: usize| {
        if i == 0 {
            r
        } else if i == r {
            0
        } else {
            i
        }
    };
    for i in 0..n {
        for j in 0..n {
            scratch[i * n + j] = transition[pi(i) * n + pi(j)].to_f64();
        }
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
            // Not reached: every state reaches r (checked above); kept as
            // a guard against an underflowed censored row.
            return Err(Error::ReducibleChain { state: pi(k) });
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
    out.swap(0, r);
    Ok(())
}

/// Marks in `marks` (1 reached, 0 not) the states reachable from `start`
/// over the edges `P_ij > 0` (`forward`) or reaching it (`!forward`);
/// `stack` holds at most `n` indices. Returns how many were reached.
fn reach<T: Real>(t: &[T], n: usize, start: usize, forward: bool, marks: &mut [f64], stack: &mut [f64]) -> usize {
    marks.iter_mut().for_each(|m| *m = 0.0);
    marks[start] = 1.0;
    stack[0] = start as f64;
    let (mut top, mut count) = (1, 1);
    while top > 0 {
        top -= 1;
        let i = stack[top] as usize;
        for j in 0..n {
            let edge = if forward { t[i * n + j] } else { t[j * n + i] };
            if marks[j] == 0.0 && edge.to_f64() > 0.0 {
                marks[j] = 1.0;
                stack[top] = j as f64;
                top += 1;
                count += 1;
            }
        }
    }
    count
}

/// A state every state reaches (one of the closed class, when there is
/// exactly one), 0 if state 0 is one. From `r = 0`: if some state reachable
/// from `r` cannot return to it, that state becomes `r` (the states it
/// reaches are strictly fewer, so this ends within `n` steps); once none
/// can, `r`'s class is closed, and either every state reaches it or the
/// chain has another closed class. `out` (`n`) and `scratch` (`n²`) are
/// working space.
///
/// # Errors
/// [`Error::ReducibleChain`] naming a state that never reaches `r`'s class.
fn recurrent_state<T: Real>(t: &[T], n: usize, out: &mut [f64], scratch: &mut [f64]) -> Result<usize, Error> {
    if n == 1 {
        return Ok(0);
    }
    let back = out;
    let (fwd, rest) = scratch.split_at_mut(n);
    let stack = &mut rest[..n];
    let mut r = 0;
    loop {
        if reach(t, n, r, false, back, stack) == n {
            return Ok(r);
        }
        reach(t, n, r, true, fwd, stack);
        match (0..n).find(|&j| fwd[j] == 1.0 && back[j] == 0.0) {
            Some(j) => r = j,
            None => {
                let state = (0..n).find(|&j| back[j] == 0.0).unwrap_or(0);
                return Err(Error::ReducibleChain { state });
            }
        }
    }
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
