//! Pixel quality and contrast for adaptive ray tracing (Part IV §2–§6,
//! Part III-IV §5): colour and geometry entropies, qualities and contrasts,
//! the classic measures they are compared with, the entropy-tree importance,
//! f-divergence criteria, and the RMSE/PSNR used to score images.
//!
//! A "sample set" is the values of one colour channel (or the geometry
//! factors) of the `N ≥ 2` rays through one pixel or sub-pixel region.

use crate::entropy::binary_entropy_nats;
use crate::math::ln;
use crate::oracle::{DivergenceKernel, divergence_from_uniform};
use crate::scan::{mass, same_len, weights_entropy_nats};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// Perceptual sRGB channel weights `w^R, w^G, w^B` (Part IV §3.1, §6.3).
pub const SRGB_LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// Mitchell's per-channel contrast thresholds, used as weights (Part IV eq. (2)).
pub const MITCHELL_WEIGHTS: [f64; 3] = [0.4, 0.3, 0.6];

fn at_least_two(n: usize) -> Result<(), Error> {
    if n == 0 {
        return Err(Error::Empty);
    }
    if n < 2 {
        return Err(Error::LengthMismatch { expected: 2, found: n });
    }
    Ok(())
}

/// Pixel channel (or geometry) entropy `H(p)` with `p_i = c(s_i) / Σ c(s_j)`
/// (Part IV Defs. 2 and 6, eqs. (8), (14)).
///
/// A sample set that is all zero (a black pixel, or no geometry) is
/// perfectly homogeneous: it gets the maximum, `log N`.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`] for a single sample,
/// [`Error::NonFinite`], [`Error::Negative`].
pub fn pixel_entropy<T: Real>(samples: &[T], base: Base) -> Result<f64, Error> {
    at_least_two(samples.len())?;
    let nats = weights_entropy_nats(samples)?.unwrap_or_else(|| ln(samples.len() as f64));
    Ok(nats * base.per_nat())
}

/// Pixel quality `Q = H(p) / log N` in `[0, 1]` (Part IV Defs. 3 and 7,
/// eqs. (10), (15)); independent of the log base.
///
/// # Errors
/// As [`pixel_entropy`].
pub fn pixel_quality<T: Real>(samples: &[T]) -> Result<f64, Error> {
    let h = pixel_entropy(samples, Base::Nats)?;
    Ok((h / ln(samples.len() as f64)).clamp(0.0, 1.0))
}

/// Pixel contrast `C = 1 − Q` (Part IV Defs. 8 and 12, eqs. (16), (20)).
///
/// # Errors
/// As [`pixel_entropy`].
pub fn pixel_contrast<T: Real>(samples: &[T]) -> Result<f64, Error> {
    pixel_quality(samples).map(|q| 1.0 - q)
}

/// `r = min / max` of the samples, in `[0, 1]`; `None` if all are zero.
/// Every extreme-based contrast depends on `p_min/p_max` alone, and the
/// ratio of raw values never overflows (their sum can).
fn extremes<T: Real>(samples: &[T]) -> Result<Option<f64>, Error> {
    at_least_two(samples.len())?;
    mass(samples)?;
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for x in samples {
        let x = x.to_f64();
        lo = lo.min(x);
        hi = hi.max(x);
    }
    Ok((hi > 0.0).then(|| lo / hi))
}

/// Binary contrast `C_b = 1 − H_b(p_min/(p_min+p_max))`, with `H_b` in bits
/// (Part IV Defs. 9 and 13, eqs. (17), (21)); in `[0, 1]`, 0 for an all-zero set.
///
/// # Errors
/// As [`pixel_entropy`].
pub fn binary_contrast<T: Real>(samples: &[T]) -> Result<f64, Error> {
    Ok(match extremes(samples)? {
        None => 0.0,
        // p_min/(p_min+p_max) = r/(1+r); H_b ≤ 1 bit exactly, rounding can exceed it by an ulp.
        Some(r) => (1.0 - binary_entropy_nats(r / (1.0 + r)) * Base::Bits.per_nat()).clamp(0.0, 1.0),
    })
}

/// Logarithmic-difference contrast `log(p_max / p_min)` (Part IV Def. 14,
/// eq. (22)); `+∞` when some sample is zero and another is not, 0 for an
/// all-zero set.
///
/// # Errors
/// As [`pixel_entropy`].
pub fn log_difference_contrast<T: Real>(samples: &[T], base: Base) -> Result<f64, Error> {
    Ok(match extremes(samples)? {
        None => 0.0,
        Some(0.0) => f64::INFINITY,
        Some(r) => -ln(r) * base.per_nat(),
    })
}

/// Geometry factor of a sample `g(s) = cos θ / r²` (Part IV eq. (12)), from
/// the cosine between the surface normal and the reversed ray and the ray
/// length; back-facing hits (`cos θ < 0`) count as `|cos θ|`.
#[must_use]
pub fn geometry_factor(cos_theta: f64, distance: f64) -> f64 {
    cos_theta.abs() / (distance * distance)
}

/// Weighted mean of per-channel values `Σ w^c v^c / Σ w^c`: the pixel colour
/// quality of Part IV Def. 4 (eq. (11)) when `values` are channel qualities.
///
/// # Errors
/// [`Error::LengthMismatch`], [`Error::NonFinite`], [`Error::Negative`],
/// [`Error::ZeroMass`] for all-zero weights.
pub fn weighted_channel_mean(values: &[f64], weights: &[f64]) -> Result<f64, Error> {
    same_len(values.len(), weights.len())?;
    let sw = mass(weights)?;
    if sw == 0.0 {
        return Err(Error::ZeroMass);
    }
    let mut acc = Neumaier::new();
    for (v, w) in values.iter().zip(weights) {
        if !v.is_finite() {
            return Err(Error::NonFinite { index: 0 });
        }
        acc.add(v * w);
    }
    Ok(acc.value() / sw)
}

/// Pixel colour contrast of a colour system (Part IV Defs. 10–11, eqs. (18),
/// (19)): channel contrasts weighted by `w^c c̄`, where `c̄` is the channel's
/// mean sample value. Pass entropy contrasts for `C^c`, binary contrasts for
/// `C_b^c`. 0 when every `w^c c̄` is 0 (a black pixel).
///
/// # Errors
/// [`Error::LengthMismatch`], [`Error::NonFinite`], [`Error::Negative`].
pub fn colour_contrast(channel_contrasts: &[f64], weights: &[f64], channel_means: &[f64]) -> Result<f64, Error> {
    same_len(channel_contrasts.len(), weights.len())?;
    same_len(channel_contrasts.len(), channel_means.len())?;
    mass(weights)?;
    mass(channel_means)?;
    let mut num = Neumaier::new();
    let mut den = Neumaier::new();
    for ((c, w), m) in channel_contrasts.iter().zip(weights).zip(channel_means) {
        if !c.is_finite() {
            return Err(Error::NonFinite { index: 0 });
        }
        num.add(w * m * c);
        den.add(w * m);
    }
    let d = den.value();
    Ok(if d > 0.0 { num.value() / d } else { 0.0 })
}

/// Colour–geometry contrast `δ C^c + (1 − δ) C^g` (Part IV Def. 15, eq. (23);
/// eq. (28) in the refinement tree).
///
/// # Errors
/// [`Error::InvalidParameter`] for `delta ∉ [0, 1]`.
pub fn mixed_contrast(delta: f64, colour: f64, geometry: f64) -> Result<f64, Error> {
    if !(0.0..=1.0).contains(&delta) {
        return Err(Error::InvalidParameter { name: "delta", value: delta });
    }
    Ok(delta * colour + (1.0 - delta) * geometry)
}

/// Mitchell's classic contrast `(I_max − I_min)/(I_max + I_min)` of one
/// channel (Part IV eq. (1)); 0 for an all-zero set.
///
/// # Errors
/// As [`pixel_entropy`].
pub fn classic_contrast<T: Real>(samples: &[T]) -> Result<f64, Error> {
    Ok(match extremes(samples)? {
        None => 0.0,
        Some(r) => (1.0 - r) / (1.0 + r),
    })
}

fn mean<T: Real>(samples: &[T]) -> Result<f64, Error> {
    Ok(mass(samples)? / samples.len() as f64)
}

/// Simmons' priority value `p_c = Σ_c k_c C_c c̄` over the R, G, B sample
/// sets with `k = (0.4, 0.3, 0.6)` (Part IV eq. (2)).
///
/// # Errors
/// As [`pixel_entropy`] for each channel; [`Error::LengthMismatch`] if the
/// channels differ in length.
pub fn priority_colour<T: Real>(r: &[T], g: &[T], b: &[T]) -> Result<f64, Error> {
    same_len(r.len(), g.len())?;
    same_len(r.len(), b.len())?;
    let mut acc = 0.0;
    for (k, c) in MITCHELL_WEIGHTS.iter().zip([r, g, b]) {
        acc += k * classic_contrast(c)? * mean(c)?;
    }
    Ok(acc)
}

/// Depth difference `p_d = 1 − d_min/d_max` (Part IV eq. (3)); 0 if all depths are 0.
///
/// # Errors
/// As [`pixel_entropy`].
pub fn depth_difference<T: Real>(depths: &[T]) -> Result<f64, Error> {
    Ok(match extremes(depths)? {
        None => 0.0,
        Some(r) => 1.0 - r,
    })
}

/// Priority value `p_v = δ p_c + (1 − δ) p_d` (Part IV eq. (4); `δ = 0.9` there).
///
/// # Errors
/// [`Error::InvalidParameter`] for `delta ∉ [0, 1]`.
pub fn priority_value(delta: f64, p_c: f64, p_d: f64) -> Result<f64, Error> {
    mixed_contrast(delta, p_c, p_d)
}

/// Outcome of the confidence test (Part IV eq. (5)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConfidenceTest {
    /// The sample mean `L̂`.
    pub mean: f64,
    /// Half-width `t_{1−α/2, N−1} · s / √N` of the `1 − α` interval.
    pub half_width: f64,
    /// `true` when the half-width is within the tolerance: stop sampling.
    pub satisfied: bool,
}

/// Confidence test of variance-based adaptive sampling (Part IV eq. (5)):
/// is the true value within `tolerance` of the mean with probability `1 − α`?
/// Uses Student's t quantile with `N − 1` degrees of freedom (the samples
/// per pixel are few: 8 in Part IV §6.4).
///
/// # Errors
/// As [`pixel_entropy`] for the samples (negative values are allowed here:
/// only finiteness is required), [`Error::InvalidParameter`] for `alpha ∉ (0, 1)`
/// or a negative `tolerance`.
pub fn confidence_test(samples: &[f64], alpha: f64, tolerance: f64) -> Result<ConfidenceTest, Error> {
    at_least_two(samples.len())?;
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(Error::InvalidParameter { name: "alpha", value: alpha });
    }
    if !(tolerance >= 0.0 && tolerance.is_finite()) {
        return Err(Error::InvalidParameter { name: "tolerance", value: tolerance });
    }
    let mut s = Neumaier::new();
    for (index, &x) in samples.iter().enumerate() {
        if !x.is_finite() {
            return Err(Error::NonFinite { index });
        }
        s.add(x);
    }
    let n = samples.len() as f64;
    let m = s.value() / n;
    let mut ss = Neumaier::new();
    for &x in samples {
        ss.add((x - m) * (x - m));
    }
    let sd = libm::sqrt(ss.value() / (n - 1.0));
    let t = crate::quantile::student_t_quantile(1.0 - alpha / 2.0, samples.len() - 1);
    let half_width = t * sd / libm::sqrt(n);
    Ok(ConfidenceTest { mean: m, half_width, satisfied: half_width <= tolerance })
}

/// Importance of an `n`-node of the refinement tree, `q_n ≈ c̄_n / N_r^{n−1}`
/// (Part IV Proposition 1, eq. (26)); `level = n ≥ 1`.
///
/// # Errors
/// [`Error::InvalidParameter`] for `level = 0`, `regions < 2`, or a negative mean.
pub fn node_importance(mean_colour: f64, regions: u32, level: u32) -> Result<f64, Error> {
    if level == 0 {
        return Err(Error::InvalidParameter { name: "level", value: 0.0 });
    }
    if regions < 2 {
        return Err(Error::InvalidParameter { name: "regions", value: f64::from(regions) });
    }
    if !(mean_colour >= 0.0 && mean_colour.is_finite()) {
        return Err(Error::InvalidParameter { name: "mean_colour", value: mean_colour });
    }
    Ok(mean_colour / libm::pow(f64::from(regions), f64::from(level - 1)))
}

/// Colour contrast of an `n`-node, `C_n = Σ_c w^c C_n^c q_n^c` (Part IV eq. (27)).
///
/// # Errors
/// [`Error::LengthMismatch`], [`Error::NonFinite`].
pub fn tree_colour_contrast(channel_contrasts: &[f64], weights: &[f64], importances: &[f64]) -> Result<f64, Error> {
    same_len(channel_contrasts.len(), weights.len())?;
    same_len(channel_contrasts.len(), importances.len())?;
    let mut acc = Neumaier::new();
    for (index, ((c, w), q)) in channel_contrasts.iter().zip(weights).zip(importances).enumerate() {
        let v = c * w * q;
        if !v.is_finite() {
            return Err(Error::NonFinite { index });
        }
        acc.add(v);
    }
    Ok(acc.value())
}

/// The per-channel contrast measure of a pixel or node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelContrast {
    /// Entropy contrast `1 − H(p)/log N` (Part IV Def. 8, eq. (16)).
    Entropy,
    /// Binary contrast `1 − H_b` of the extreme probabilities (Part IV Def. 9, eq. (17)).
    Binary,
    /// Mitchell's classic contrast `(I_max − I_min)/(I_max + I_min)` (Part IV eq. (1)).
    Classic,
}

/// The contrast of one channel's samples under `kind`: [`pixel_contrast`],
/// [`binary_contrast`] or [`classic_contrast`].
///
/// # Errors
/// As [`pixel_entropy`].
pub fn channel_contrast<T: Real>(samples: &[T], kind: ChannelContrast) -> Result<f64, Error> {
    match kind {
        ChannelContrast::Entropy => pixel_contrast(samples),
        ChannelContrast::Binary => binary_contrast(samples),
        ChannelContrast::Classic => classic_contrast(samples),
    }
}

/// Importance-weighted contrast of an `n`-node of the refinement tree,
/// `Σ_c w^c C^c q_n^c` with the importance `q_n^c = c̄_n^c / N_r^{n−1}`
/// of Proposition 1 (Part IV eqs. (26), (27)); `channels[c]` holds channel
/// `c` of the node's samples, `level = n ≥ 1`.
///
/// With [`ChannelContrast::Entropy`] this is the entropy contrast `C_n` of
/// eq. (27) (the `EC` sampler of §6.4); with [`ChannelContrast::Classic`]
/// it is the importance-weighted classic contrast `IC` of §6.4 (eq. (1)
/// per channel weighted by `q_n` instead of the channel mean). Both fall by
/// a factor `N_r` per level, which is what stops the descent.
///
/// # Errors
/// [`Error::LengthMismatch`] when `weights` and `channels` differ in length
/// or the channels in sample count; as [`channel_contrast`] for each
/// channel; as [`node_importance`].
pub fn importance_weighted_contrast(
    channels: &[&[f64]],
    weights: &[f64],
    kind: ChannelContrast,
    regions: u32,
    level: u32,
) -> Result<f64, Error> {
    same_len(channels.len(), weights.len())?;
    let n = channels.first().map_or(0, |c| c.len());
    let mut acc = Neumaier::new();
    for (index, (ch, w)) in channels.iter().zip(weights).enumerate() {
        same_len(n, ch.len())?;
        let c = channel_contrast(ch, kind)?;
        let q = node_importance(mean(ch)?, regions, level)?;
        let v = w * c * q;
        if !v.is_finite() {
            return Err(Error::NonFinite { index });
        }
        acc.add(v);
    }
    Ok(acc.value())
}

/// Pixel colour contrast of a colour system from its channels' samples
/// (Part IV Defs. 10–11, eqs. (18), (19)): each channel's contrast under
/// `kind`, weighted by `w^c c̄^c` and normalised, so in `[0, 1]`.
///
/// # Errors
/// As [`importance_weighted_contrast`].
pub fn pixel_colour_contrast(channels: &[&[f64]], weights: &[f64], kind: ChannelContrast) -> Result<f64, Error> {
    same_len(channels.len(), weights.len())?;
    mass(weights)?;
    let n = channels.first().map_or(0, |c| c.len());
    let (mut num, mut den) = (Neumaier::new(), Neumaier::new());
    for (ch, w) in channels.iter().zip(weights) {
        same_len(n, ch.len())?;
        let m = mean(ch)?;
        num.add(w * m * channel_contrast(ch, kind)?);
        den.add(w * m);
    }
    let d = den.value();
    Ok(if d > 0.0 { num.value() / d } else { 0.0 })
}

/// Pixel colour quality from its channels' samples: the channel qualities
/// `H(p^c)/log N` (eq. (10)) averaged with the weights `w^c` (Part IV
/// Def. 4, eq. (11)).
///
/// # Errors
/// As [`importance_weighted_contrast`]; [`Error::ZeroMass`] for all-zero weights.
pub fn pixel_colour_quality(channels: &[&[f64]], weights: &[f64]) -> Result<f64, Error> {
    same_len(channels.len(), weights.len())?;
    let sw = mass(weights)?;
    if sw == 0.0 {
        return Err(Error::ZeroMass);
    }
    let n = channels.first().map_or(0, |c| c.len());
    let mut acc = Neumaier::new();
    for (ch, w) in channels.iter().zip(weights) {
        same_len(n, ch.len())?;
        acc.add(w * pixel_quality(ch)?);
    }
    Ok(acc.value() / sw)
}

/// The f-divergence refinement criterion for ray tracing,
/// `(1/N) L̄ D(p, u)` with `p_i = L_i / Σ L_j` and `u` uniform
/// (Part III-IV eqs. (14)–(16)); with `square_root`, `(1/N) L̄ D^½(p, u)`
/// (Def. 4). Refine while the value is not below `ε`.
/// `kernel` must not be [`DivergenceKernel::Variance`].
///
/// # Errors
/// As [`pixel_entropy`]; [`Error::InvalidParameter`] for the variance kernel.
pub fn divergence_criterion(kernel: DivergenceKernel, luminances: &[f64], square_root: bool) -> Result<f64, Error> {
    if kernel == DivergenceKernel::Variance {
        return Err(Error::InvalidParameter { name: "kernel", value: 3.0 });
    }
    at_least_two(luminances.len())?;
    let s = mass(luminances)?;
    let n = luminances.len() as f64;
    let d = divergence_from_uniform(kernel, luminances, s).unwrap_or(0.0);
    let d = if square_root { libm::sqrt(d) } else { d };
    Ok(s / n / n * d)
}

/// The sRGB transfer function (IEC 61966-2-1, \[Com98\] of Part III-IV §5.1)
/// of a linear value clamped to `[0, 1]`: the display encoding on which the
/// RMSE and PSNR of Part IV Table 2 / Part III-IV Table 3 are taken (times 255).
#[must_use]
pub fn srgb_encode(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * libm::pow(x, 1.0 / 2.4) - 0.055 }
}

/// Derivative of [`srgb_encode`] at `x`: how much a small change of a
/// linear value moves its display value (0 at and above 1, where the
/// display clamps; the linear segment's 12.92 at and below 0.0031308).
#[must_use]
pub fn srgb_slope(x: f64) -> f64 {
    if x >= 1.0 {
        0.0
    } else if x <= 0.003_130_8 {
        12.92
    } else {
        1.055 / 2.4 * libm::pow(x, 1.0 / 2.4 - 1.0)
    }
}

/// Luminance `Y` of a linear sRGB colour (Part III-IV §5.1).
#[must_use]
pub fn luminance(rgb: [f64; 3]) -> f64 {
    SRGB_LUMINANCE_WEIGHTS[0] * rgb[0] + SRGB_LUMINANCE_WEIGHTS[1] * rgb[1] + SRGB_LUMINANCE_WEIGHTS[2] * rgb[2]
}

/// Image error of Part IV §6.4 Table 2 / Part III-IV Table 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Root of the channel-weighted mean square error.
    pub rmse: f64,
    /// `10 log10(I_max² / MSE)` dB; `+∞` for identical images.
    pub psnr: f64,
}

/// RMSE and PSNR between two interleaved images with `channels` channels,
/// the per-channel MSEs combined with `weights` (equal weights give the
/// `_a` columns of the tables, the sRGB weights the `_p` columns), and the
/// peak value `peak` (255 for 8-bit images).
///
/// # Errors
/// [`Error::LengthMismatch`] (lengths, or not a multiple of `channels`,
/// or `weights.len() != channels`), [`Error::NonFinite`],
/// [`Error::InvalidParameter`] for `peak`, [`Error::ZeroMass`] for all-zero weights.
pub fn image_error(a: &[f64], b: &[f64], channels: usize, weights: &[f64], peak: f64) -> Result<ImageError, Error> {
    same_len(a.len(), b.len())?;
    if channels == 0 || !a.len().is_multiple_of(channels) {
        return Err(Error::LengthMismatch { expected: channels.max(1), found: a.len() });
    }
    same_len(channels, weights.len())?;
    if !(peak > 0.0 && peak.is_finite()) {
        return Err(Error::InvalidParameter { name: "peak", value: peak });
    }
    let sw = mass(weights)?;
    if sw == 0.0 {
        return Err(Error::ZeroMass);
    }
    let mut mse = 0.0;
    for (c, w) in weights.iter().enumerate() {
        let mut acc = Neumaier::new();
        for (index, (x, y)) in a.iter().zip(b).enumerate().skip(c).step_by(channels) {
            let d = x - y;
            if !d.is_finite() {
                return Err(Error::NonFinite { index });
            }
            acc.add(d * d);
        }
        mse += w * acc.value() / (a.len() / channels) as f64;
    }
    let mse = mse / sw;
    let psnr = if mse > 0.0 { 10.0 * libm::log10(peak * peak / mse) } else { f64::INFINITY };
    Ok(ImageError { rmse: libm::sqrt(mse), psnr })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contrasts_on_known_sets() {
        // Uniform samples: quality 1, every contrast 0.
        let flat = [0.3f64; 8];
        assert!((pixel_quality(&flat).unwrap() - 1.0).abs() < 1e-15);
        assert_eq!(binary_contrast(&flat).unwrap(), 0.0);
        assert_eq!(classic_contrast(&flat).unwrap(), 0.0);
        // One bright sample among dark ones.
        let edge = [1.0f64, 0.0, 0.0, 0.0];
        assert_eq!(pixel_contrast(&edge).unwrap(), 1.0);
        assert_eq!(binary_contrast(&edge).unwrap(), 1.0);
        assert_eq!(classic_contrast(&edge).unwrap(), 1.0);
        assert_eq!(log_difference_contrast(&edge, Base::Bits).unwrap(), f64::INFINITY);
        // min/max = 1/3: classic (3-1)/(3+1) = 0.5; binary 1 - H(1/4) in bits.
        let s = [1.0f64, 3.0];
        assert!((classic_contrast(&s).unwrap() - 0.5).abs() < 1e-15);
        let hb = -(0.25f64 * 0.25f64.log2() + 0.75 * 0.75f64.log2());
        assert!((binary_contrast(&s).unwrap() - (1.0 - hb)).abs() < 1e-15);
        assert!((log_difference_contrast(&s, Base::Bits).unwrap() - 3f64.log2()).abs() < 1e-15);
        assert!((depth_difference(&[2.0f64, 8.0]).unwrap() - 0.75).abs() < 1e-15);
        assert_eq!(pixel_entropy(&[0.0f64; 4], Base::Bits).unwrap(), 2.0, "black pixel is homogeneous");
        assert_eq!(pixel_entropy(&[1.0f64], Base::Bits), Err(Error::LengthMismatch { expected: 2, found: 1 }));
    }

    #[test]
    fn colour_contrast_weights_channels_by_mean() {
        // Eq. (18): a dark channel's contrast matters less.
        let c = colour_contrast(&[1.0, 0.0, 0.0], &[1.0, 1.0, 1.0], &[0.1, 0.9, 0.0]).unwrap();
        assert!((c - 0.1).abs() < 1e-15);
        assert_eq!(colour_contrast(&[1.0, 1.0], &[1.0, 1.0], &[0.0, 0.0]).unwrap(), 0.0);
        assert!((mixed_contrast(0.9, 1.0, 0.0).unwrap() - 0.9).abs() < 1e-15);
        assert!(mixed_contrast(1.5, 1.0, 0.0).is_err());
    }

    #[test]
    fn priority_value_matches_equation_2() {
        let (r, g, b) = ([1.0f64, 3.0], [2.0f64, 2.0], [0.0f64, 4.0]);
        let want = 0.4 * 0.5 * 2.0 + 0.3 * 0.0 * 2.0 + 0.6 * 1.0 * 2.0;
        assert!((priority_colour(&r, &g, &b).unwrap() - want).abs() < 1e-15);
        assert!((priority_value(0.9, 1.0, 0.5).unwrap() - 0.95).abs() < 1e-15);
    }

    #[test]
    fn confidence_test_uses_student_t() {
        let s = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        let ct = confidence_test(&s, 0.1, 10.0).unwrap();
        // mean 4.5, sd = sqrt(6), t_{0.95,7} = 1.894579
        let want = 1.894_579 * 6f64.sqrt() / 8f64.sqrt();
        assert!((ct.mean - 4.5).abs() < 1e-15 && (ct.half_width - want).abs() < 1e-5 && ct.satisfied);
        assert!(!confidence_test(&s, 0.1, 0.025).unwrap().satisfied);
    }

    #[test]
    fn divergence_criterion_and_importance() {
        let flat = [2.0; 8];
        assert_eq!(divergence_criterion(DivergenceKernel::Hellinger, &flat, true).unwrap(), 0.0);
        let l = [1.0, 0.0, 0.0, 0.0];
        // p = (1,0,0,0), u = 1/4: KL = ln 4; (1/N) L̄ KL with L̄ = 1/4.
        let want = 0.25 * 0.25 * 4f64.ln();
        assert!((divergence_criterion(DivergenceKernel::KullbackLeibler, &l, false).unwrap() - want).abs() < 1e-15);
        assert!(
            (divergence_criterion(DivergenceKernel::KullbackLeibler, &l, true).unwrap() - 0.0625 * 4f64.ln().sqrt())
                .abs()
                < 1e-15
        );
        assert!((node_importance(0.8, 4, 3).unwrap() - 0.05).abs() < 1e-15);
        assert!((tree_colour_contrast(&[0.5, 1.0], &[0.5, 0.5], &[1.0, 0.2]).unwrap() - 0.35).abs() < 1e-15);
    }

    #[test]
    fn importance_weighted_contrast_by_hand() {
        // Two channels, samples (1, 3) and (2, 2): classic contrasts 0.5 and 0;
        // means 2 and 2; level 2 of N_r = 4: q = 2/4. IC = w0 * 0.5 * 0.5.
        let (a, b) = ([1.0, 3.0], [2.0, 2.0]);
        let ic = importance_weighted_contrast(&[&a, &b], &[0.3, 0.7], ChannelContrast::Classic, 4, 2).unwrap();
        assert!((ic - 0.3 * 0.5 * 0.5).abs() < 1e-15, "{ic}");
        // Entropy form equals eq. (27) through tree_colour_contrast.
        let ec = importance_weighted_contrast(&[&a, &b], &[0.3, 0.7], ChannelContrast::Entropy, 4, 1).unwrap();
        let want = tree_colour_contrast(&[pixel_contrast(&a).unwrap(), 0.0], &[0.3, 0.7], &[2.0, 2.0]).unwrap();
        assert!((ec - want).abs() < 1e-15);
        assert!(importance_weighted_contrast(&[&a, &[1.0]], &[0.3, 0.7], ChannelContrast::Classic, 4, 1).is_err());
        assert!(importance_weighted_contrast(&[&a], &[0.3, 0.7], ChannelContrast::Classic, 4, 1).is_err());
        // Eq. (18) normalises: (w0 m0 C0 + w1 m1 C1) / (w0 m0 + w1 m1) = 0.3 * 2 * 0.5 / 2.
        let cc = pixel_colour_contrast(&[&a, &b], &[0.3, 0.7], ChannelContrast::Classic).unwrap();
        assert!((cc - 0.15).abs() < 1e-15, "{cc}");
        let q = pixel_colour_quality(&[&a, &b], &[1.0, 1.0]).unwrap();
        assert!((q - 0.5 * (pixel_quality(&a).unwrap() + 1.0)).abs() < 1e-15);
    }

    #[test]
    fn image_error_matches_definitions() {
        let a = [10.0, 20.0, 30.0, 10.0, 20.0, 30.0];
        let b = [12.0, 20.0, 30.0, 10.0, 20.0, 26.0];
        let e = image_error(&a, &b, 3, &[1.0, 1.0, 1.0], 255.0).unwrap();
        // MSE per channel: R (4+0)/2 = 2, G 0, B 16/2 = 8; mean 10/3.
        let mse: f64 = 10.0 / 3.0;
        assert!((e.rmse - mse.sqrt()).abs() < 1e-12);
        assert!((e.psnr - 10.0 * (255.0f64 * 255.0 / mse).log10()).abs() < 1e-12);
        assert_eq!(image_error(&a, &a, 3, &SRGB_LUMINANCE_WEIGHTS, 255.0).unwrap().psnr, f64::INFINITY);
    }
}
