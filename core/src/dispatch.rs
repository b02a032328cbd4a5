//! Run-time selection of an AVX2 build of the hot kernels.
//!
//! The kernels are written once, branch-free over 8 lanes, and compiled
//! three times: for the portable x86-64 baseline (SSE2, 2 lanes) and, inside
//! the `#[target_feature]` functions below, for AVX2 + FMA (4 lanes) and
//! AVX-512 (8 lanes). With the `std` feature on x86-64, the CPU is asked
//! (std caches the answer) and the widest build it supports is used
//! (BENCHMARKS.md has the figures). Without `std` the portable build is used; a
//! no_std user can still get the fast build with `-C target-cpu=x86-64-v3`.
//!
//! This module holds the crate's only `unsafe`: calling a target-feature
//! function, which is sound exactly when the CPU has those features.

use crate::matrix::MatrixRef;
use crate::scan::{Mass, kl_pass_body, mass_body, mass_xlnx_body};
use crate::{Error, Real};

/// The widest build to use: 0 portable, 1 AVX2, 2 AVX-512. Detected once;
/// the environment variable `ITGFX_SIMD=portable|avx2|avx512` can lower it
/// (CI runs the core's tests under each, whatever the machine prefers).
fn level() -> u8 {
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

/// Whether an AVX2 (or wider) build may be used.
#[inline]
pub(crate) fn avx2() -> bool {
    level() >= 1
}

/// Whether the AVX-512 build (8 lanes of f64) may be used.
#[inline]
fn avx512() -> bool {
    level() >= 2
}

#[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
fn mass_xlnx_avx512<T: Real>(xs: &[T]) -> Result<Mass, Error> {
    mass_xlnx_body(xs)
}

#[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
fn kl_pass_avx512<T: Real>(p: &[T], q: &[T]) -> Result<(f64, f64, f64), Error> {
    kl_pass_body(p, q)
}

#[target_feature(enable = "avx2,fma,avx512f,avx512dq,avx512vl")]
fn mixture_avx512<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    crate::divergence::mixture_body(w, m)
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
    if avx512() {
        // SAFETY: `avx512()` just confirmed every feature the function enables.
        return unsafe { mass_xlnx_avx512(xs) };
    }
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
    if avx512() {
        // SAFETY: `avx512()` just confirmed every feature the function enables.
        return unsafe { kl_pass_avx512(p, q) };
    }
    // SAFETY: as in `mass_xlnx`: the caller checked `avx2()`.
    unsafe { kl_pass_avx2(p, q) }
}

/// The channel/Jensen-Shannon kernel compiled for AVX2; call only when [`avx2`] is true.
#[allow(unsafe_code)]
pub(crate) fn mixture<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    debug_assert!(avx2());
    if avx512() {
        // SAFETY: `avx512()` just confirmed every feature the function enables.
        return unsafe { mixture_avx512(w, m) };
    }
    // SAFETY: as in `mass_xlnx`: the caller checked `avx2()`.
    unsafe { mixture_avx2(w, m) }
}
