//! Hierarchical Monte Carlo radiosity whose link refinement is decided by
//! the tutorial's oracles (Part III §9, Part III-IV §4).
//!
//! * [`element`]: a quadtree over every input polygon;
//! * [`link`]: form factors and the oracle's samples from `N_s` random
//!   point pairs traced with [`Tracer::occluded`](crate::tracer::Tracer::occluded);
//! * gathering with push-pull, iterated to convergence;
//! * [`refine`]: a link is refined while its oracle, scaled by `ρ_i B_j`
//!   and normalised, is not below `ε`; the larger of its two elements is split;
//! * [`search`]: `ε` bisected so every oracle ends near the same element count;
//! * [`render`]: the Gouraud-shaded solution and the mesh from a camera;
//! * [`patches`]: each patch's mean radiosity by the renderer's path
//!   tracer, to check a solution patch by patch;
//! * [`reference`](mod@reference): an independent path-traced estimate of the radiosity
//!   seen through each pixel, with its standard error.
//!
//! Every oracle's formula is the core's ([`itgfx_core::oracle`]): power
//! (eq. 36), kernel smoothness (eqs. 37, 38), mutual information (eqs.
//! 76-77), and the f-divergence and variance oracles of Part III-IV Def. 3.

#[cfg(test)]
mod conservation;
pub mod element;
mod front;
mod gather;
pub mod link;
pub mod patches;
pub mod reference;
pub mod refine;
pub mod render;
pub mod search;
pub mod spherical;

use std::fmt;
use std::str::FromStr;

pub use gather::Rgb;
pub use refine::{Settings, Solution, solve};

/// A refinement oracle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Oracle {
    /// Transported power `ρ_i A_i F_ij B_j` (Part III eq. 36).
    Power,
    /// Kernel smoothness `ρ_i (F^max − F^min) A_j B_j` (Part III eq. 37).
    KernelSmoothness,
    /// Kernel smoothness around the mean (Part III eq. 38; KS of Part III-IV §4.2).
    KernelSmoothnessAverage,
    /// Mutual information `ρ_i δ_ij B_j` (Part III eqs. 76-77).
    MutualInformation,
    /// Kullback-Leibler (Part III-IV Def. 3).
    KullbackLeibler,
    /// Chi-square (Part III-IV Def. 3).
    ChiSquare,
    /// Hellinger (Part III-IV Def. 3).
    Hellinger,
    /// Variance, VT (Part III-IV §4.2).
    Variance,
}

impl Oracle {
    /// Every oracle, in the order tables list them.
    pub const ALL: [Oracle; 8] = [
        Oracle::Power,
        Oracle::KernelSmoothness,
        Oracle::KernelSmoothnessAverage,
        Oracle::MutualInformation,
        Oracle::KullbackLeibler,
        Oracle::ChiSquare,
        Oracle::Hellinger,
        Oracle::Variance,
    ];

    /// The name `--oracle` takes.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Oracle::Power => "power",
            Oracle::KernelSmoothness => "ks",
            Oracle::KernelSmoothnessAverage => "ks-avg",
            Oracle::MutualInformation => "mi",
            Oracle::KullbackLeibler => "kl",
            Oracle::ChiSquare => "cs",
            Oracle::Hellinger => "hl",
            Oracle::Variance => "variance",
        }
    }

    /// Whether the oracle's value is a radiosity (KS, VT) rather than a
    /// power; [`refine`] normalises by the largest emittance or the
    /// emitted power accordingly, so `ε` is dimensionless.
    #[must_use]
    pub const fn is_radiosity(self) -> bool {
        matches!(self, Oracle::KernelSmoothness | Oracle::KernelSmoothnessAverage | Oracle::Variance)
    }
}

impl fmt::Display for Oracle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An unknown oracle name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownOracle(pub String);

impl fmt::Display for UnknownOracle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown oracle {:?}: expected power, ks, ks-avg, mi, kl, cs, hl or variance", self.0)
    }
}

impl std::error::Error for UnknownOracle {}

impl FromStr for Oracle {
    type Err = UnknownOracle;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "vt" {
            return Ok(Oracle::Variance);
        }
        Oracle::ALL.into_iter().find(|o| o.name() == s).ok_or_else(|| UnknownOracle(s.to_string()))
    }
}
