//! The refinement criteria of adaptive sampling, each one call into
//! `itgfx_core::pixel` on a pixel's samples so far.
//!
//! As in Part III-IV §5.2: every pixel first takes a stratified batch of
//! 8 rays, then batches of 8 more while the criterion says "refine", up to
//! a cap. `Y` is the luminance of linear sRGB, `N` the samples so far, `Ȳ`
//! their mean. Refine while:
//!
//! | name | test | source |
//! |---|---|---|
//! | `cc` | `(1/N) Ȳ C(Y) ≥ ε`, `C = (Y_max − Y_min)/(Y_max + Y_min)` | classic contrast, Part IV eq. (1), weighted by `Ȳ` as in III-IV §5.2 |
//! | `ct` | `t_{1−α/2,N−1} s/√N > ε`, α = 0.1 | confidence test, Part IV eq. (5) (tutorial tolerance 0.025) |
//! | `kl`, `cs`, `hl` | `(1/N) Ȳ D(p, u) ≥ ε`, `p_i = Y_i/ΣY` | f-divergence criteria, III-IV eqs. (14)–(16) |
//! | `kl-sqrt`, `cs-sqrt`, `hl-sqrt` | `(1/N) Ȳ D^½(p, u) ≥ ε` | III-IV Def. 4 |
//! | `rel` | `t_{1−α/2,N−1} s/√N > ε (Ȳ + 0.01)` | beyond the tutorial: a relative-error stop in the style of production renderers' adaptive sampling (noise relative to brightness); the confidence interval of Part IV eq. (5) |
//! | `ec-batch` | `(1/N) Σ_c w^c C^c c̄^c ≥ ε`, `C^c = 1 − H(p^c)/log N` | entropy contrast of each channel weighted by its importance, Part IV eqs. (16), (27) at the pixel level (`q_1 = c̄`), sRGB weights; the tree form `ec` is in [`super::tree`] |
//!
//! The `1/N` factor of III-IV eq. (15) makes every criterion but `ct` stop
//! (`ct`'s interval shrinks as `1/√N` by itself); `ε` is the one parameter
//! tuned so all criteria spend the same average samples per pixel.

use itgfx_core::oracle::DivergenceKernel;
use itgfx_core::pixel::{
    SRGB_LUMINANCE_WEIGHTS, classic_contrast, confidence_test, divergence_criterion, luminance, pixel_contrast,
    tree_colour_contrast,
};

use super::batch::{PixelSamples, Policy};

/// Rays per batch (III-IV §5.2: 8 initial rays, then 8 more at a time).
pub const BATCH: u32 = 8;
/// Confidence level parameter α of the confidence test (III-IV §5.2).
pub const ALPHA: f64 = 0.1;
/// Added to the mean luminance by `rel` so black pixels stop.
pub const RELATIVE_FLOOR: f64 = 0.01;

/// A refinement criterion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Criterion {
    /// Classic contrast of the luminance weighted by its mean (`cc`).
    ClassicContrast,
    /// Confidence test (`ct`).
    ConfidenceTest,
    /// f-divergence from uniform, optionally its square root (`kl`, `kl-sqrt`, …).
    Divergence(DivergenceKernel, bool),
    /// Confidence half-width relative to the mean luminance (`rel`).
    RelativeError,
    /// Entropy contrast of the channels weighted by their importance, in
    /// batches (`ec-batch`; the tree form is [`super::tree`]).
    EntropyContrast,
}

/// Every criterion's command-line name, in help order.
pub const NAMES: &[&str] = &["cc", "ct", "kl", "cs", "hl", "kl-sqrt", "cs-sqrt", "hl-sqrt", "ec-batch", "rel"];

impl Criterion {
    /// The criterion called `name` (see [`NAMES`]).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        use DivergenceKernel::{ChiSquare, Hellinger, KullbackLeibler};
        Some(match name {
            "cc" => Self::ClassicContrast,
            "ct" => Self::ConfidenceTest,
            "kl" => Self::Divergence(KullbackLeibler, false),
            "cs" => Self::Divergence(ChiSquare, false),
            "hl" => Self::Divergence(Hellinger, false),
            "kl-sqrt" => Self::Divergence(KullbackLeibler, true),
            "cs-sqrt" => Self::Divergence(ChiSquare, true),
            "hl-sqrt" => Self::Divergence(Hellinger, true),
            "ec-batch" => Self::EntropyContrast,
            "rel" => Self::RelativeError,
            _ => return None,
        })
    }

    /// The value compared with the threshold: refine while it is `≥ ε`
    /// (`> ε` for the confidence test's half-width). Samples must be
    /// finite and non-negative (radiance is); otherwise the pixel refines.
    #[must_use]
    pub fn value(&self, rgb: &[[f64; 3]]) -> f64 {
        let n = rgb.len() as f64;
        let y: Vec<f64> = rgb.iter().map(|c| luminance(*c)).collect();
        let mean = y.iter().sum::<f64>() / n;
        let v = match self {
            Self::ClassicContrast => classic_contrast(&y).map(|c| mean * c / n),
            Self::ConfidenceTest => confidence_test(&y, ALPHA, 0.0).map(|t| t.half_width),
            Self::RelativeError => confidence_test(&y, ALPHA, 0.0).map(|t| t.half_width / (mean + RELATIVE_FLOOR)),
            Self::Divergence(k, sqrt) => divergence_criterion(*k, &y, *sqrt),
            Self::EntropyContrast => (|| {
                let mut contrasts = [0.0; 3];
                let mut means = [0.0; 3];
                for c in 0..3 {
                    let ch: Vec<f64> = rgb.iter().map(|s| s[c]).collect();
                    contrasts[c] = pixel_contrast(&ch)?;
                    means[c] = ch.iter().sum::<f64>() / n;
                }
                tree_colour_contrast(&contrasts, &SRGB_LUMINANCE_WEIGHTS, &means).map(|v| v / n)
            })(),
        };
        v.unwrap_or(f64::INFINITY)
    }
}

/// Adaptive sampling with a criterion and threshold: batches of
/// [`BATCH`] until the criterion is met or `max` samples.
#[derive(Clone, Copy, Debug)]
pub struct Adaptive {
    /// The criterion.
    pub criterion: Criterion,
    /// Threshold `ε` (tolerance for the confidence test).
    pub threshold: f64,
    /// Most samples one pixel takes.
    pub max: u32,
    /// Decide on a separate pilot set (see [`Policy::unbiased`]).
    pub unbiased: bool,
}

impl Adaptive {
    /// Whether a pixel with these samples refines.
    #[must_use]
    pub fn refines(&self, rgb: &[[f64; 3]]) -> bool {
        let v = self.criterion.value(rgb);
        if matches!(self.criterion, Criterion::ConfidenceTest | Criterion::RelativeError) {
            v > self.threshold
        } else {
            v >= self.threshold
        }
    }
}

impl Policy for Adaptive {
    fn first(&self) -> u32 {
        BATCH.min(self.max)
    }

    fn more(&self, so_far: &PixelSamples) -> u32 {
        let n = so_far.rgb.len() as u32;
        if n >= self.max || !self.refines(&so_far.rgb) { 0 } else { BATCH.min(self.max - n) }
    }

    fn unbiased(&self) -> bool {
        self.unbiased
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(name: &str, threshold: f64) -> Adaptive {
        Adaptive { criterion: Criterion::from_name(name).unwrap(), threshold, max: 64, unbiased: false }
    }

    #[test]
    fn a_flat_pixel_never_refines_and_a_split_pixel_does() {
        let flat = PixelSamples { rgb: vec![[0.4, 0.5, 0.6]; 8] };
        // Half the samples see a light, half a black wall: an edge.
        let split = PixelSamples { rgb: (0..8).map(|i| if i % 2 == 0 { [1.0; 3] } else { [0.0; 3] }).collect() };
        for &name in NAMES {
            let p = policy(name, 1e-3);
            assert_eq!(p.more(&flat), 0, "{name}: a flat pixel refines");
            assert_eq!(p.more(&split), BATCH, "{name}: a split pixel does not refine");
        }
    }

    #[test]
    fn the_cap_and_the_first_batch_hold() {
        let split = PixelSamples { rgb: (0..64).map(|i| if i % 2 == 0 { [1.0; 3] } else { [0.0; 3] }).collect() };
        assert_eq!(policy("kl", 0.0).more(&split), 0, "at the cap");
        assert_eq!(policy("kl", 0.0).first(), 8);
        assert!(Criterion::from_name("nope").is_none());
    }

    #[test]
    fn values_are_the_core_definitions() {
        // Y = 1 and 3 (grey samples): C = (3-1)/(3+1) = 0.5, mean 2, N = 2.
        let s = [[1.0; 3], [3.0; 3]];
        let cc = Criterion::ClassicContrast.value(&s);
        assert!((cc - 2.0 * 0.5 / 2.0).abs() < 1e-12, "{cc}");
        // p = (1/4, 3/4), u = 1/2: KL = 1/4 ln(1/2) + 3/4 ln(3/2); (1/N) Ȳ KL.
        let kl = 0.25 * 0.5f64.ln() + 0.75 * 1.5f64.ln();
        let v = Criterion::from_name("kl").unwrap().value(&s);
        assert!((v - 0.5 * 2.0 * kl).abs() < 1e-12, "{v}");
        let v = Criterion::from_name("kl-sqrt").unwrap().value(&s);
        assert!((v - 0.5 * 2.0 * kl.sqrt()).abs() < 1e-12, "{v}");
    }
}
