//! The equal-element-count protocol (Part III-IV §4.2): `ε` is bisected on
//! a log scale until the mesh has about the requested number of leaves, so
//! oracles are compared at the same mesh size.

use super::refine::{RadiosityError, Settings, Solution, solve};
use crate::scene::Scene;
use crate::tracer::{Prepared, Tracer};

/// The outcome of a search.
#[derive(Clone, Debug)]
pub struct Search {
    /// The solution whose leaf count came closest to the target.
    pub solution: Solution,
    /// `(ε, leaves)` of every trial, in order.
    pub trials: Vec<(f64, usize)>,
}

/// Bisects `log ε` in `[1e-14, 10]` for `target` leaves, within a relative
/// `tolerance` or `max_trials` solves. Trials are capped at three times the
/// target (a capped trial counts as too many), so small `ε` stay cheap.
///
/// # Errors
/// As [`solve`].
#[allow(clippy::too_many_arguments)]
pub fn search_epsilon(
    scene: &Scene,
    prepared: &Prepared,
    tracer: &dyn Tracer,
    base: &Settings,
    target: usize,
    tolerance: f64,
    max_trials: u32,
    progress: &mut dyn FnMut(u32, f64, usize),
) -> Result<Search, RadiosityError> {
    let (mut lo, mut hi) = (-14.0f64, 1.0f64);
    let mut best: Option<Solution> = None;
    let mut trials = Vec::new();
    let cap = target.saturating_mul(3).max(target + 16);
    for t in 0..max_trials.max(1) {
        let log_eps = 0.5 * (lo + hi);
        let eps = 10f64.powf(log_eps);
        let s = solve(
            scene,
            prepared,
            tracer,
            &Settings { epsilon: eps, max_elements: cap.min(base.max_elements), ..*base },
        )?;
        let n = s.hierarchy.leaves().len();
        trials.push((eps, n));
        progress(t + 1, eps, n);
        let too_many = n > target || s.capped;
        let key = |s: &Solution| (s.capped, s.hierarchy.leaves().len().abs_diff(target));
        if best.as_ref().is_none_or(|b| key(&s) < key(b)) {
            best = Some(s);
        }
        if best.as_ref().is_some_and(|b| {
            !b.capped && b.hierarchy.leaves().len().abs_diff(target) as f64 <= tolerance * target as f64
        }) {
            break;
        }
        if too_many {
            lo = log_eps;
        } else {
            hi = log_eps;
        }
    }
    Ok(Search { solution: best.expect("at least one trial"), trials })
}
