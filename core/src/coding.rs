//! Optimal prefix codes and the source coding bounds (Part II §6, eqs. (23)–(25)).

use crate::scan::{check_normalized, mass, non_empty};
use crate::{Error, Real};

/// Expected length `ℓ̄ = Σ p_i ℓ_i` (bits per symbol) of a binary Huffman
/// code for `p`, allocation-free with a caller's `scratch` of `p.len()` values.
///
/// Satisfies `H(p) ≤ ℓ̄ < H(p) + 1` (Part II eq. (24)). Symbols of zero
/// probability are left out of the tree (they add nothing to `ℓ̄`), and a
/// distribution with one possible symbol needs 0 bits. The expected length
/// equals the sum of the weights of the internal nodes of the Huffman tree;
/// the two-queue construction keeps its internal-node queue in the slots of
/// leaves already consumed, so `scratch` needs only one value per symbol.
///
/// # Errors
/// As [`crate::Pmf::new`], and [`Error::LengthMismatch`] if `scratch` is too short.
///
/// # Examples
/// ```
/// use itgfx_core::huffman_expected_length;
/// let mut scratch = [0.0; 4];
/// let l = huffman_expected_length(&[0.5f64, 0.25, 0.125, 0.125], &mut scratch).unwrap();
/// assert_eq!(l, 1.75); // dyadic: equal to the entropy
/// ```
pub fn huffman_expected_length<T: Real>(p: &[T], scratch: &mut [f64]) -> Result<f64, Error> {
    non_empty(p.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    let n = p.len();
    if scratch.len() < n {
        return Err(Error::LengthMismatch { expected: n, found: scratch.len() });
    }
    // Zero-probability symbols cost nothing and must not deepen the tree.
    let mut k = 0;
    for x in p {
        let x = x.to_f64();
        if x > 0.0 {
            scratch[k] = x / s;
            k += 1;
        }
    }
    Ok(huffman_in_place(&mut scratch[..k]))
}

/// Sum of internal node weights of the Huffman tree of `w` (destroys `w`).
pub(crate) fn huffman_in_place(w: &mut [f64]) -> f64 {
    let n = w.len();
    if n < 2 {
        return 0.0;
    }
    w.sort_unstable_by(f64::total_cmp);
    // Leaves: w[leaf..n]; internal queue: w[head..tail], tail ≤ leaf always.
    let (mut leaf, mut head, mut tail) = (0usize, 0usize, 0usize);
    let mut total = 0.0;
    for _ in 0..n - 1 {
        let pick = |leaf: &mut usize, head: &mut usize, tail: usize, w: &[f64]| -> f64 {
            let take_leaf = *leaf < n && (*head >= tail || w[*leaf] <= w[*head]);
            if take_leaf {
                *leaf += 1;
                w[*leaf - 1]
            } else {
                *head += 1;
                w[*head - 1]
            }
        };
        let a = pick(&mut leaf, &mut head, tail, w);
        let b = pick(&mut leaf, &mut head, tail, w);
        let merged = a + b;
        total += merged;
        // Slot `tail` is free: at least tail + 2 items were consumed from the
        // front, and only `tail` of them could be internal nodes.
        w[tail] = merged;
        tail += 1;
    }
    total
}

/// Most block symbols `n^k` [`huffman_block_length`] builds (2^22).
#[cfg(feature = "alloc")]
pub const HUFFMAN_MAX_BLOCKS: u64 = 1 << 22;

/// Expected code length per symbol `ℓ̄_k / k` of a Huffman code over blocks
/// of `k` independent symbols from `p` (Part II eq. (25)):
/// `H(p) ≤ ℓ̄_k / k < H(p) + 1/k`.
///
/// Builds the `n^k` block distribution.
///
/// # Errors
/// As [`crate::Pmf::new`]; [`Error::InvalidParameter`] if `k = 0` or `n^k`
/// exceeds [`HUFFMAN_MAX_BLOCKS`] symbols.
#[cfg(feature = "alloc")]
pub fn huffman_block_length<T: Real>(p: &[T], k: u32) -> Result<f64, Error> {
    use alloc::vec::Vec;
    non_empty(p.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    let n = p.len();
    let size = (n as u64).checked_pow(k).filter(|&m| k > 0 && m <= HUFFMAN_MAX_BLOCKS);
    let Some(size) = size else {
        return Err(Error::InvalidParameter { name: "k", value: f64::from(k) });
    };
    let base: Vec<f64> = p.iter().map(|x| x.to_f64() / s).filter(|&x| x > 0.0).collect();
    let mut blocks = Vec::with_capacity(size as usize);
    blocks.push(1.0f64);
    for _ in 0..k {
        let mut next = Vec::with_capacity(blocks.len() * n);
        for &b in &blocks {
            for &x in &base {
                next.push(b * x);
            }
        }
        blocks = next;
    }
    Ok(huffman_in_place(&mut blocks) / f64::from(k))
}
