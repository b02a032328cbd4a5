//! Run-time selection of an AVX2 build of the hot kernels.
//!
//! The kernels are written once, branch-free over 8 lanes, and compiled
//! twice: for the portable x86-64 baseline (SSE2, 2 lanes) and, inside the
//! `#[target_feature]` functions below, for AVX2 + FMA (4 lanes). With the
//! `std` feature on x86-64, the CPU is asked once (cached by std) and the
//! AVX2 build is used when present: 2.2x on entropy and KL on the benchmark
//! machine (BENCHMARKS.md). Without `std` the portable build is used; a
//! no_std user can still get the fast build with `-C target-cpu=x86-64-v3`.
//!
//! This module holds the crate's only `unsafe`: calling a target-feature
//! function, which is sound exactly when the CPU has those features.

use crate::matrix::MatrixRef;
use crate::scan::{Mass, kl_pass_body, mass_body, mass_xlnx_body};
use crate::{Error, Real};

/// Whether the CPU running us has AVX2 and FMA.
#[inline]
pub(crate) fn avx2() -> bool {
    std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
}

#[target_feature(enable = "avx2,fma")]
fn mass_xlnx_avx2<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    mass_xlnx_body(xs)
}

#[target_feature(enable = "avx2,fma")]
fn mass_avx2<T: Real>(xs: &[T]) -> Result<f64, Error> {
    mass_body(xs)
}

#[target_feature(enable = "avx2,fma")]
fn kl_pass_avx2<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    kl_pass_body(p, q)
}

#[target_feature(enable = "avx2,fma")]
fn mixture_avx2<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    crate::divergence::mixture_body(w, m)
}

/// [`crate::scan::mass_xlnx`] compiled for AVX2; call only when [`avx2`] is true.
#[allow(unsafe_code)]
pub(crate) fn mass_xlnx<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    debug_assert!(avx2());
    // SAFETY: every caller checks `avx2()` first, so the CPU has the
    // target features this function was compiled for.
    unsafe { mass_xlnx_avx2(xs) }
}

/// [`crate::scan::mass`] (validation and sum) compiled for AVX2; call only when [`avx2`] is true.
#[allow(unsafe_code)]
pub(crate) fn mass<T: Real>(xs: &[T]) -> Result<f64, Error> {
    debug_assert!(avx2());
    // SAFETY: as in `mass_xlnx`: the caller checked `avx2()`.
    unsafe { mass_avx2(xs) }
}

/// [`crate::scan::kl_pass`] compiled for AVX2; call only when [`avx2`] is true.
#[allow(unsafe_code)]
pub(crate) fn kl_pass<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    debug_assert!(avx2());
    // SAFETY: as in `mass_xlnx`: the caller checked `avx2()`.
    unsafe { kl_pass_avx2(p, q) }
}

/// The channel/Jensen-Shannon kernel compiled for AVX2; call only when [`avx2`] is true.
#[allow(unsafe_code)]
pub(crate) fn mixture<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    debug_assert!(avx2());
    // SAFETY: as in `mass_xlnx`: the caller checked `avx2()`.
    unsafe { mixture_avx2(w, m) }
}
