//! Refinement oracles for hierarchical radiosity as pure functions of their
//! samples: power (Part III eq. (36)), kernel smoothness (eqs. (37), (38)),
//! mutual information (eqs. (76)–(77)), and the f-divergence and variance
//! oracles of Part III-IV Def. 3. An interaction `j → i` is refined when the
//! returned value is not below the threshold `ε`.
//!
//! Samples are point-to-point form factors `F(x_k, y_k)` between random
//! point pairs on elements `i` and `j` (zero when occluded).

use crate::divergence::{ChiSquare, FGenerator, Hellinger, KullbackLeibler, f_term};
use crate::scan::{mass, non_empty};
use crate::scene::discretisation_error_area_sampling;
use crate::sum::Neumaier;
use crate::{Base, Error};

fn finite_non_negative(name: &'static str, v: f64) -> Result<f64, Error> {
    if v >= 0.0 && v.is_finite() { Ok(v) } else { Err(Error::InvalidParameter { name, value: v }) }
}

/// Power-based oracle `ρ_i A_i F_ij B_j` (Part III eq. (36)).
///
/// # Errors
/// [`Error::InvalidParameter`] for a negative or non-finite argument.
pub fn power_oracle(rho_i: f64, area_i: f64, f_ij: f64, b_j: f64) -> Result<f64, Error> {
    Ok(finite_non_negative("rho_i", rho_i)?
        * finite_non_negative("area_i", area_i)?
        * finite_non_negative("f_ij", f_ij)?
        * finite_non_negative("b_j", b_j)?)
}

/// Minimum, mean and maximum of a validated sample of kernel values.
fn kernel_stats(samples: &[f64]) -> Result<(f64, f64, f64), Error> {
    non_empty(samples.len())?;
    let s = mass(samples)?;
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &x in samples {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    Ok((lo, s / samples.len() as f64, hi))
}

/// Kernel-smoothness oracle `ρ_i (F^max − F^min) A_j B_j` (Part III eq. (37)),
/// with the extremes estimated from the samples.
///
/// # Errors
/// [`Error::Empty`], sample errors ([`Error::NonFinite`], [`Error::Negative`]),
/// [`Error::InvalidParameter`] for the scalars.
pub fn kernel_smoothness_oracle(rho_i: f64, samples: &[f64], area_j: f64, b_j: f64) -> Result<f64, Error> {
    let (lo, _, hi) = kernel_stats(samples)?;
    Ok(finite_non_negative("rho_i", rho_i)?
        * (hi - lo)
        * finite_non_negative("area_j", area_j)?
        * finite_non_negative("b_j", b_j)?)
}

/// Kernel-smoothness oracle around the average,
/// `ρ_i max(F^max − F^av, F^av − F^min) A_j B_j` (Part III eq. (38); the KS
/// oracle of Part III-IV §4.2). `F^av` is the sample mean, the estimate of
/// `F_ij / A_j`.
///
/// # Errors
/// As [`kernel_smoothness_oracle`].
pub fn kernel_smoothness_average_oracle(rho_i: f64, samples: &[f64], area_j: f64, b_j: f64) -> Result<f64, Error> {
    let (lo, av, hi) = kernel_stats(samples)?;
    Ok(finite_non_negative("rho_i", rho_i)?
        * (hi - av).max(av - lo)
        * finite_non_negative("area_j", area_j)?
        * finite_non_negative("b_j", b_j)?)
}

/// Mutual-information-based oracle `ρ_i δ_ij B_j` (Part III eqs. (76)–(77)),
/// with `δ_ij` from area sampling (eq. (73)), in `base`.
///
/// # Errors
/// As [`discretisation_error_area_sampling`], plus [`Error::InvalidParameter`]
/// for `rho_i`, `b_j`.
pub fn mutual_information_oracle(
    rho_i: f64,
    area_i: f64,
    area_j: f64,
    total_area: f64,
    samples: &[f64],
    b_j: f64,
    base: Base,
) -> Result<f64, Error> {
    let d = discretisation_error_area_sampling(area_i, area_j, total_area, samples, base)?;
    Ok(finite_non_negative("rho_i", rho_i)? * d * finite_non_negative("b_j", b_j)?)
}

/// The kernel of Part III-IV Def. 3 and of the VT oracle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DivergenceKernel {
    /// `D_KL(p, u)` in nats (oracle KL).
    KullbackLeibler,
    /// `χ²(p, u)` (oracle CS).
    ChiSquare,
    /// `D_h²(p, u)` (oracle HL).
    Hellinger,
    /// `F̂ · V(p, u)` with `V = mean p_k² − 1/N²` (oracle VT, §4.2).
    Variance,
}

/// `D(p ‖ u)` between the normalised samples `p_k = x_k / Σx` and the
/// uniform distribution `u_k = 1/N`, by one of the kernels; `None` when all
/// samples are zero. Shared by the radiosity and ray-tracing criteria.
pub(crate) fn divergence_from_uniform(kernel: DivergenceKernel, samples: &[f64], sum: f64) -> Option<f64> {
    if sum <= 0.0 {
        return None;
    }
    let n = samples.len() as f64;
    let u = 1.0 / n;
    let mut acc = Neumaier::new();
    let gen_: &dyn FGenerator = match kernel {
        DivergenceKernel::KullbackLeibler => &KullbackLeibler,
        DivergenceKernel::ChiSquare => &ChiSquare,
        DivergenceKernel::Hellinger => &Hellinger,
        DivergenceKernel::Variance => {
            for &x in samples {
                let p = x / sum;
                acc.add(p * p);
            }
            return Some((acc.value() / n - u * u).max(0.0));
        }
    };
    for &x in samples {
        acc.add(f_term(gen_, x / sum, u));
    }
    Some(acc.value().max(0.0))
}

/// f-divergence oracles of Part III-IV Def. 3,
/// `ρ_i A_i A_j F̂ D(p, u) B_j`, and the variance oracle VT,
/// `ρ_i A_i A_j F̂² V(p, u) B_j` (§4.2), where `F̂ = Σ_k F(x_k, y_k)` and
/// `p_k = F(x_k, y_k)/F̂`.
///
/// With the KL kernel, dividing by `A_T N_s` gives exactly the
/// discretisation error `δ_ij` of Part III eq. (73) times `ρ_i B_j`
/// (Part III-IV eq. (13)); the constants are left to the threshold, as the
/// tutorial does. All-zero samples (full occlusion) give 0.
///
/// # Errors
/// [`Error::Empty`], sample errors, [`Error::InvalidParameter`] for the scalars.
pub fn divergence_oracle(
    kernel: DivergenceKernel,
    rho_i: f64,
    area_i: f64,
    area_j: f64,
    samples: &[f64],
    b_j: f64,
) -> Result<f64, Error> {
    non_empty(samples.len())?;
    let sum = mass(samples)?;
    let scale = finite_non_negative("rho_i", rho_i)?
        * finite_non_negative("area_i", area_i)?
        * finite_non_negative("area_j", area_j)?
        * finite_non_negative("b_j", b_j)?;
    let f_hat = if kernel == DivergenceKernel::Variance { sum * sum } else { sum };
    Ok(divergence_from_uniform(kernel, samples, sum).map_or(0.0, |d| scale * f_hat * d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classic_oracles() {
        assert_eq!(power_oracle(0.5, 2.0, 0.25, 4.0).unwrap(), 1.0);
        let s = [0.1, 0.4, 0.3];
        assert!((kernel_smoothness_oracle(0.5, &s, 2.0, 1.0).unwrap() - 0.3).abs() < 1e-15);
        // av = 0.8/3 ≈ 0.2667; max(0.4 − av, av − 0.1) = av − 0.1
        let av = 0.8 / 3.0;
        assert!((kernel_smoothness_average_oracle(1.0, &s, 1.0, 1.0).unwrap() - (av - 0.1)).abs() < 1e-15);
        assert!(power_oracle(-1.0, 1.0, 1.0, 1.0).is_err());
        assert!(kernel_smoothness_oracle(1.0, &[], 1.0, 1.0).is_err());
    }

    #[test]
    fn divergence_oracles_vanish_on_a_constant_kernel() {
        for k in [
            DivergenceKernel::KullbackLeibler,
            DivergenceKernel::ChiSquare,
            DivergenceKernel::Hellinger,
            DivergenceKernel::Variance,
        ] {
            assert!(divergence_oracle(k, 0.7, 1.0, 1.0, &[0.2; 10], 1.0).unwrap().abs() < 1e-15);
            assert_eq!(divergence_oracle(k, 0.7, 1.0, 1.0, &[0.0; 10], 1.0).unwrap(), 0.0, "full occlusion");
            assert!(divergence_oracle(k, 0.7, 1.0, 1.0, &[0.0, 0.0, 1.0], 1.0).unwrap() > 0.0);
        }
        let m = mutual_information_oracle(1.0, 1.0, 1.0, 6.0, &[0.2; 10], 1.0, Base::Bits).unwrap();
        assert!(m.abs() < 1e-15);
    }
}
