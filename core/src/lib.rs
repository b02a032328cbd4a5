//! # itgfx-core
//!
//! Information-theoretic measures for computer graphics, after the
//! Eurographics 2007 tutorial *Applications of Information Theory to
//! Computer Graphics* (Feixas, Rigau, Sbert, Viola et al.). Every function
//! cites the Part and equation it implements; numbering restarts in each Part.
//!
//! * `#![no_std]`, one dependency (`libm`), no allocation in any function
//!   outside the `alloc` feature: inputs are slices, row-major matrices are a
//!   slice plus a shape, outputs go to caller buffers (`*_into`).
//! * Generic over `f32` and `f64` through the sealed [`Real`]; all arithmetic
//!   is `f64` with compensated sums ([`sum`]).
//! * Total: invalid input is an [`Error`], never a panic or a silent NaN.
//!   Values the mathematics defines are values: `KL(p‖q) = +∞` when `p`
//!   has mass where `q` has none; `0 · log 0 = 0`.
//! * Logarithmic measures take an explicit [`Base`] (bits by default in the CLI).
//!
//! ```
//! use itgfx_core::{entropy, kl_divergence, Base, Channel};
//! let h = entropy(&[0.5, 0.25, 0.25], Base::Bits).unwrap();
//! assert!((h - 1.5f64).abs() < 1e-15);
//! let d: f64 = kl_divergence(&[1.0, 0.0], &[0.5, 0.5], Base::Bits).unwrap();
//! assert!((d - 1.0).abs() < 1e-15);
//! let ch = Channel::new(&[0.5, 0.5], &[1.0, 0.0, 0.0, 1.0], 2).unwrap();
//! assert!((ch.measures(Base::Bits).mutual_information - 1.0).abs() < 1e-15);
//! ```
//!
//! ## Accuracy
//! `f64`: the Shannon entropy of a 10^7-element distribution agrees with a
//! double-double reference to 1e-14 relative (test `golden::entropy_accuracy`);
//! the blocked Neumaier sums keep the error bound independent of length to
//! first order, and 10^8 elements stay inside 1e-12 (measured by the
//! benchmark binary). `f32` inputs are widened, so an `f32` result is the
//! `f64` result of its inputs rounded once (within half an `f32` ulp).

#![no_std]
// `unsafe` appears only in `dispatch` (calling AVX2 builds after detection).
#![deny(unsafe_code)]
#![deny(clippy::undocumented_unsafe_blocks)]
#![deny(missing_docs)]
#![doc(test(attr(deny(warnings))))]
// Validation is written `!(x >= lo)` on purpose: NaN fails every comparison,
// so the negated form rejects it where `x < lo` would let it through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

#[cfg(feature = "alloc")]
extern crate alloc;
#[cfg(feature = "std")]
extern crate std;

mod base;
#[cfg(feature = "alloc")]
mod bottleneck;
mod channel;
mod coding;
mod dispatch;
mod divergence;
mod entropy;
mod error;
mod fano;
mod grouping;
mod kernels;
mod markov;
mod math;
mod matrix;
pub mod oracle;
pub mod pixel;
mod pmf;
mod quantile;
mod real;
mod scan;
pub mod scene;
mod sparse;
pub mod sum;

pub use base::Base;
#[cfg(feature = "alloc")]
pub use bottleneck::{
    Bottleneck, Merge, agglomerative_bottleneck, agglomerative_bottleneck_with_progress, bottleneck_work,
};
pub use channel::{Channel, ChannelMeasures, cascade_into, row_entropies_into};
pub use coding::huffman_expected_length;
#[cfg(feature = "alloc")]
pub use coding::{HUFFMAN_MAX_BLOCKS, huffman_block_length};
pub use dispatch::kl_terms_into;
pub use divergence::{
    ArithmeticGeometric, ChiSquare, ConvexFunction, Divergences, FGenerator, Hellinger, KullbackLeibler, Square,
    TotalVariation, ULogU, arithmetic_geometric, bregman, burbea_rao, chi_square, divergences, f_divergence, f_term,
    hellinger, jensen_shannon, kl_divergence, l_alpha, log_sum_terms, vasershtein_ornstein,
};
pub use entropy::{
    JointEntropies, binary_entropy, conditional_entropy, differential_entropy_from_bins, entropy, entropy_nats_of_sums,
    entropy_of_weight_sums, entropy_of_weights, joint_entropies, joint_entropy, kl_nats_of_sums, mutual_information,
    mutual_information_of_weight_sums, renyi_entropy, specific_information_of_weight_sums, tsallis_entropy,
    weight_log_term,
};
pub use error::Error;
pub use fano::{fano_bound, fano_minimum_error, fano_weak_bound};
pub use grouping::{Grouping, grouping, grouping_by_label};
pub use kernels::kl_term;
#[cfg(feature = "alloc")]
pub use markov::stationary_distribution;
pub use markov::{entropy_rate, excess_entropy_from_blocks, markov_excess_entropy, stationary_distribution_into};
pub use math::{ln, xlnx};
pub use matrix::MatrixRef;
pub use pmf::Pmf;
pub use real::Real;
pub use scene::{
    ContinuousMutualInformation, PairCount, SceneMeasures, continuous_mutual_information,
    discretisation_error_area_sampling, discretisation_error_lines, log_area_form_factor,
    mutual_information_matrix_into, point_form_factor, scene_measures, scene_measures_from_counts,
    scene_measures_from_counts_with,
};
#[cfg(feature = "alloc")]
pub use sparse::SparseRows;
pub use sparse::{SparseChannel, jensen_shannon_sparse, jensen_shannon_sparse_logs, sparse_logs};
