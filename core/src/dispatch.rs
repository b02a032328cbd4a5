//! The one SIMD dispatch layer: run-time selection of a wider build of the
//! hot kernels ([`crate::kernels`]).
//!
//! The kernels are written once, branch-free over 8 lanes, and compiled
//! three times: for the portable x86-64 baseline (SSE2, 2 lanes) and, inside
//! the `#[target_feature]` functions of [`x86`], for AVX2 + FMA (4 lanes) and
//! AVX-512 (8 lanes). With the `std` feature on x86-64, the CPU is asked
//! (std caches the answer) and the widest build it supports is used
//! (BENCHMARKS.md has the figures). Without `std`, or off x86-64, the
//! portable build is used; a no_std user can still get the fast build with
//! `-C target-cpu=x86-64-v3`. The measures call the four entry points here
//! (through [`crate::scan`]); this is the only file that names a build.
//!
//! This module holds the crate's only `unsafe`: calling a target-feature
//! function, which is sound exactly when the CPU has those features.

use crate::kernels::{Mass, kl_pass_body, kl_terms_body, ln_into_body, mass_body, mass_xlnx_body, mixture_body};
use crate::matrix::MatrixRef;
use crate::{Error, Real};

/// The widest build the CPU allows: 0 portable, 1 AVX2, 2 AVX-512.
#[inline]
fn level() -> u8 {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    return x86::level();
    #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
    0
}

/// Checks every element is finite and non-negative; returns the compensated sum.
#[allow(unsafe_code)]
pub(crate) fn mass<T: Real>(xs: &[T]) -> Result<f64, Error> {
    match level() {
        // SAFETY: `level()` ≥ 1 only when the CPU has AVX2 and FMA, every
        // feature `mass_avx2` enables (the AVX-512 build adds nothing here).
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1.. => unsafe { x86::mass_avx2(xs) },
        _ => mass_body(xs),
    }
}

/// Checks every element and returns `Σ x` and `Σ x ln x` in one pass.
#[allow(unsafe_code)]
pub(crate) fn mass_xlnx<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    match level() {
        // SAFETY: `level()` is 2 only when the CPU has AVX2, FMA and
        // AVX-512 F/DQ/VL, every feature the AVX-512 build enables.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        2.. => unsafe { x86::mass_xlnx_avx512(xs) },
        // SAFETY: `level()` is 1 only when the CPU has AVX2 and FMA.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1 => unsafe { x86::mass_xlnx_avx2(xs) },
        _ => mass_xlnx_body(xs),
    }
}

/// `x ln(x/y)` summed over two validated slices in one pass, with `Σ x` and
/// `Σ y` (nats). Conventions of Part II eq. (8).
#[allow(unsafe_code)]
pub(crate) fn kl_pass<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    match level() {
        // SAFETY: as in `mass_xlnx`: level 2 means every AVX-512 feature.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        2.. => unsafe { x86::kl_pass_avx512(p, q) },
        // SAFETY: as in `mass_xlnx`: level 1 means AVX2 and FMA.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1 => unsafe { x86::kl_pass_avx2(p, q) },
        _ => kl_pass_body(p, q),
    }
}

/// The channel/Jensen-Shannon kernel: `Σ_i w_i D_KL(M_i ‖ Σ_k w_k M_k)`,
/// `H(Σ w_i M_i)` and `Σ_i w_i H(M_i)` in nats.
#[allow(unsafe_code)]
pub(crate) fn mixture<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    match level() {
        // SAFETY: as in `mass_xlnx`: level 2 means every AVX-512 feature.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        2.. => unsafe { x86::mixture_avx512(w, m) },
        // SAFETY: as in `mass_xlnx`: level 1 means AVX2 and FMA.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1 => unsafe { x86::mixture_avx2(w, m) },
        _ => mixture_body(w, m),
    }
}

/// `out[i] = ln(xs[i])` ([`crate::math::ln`]) for the shorter of the two:
/// the same bits as the scalar call (no branches, no fused operations), a
/// few lanes at a time.
#[allow(unsafe_code)]
pub(crate) fn ln_into(xs: &[f64], out: &mut [f64]) {
    match level() {
        // SAFETY: `level()` ≥ 1 only when the CPU has AVX2 and FMA, every
        // feature `ln_into_avx2` enables.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1.. => unsafe { x86::ln_into_avx2(xs, out) },
        _ => ln_into_body(xs, out),
    }
}

/// The term `x ln(x/y)` of the Kullback–Leibler divergence (Part II eq.
/// (8)) of many pairs: `out[i] = kl_term(x[i], y[i])` for the shortest of
/// the three slices, bit for bit [`kl_term`](crate::kl_term)'s value (the
/// same operations), several lanes at a time where the CPU has them.
#[allow(unsafe_code)]
pub fn kl_terms_into(x: &[f64], y: &[f64], out: &mut [f64]) {
    match level() {
        // SAFETY: `level()` ≥ 1 only when the CPU has AVX2 and FMA, every
        // feature `kl_terms_into_avx2` enables.
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        1.. => unsafe { x86::kl_terms_into_avx2(x, y, out) },
        _ => kl_terms_body(x, y, out),
    }
}

/// The x86-64 builds and the CPU query (std only: `is_x86_feature_detected`).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86 {
    use super::*;

    /// The widest build to use: 0 portable, 1 AVX2, 2 AVX-512. Detected once;
    /// the environment variable `ITGFX_SIMD=portable|avx2|avx512` can lower it
    /// (CI runs the core's tests under each, whatever the machine prefers).
    pub(super) fn level() -> u8 {
        static LEVEL: std::sync::OnceLock<u8> = std::sync::OnceLock::new();
        *LEVEL.get_or_init(|| {
            let avx2 = std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
            let avx512 = avx2
                && std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512dq")
                && std::is_x86_feature_detected!("avx512vl");
            let best = if avx512 { 2 } else { u8::from(avx2) };
            let cap = match std::env::var("ITGFX_SIMD").as_deref() {
                Ok("portable") => 0,
                Ok("avx2") => 1,
                _ => 2,
            };
            best.min(cap)
        })
    }

    #[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
    pub(super) fn mass_xlnx_avx512<T: Real>(xs: &[T]) -> Result<Mass, Error> {
        mass_xlnx_body(xs)
    }

    #[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
    pub(super) fn kl_pass_avx512<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
        kl_pass_body(p, q)
    }

    #[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
    pub(super) fn mixture_avx512<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
        mixture_body(w, m)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn mass_xlnx_avx2<T: Real>(xs: &[T]) -> Result<Mass, Error> {
        mass_xlnx_body(xs)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn ln_into_avx2(xs: &[f64], out: &mut [f64]) {
        ln_into_body(xs, out);
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn kl_terms_into_avx2(x: &[f64], y: &[f64], out: &mut [f64]) {
        kl_terms_body(x, y, out);
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn mass_avx2<T: Real>(xs: &[T]) -> Result<f64, Error> {
        mass_body(xs)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn kl_pass_avx2<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
        kl_pass_body(p, q)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn mixture_avx2<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
        mixture_body(w, m)
    }
}

#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;
    use alloc::{vec, vec::Vec};

    /// The batched logarithm is the scalar one to the bit, in whichever
    /// build `ITGFX_SIMD` selects (CI runs each), on random bit patterns
    /// (subnormals to the largest), the edges and the invalid inputs.
    #[test]
    fn ln_into_is_ln_bit_for_bit() {
        let mut s: u64 = 0x2545_F491_4F6C_DD1D;
        let mut xs: Vec<f64> = (0..100_003)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                f64::from_bits(s & 0x7fff_ffff_ffff_ffff)
            })
            .collect();
        xs.extend([0.0, -0.0, 1.0, f64::MIN_POSITIVE, 5e-324, f64::MAX, f64::INFINITY, -1.0, f64::NAN]);
        let mut out = vec![0.0; xs.len()];
        ln_into(&xs, &mut out);
        for (&x, &y) in xs.iter().zip(&out) {
            let want = crate::math::ln(x);
            assert!(want.to_bits() == y.to_bits() || (want.is_nan() && y.is_nan()), "ln({x:e}): {y:e} vs {want:e}");
        }
    }

    /// The batched KL term is [`crate::kl_term`] to the bit on pairs of
    /// probabilities (a merged view and `p(O)`), on pairs whose ratio
    /// overflows or underflows (its other path), and on zeros, infinities,
    /// negatives and NaN.
    #[test]
    fn kl_terms_into_is_kl_term_bit_for_bit() {
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for _ in 0..50_000 {
            x.push((next() >> 11) as f64 / (1u64 << 53) as f64);
            y.push((next() >> 11) as f64 / (1u64 << 53) as f64);
            x.push(f64::from_bits(next() & 0x7fef_ffff_ffff_ffff));
            y.push(f64::from_bits(next() & 0x7fef_ffff_ffff_ffff));
        }
        let edges = [0.0, -0.0, 1.0, 5e-324, f64::MIN_POSITIVE, f64::MAX, f64::INFINITY, -1.0, f64::NAN];
        for a in edges {
            for b in edges {
                x.push(a);
                y.push(b);
            }
        }
        let mut out = vec![0.0; x.len()];
        kl_terms_into(&x, &y, &mut out);
        for ((&a, &b), &o) in x.iter().zip(&y).zip(&out) {
            let want = crate::kl_term(a, b);
            assert!(
                want.to_bits() == o.to_bits() || (want.is_nan() && o.is_nan()),
                "kl_term({a:e}, {b:e}): {o:e} vs {want:e}"
            );
        }
    }
}
