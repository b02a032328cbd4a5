//! Shannon entropy and its relatives (Part II §2, §7; Rényi and Tsallis).

use crate::math::{ln, xlnx};
use crate::matrix::{MatrixRef, for_column_blocks};
use crate::scan::{check_normalized, entropy_nats, mass, mass_xlnx, non_empty, weights_entropy_nats};
use crate::sum::{Neumaier, sum_map};
use crate::{Base, Error, Real};

/// Shannon entropy `H(p) = −Σ p_i log p_i` of a distribution (Part II eq. (2)).
///
/// ```text
/// H(p) = − Σ_i p_i log p_i ,   0 · log 0 = 0
/// ```
/// One pass: validation, the sum and `Σ p ln p` are fused. The result is
/// the entropy of `p / Σp`, so the residual normalisation error allowed by
/// [`Real::MASS_TOLERANCE`] does not leak into it.
///
/// # Errors
/// [`Error::Empty`], [`Error::NonFinite`], [`Error::Negative`],
/// [`Error::ZeroMass`], [`Error::NotNormalized`].
///
/// # Examples
/// ```
/// use itgfx_core::{entropy, Base};
/// let h = entropy(&[0.5f64, 0.25, 0.25], Base::Bits).unwrap();
/// assert!((h - 1.5).abs() < 1e-15);
/// ```
pub fn entropy<T: Real>(p: &[T], base: Base) -> Result<T, Error> {
    non_empty(p.len())?;
    let m = mass_xlnx(p)?;
    check_normalized::<T>(m.sum)?;
    Ok(T::from_f64(entropy_nats(m) * base.per_nat()))
}

/// Entropy of non-negative weights (counts, areas, luminances) after
/// normalising them by their sum: `H(w / Σw) = log S − (Σ w log w)/S`.
///
/// # Errors
/// As [`entropy`] but never [`Error::NotNormalized`].
pub fn entropy_of_weights<T: Real>(w: &[T], base: Base) -> Result<T, Error> {
    non_empty(w.len())?;
    let h = weights_entropy_nats(w)?.ok_or(Error::ZeroMass)?;
    Ok(T::from_f64(h * base.per_nat()))
}

/// The term `w ln w` (nats, `0 ln 0 = 0`) of which [`entropy_of_weight_sums`]
/// and [`mutual_information_of_weight_sums`] take running sums, so that a
/// caller changing a few weights updates `Σ w ln w` by their terms alone.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::Negative`] for a weight that is not a
/// finite non-negative number.
pub fn weight_log_term<T: Real>(w: T) -> Result<f64, Error> {
    let x = w.to_f64();
    if !x.is_finite() {
        return Err(Error::NonFinite { index: 0 });
    }
    if x < 0.0 {
        return Err(Error::Negative { index: 0 });
    }
    Ok(xlnx(x))
}

/// Entropy (Part II eq. (2)) of weights `w` known only by their sum
/// `S = Σ w` and `X = Σ w ln w` (terms from [`weight_log_term`]):
///
/// ```text
/// H(w / S) = ln S − X / S
/// ```
/// the identity behind [`entropy_of_weights`]; a viewpoint entropy `H(O|v)`
/// (Part V eq. (2)) kept up to date while a mesh's polygons change.
/// Rounding below 0 is clamped to 0.
///
/// # Errors
/// [`Error::ZeroMass`] when `S ≤ 0`; [`Error::NonFinite`] for a sum that
/// is not finite.
pub fn entropy_of_weight_sums<T: Real>(sum: T, xlnx_sum: T, base: Base) -> Result<T, Error> {
    let (s, x) = (sum.to_f64(), xlnx_sum.to_f64());
    if !s.is_finite() || !x.is_finite() {
        return Err(Error::NonFinite { index: usize::from(s.is_finite()) });
    }
    if s <= 0.0 {
        return Err(Error::ZeroMass);
    }
    Ok(T::from_f64(entropy_nats_of_sums(s, x) * base.per_nat()))
}

/// Entropy in nats (Part II eq. (2)) of weights known by `S = Σ w` and
/// `X = Σ w ln w` (terms from [`xlnx`](crate::xlnx)): `ln S − X / S`,
/// clamped at 0 below (rounding), the infallible form of
/// [`entropy_of_weight_sums`] for engines that keep their own sums. 0 when
/// `S ≤ 0` (no mass: nothing is uncertain); NaN sums give NaN.
#[inline]
#[must_use]
pub fn entropy_nats_of_sums(sum: f64, xlnx_sum: f64) -> f64 {
    if !(sum > 0.0) {
        return if sum.is_nan() { f64::NAN } else { 0.0 };
    }
    let h = ln(sum) - xlnx_sum / sum;
    if h < 0.0 { 0.0 } else { h }
}

/// Kullback–Leibler divergence in nats (Part II eq. (5)) of the weights
/// `m` normalised by their sum `W = Σ m` from a distribution `q`, known by
/// `A = Σ m ln(m/q)` (terms from [`kl_term`](crate::kl_term)):
///
/// ```text
/// D(m/W ‖ q) = (A − W ln W) / W
/// ```
/// clamped at 0 below (rounding); 0 when `W ≤ 0`. With `m` a merged
/// view's projected areas and `q = p(O)`, the VMI of the merge (Part V
/// eq. (7)).
#[inline]
#[must_use]
pub fn kl_nats_of_sums(kl_sum: f64, mass: f64) -> f64 {
    if !(mass > 0.0) {
        return if mass.is_nan() { f64::NAN } else { 0.0 };
    }
    let d = (kl_sum - xlnx(mass)) / mass;
    if d < 0.0 { 0.0 } else { d }
}

/// Mutual information `I(X;Y) = H(X) + H(Y) − H(X,Y)` (Part II eq. (7)) of
/// the joint `w_xy / S` of non-negative weights known by running sums:
/// the total `S = Σ w_xy`, `J = Σ w_xy ln w_xy`, `R = Σ_x r_x ln r_x` of the
/// row sums and `C = Σ_y c_y ln c_y` of the column sums. Each entropy is
/// `ln S − (sum of w ln w)/S` as in [`entropy_of_weight_sums`], so
///
/// ```text
/// I(X;Y) = ln S + (J − R − C) / S
/// ```
/// With rows the viewpoints and columns the polygons, weights the projected
/// solid angles `a_o(v)`, this is `I(V;O)` (Part V eq. (6)) with `p(v)`
/// proportional to the projected area, updated by a few terms when a
/// few polygons change. Rounding below 0 is clamped to 0.
///
/// # Errors
/// [`Error::ZeroMass`] when `S ≤ 0`; [`Error::NonFinite`] (index 0..=3 in
/// argument order) for a sum that is not finite.
pub fn mutual_information_of_weight_sums<T: Real>(
    total: T,
    joint_xlnx: T,
    rows_xlnx: T,
    cols_xlnx: T,
    base: Base,
) -> Result<T, Error> {
    let v = [total.to_f64(), joint_xlnx.to_f64(), rows_xlnx.to_f64(), cols_xlnx.to_f64()];
    if let Some(index) = v.iter().position(|x| !x.is_finite()) {
        return Err(Error::NonFinite { index });
    }
    let [s, j, r, c] = v;
    if s <= 0.0 {
        return Err(Error::ZeroMass);
    }
    let i = ln(s) + (j - r - c) / s;
    Ok(T::from_f64(if i < 0.0 { 0.0 } else { i * base.per_nat() }))
}

/// Specific information `I(x;Y) = Σ_y p(y|x) ln(p(y|x)/p(y))` of one row
/// of non-negative joint weights `w_xy` (Part V eq. (7): the viewpoint
/// mutual information when `x` is a viewpoint), from running sums: the
/// total `S = Σ w`, the row sum `R = Σ_y w_xy`, `X = Σ_y w_xy ln w_xy` and
/// the cross term `K = Σ_y w_xy ln c_y` with the column sums `c_y`:
///
/// ```text
/// I(x;Y) = ln S − ln R + (X − K) / R
/// ```
/// since `p(y|x) = w_xy / R` and `p(y) = c_y / S`. Rounding below 0 is
/// clamped to 0.
///
/// # Errors
/// [`Error::ZeroMass`] when `S ≤ 0` or `R ≤ 0`; [`Error::NonFinite`]
/// (index 0..=3 in argument order) for a sum that is not finite.
pub fn specific_information_of_weight_sums<T: Real>(
    total: T,
    row_sum: T,
    row_xlnx: T,
    row_cross: T,
    base: Base,
) -> Result<T, Error> {
    let v = [total.to_f64(), row_sum.to_f64(), row_xlnx.to_f64(), row_cross.to_f64()];
    if let Some(index) = v.iter().position(|x| !x.is_finite()) {
        return Err(Error::NonFinite { index });
    }
    let [s, r, x, k] = v;
    if s <= 0.0 || r <= 0.0 {
        return Err(Error::ZeroMass);
    }
    let i = ln(s) - ln(r) + (x - k) / r;
    Ok(T::from_f64(if i < 0.0 { 0.0 } else { i * base.per_nat() }))
}

/// Binary entropy `H(p, 1−p)` (Part II eq. (4)).
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::InvalidParameter`] if `p ∉ [0, 1]`.
pub fn binary_entropy<T: Real>(p: T, base: Base) -> Result<T, Error> {
    let p = p.to_f64();
    if !p.is_finite() {
        return Err(Error::NonFinite { index: 0 });
    }
    if !(0.0..=1.0).contains(&p) {
        return Err(Error::InvalidParameter { name: "p", value: p });
    }
    Ok(T::from_f64(binary_entropy_nats(p) * base.per_nat()))
}

#[inline]
pub(crate) fn binary_entropy_nats(p: f64) -> f64 {
    -(xlnx(p) + xlnx(1.0 - p))
}

/// Joint entropy `H(X,Y) = −Σ p_ij log p_ij` of a joint distribution given
/// as a row-major `rows × cols` matrix (Part II eq. (3)).
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`], then as [`entropy`].
pub fn joint_entropy<T: Real>(joint: &[T], rows: usize, cols: usize, base: Base) -> Result<T, Error> {
    MatrixRef::new(joint, rows, cols)?;
    entropy(joint, base)
}

/// Entropies of a joint distribution `p(x, y)` (rows are `x`, columns `y`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointEntropies {
    /// `H(X)` from the row marginal.
    pub h_x: f64,
    /// `H(Y)` from the column marginal.
    pub h_y: f64,
    /// `H(X,Y)` (Part II eq. (3)).
    pub h_xy: f64,
    /// `H(X|Y) = H(X,Y) − H(Y)` (Part II eq. (5) and property 2).
    pub h_x_given_y: f64,
    /// `H(Y|X) = H(X,Y) − H(X)`.
    pub h_y_given_x: f64,
    /// `I(X;Y) = H(X) + H(Y) − H(X,Y)` (Part II eq. (7), property 3).
    pub mutual_information: f64,
}

impl JointEntropies {
    /// Mutual information normalised by the joint entropy, `I(X;Y) / H(X,Y)`
    /// in `[0, 1]` (Part III §3.2.3, the `Î_S = I_S / H_J` normalisation
    /// beside eq. (51), used for image alignment by \[Stu97\]). 0 when
    /// `H(X,Y) = 0` (both variables constant: nothing is shared).
    #[must_use]
    pub fn mi_over_joint(&self) -> f64 {
        if self.h_xy > 0.0 { (self.mutual_information / self.h_xy).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// Studholme's normalised mutual information `(H(X) + H(Y)) / H(X,Y)`
    /// in `[1, 2]`, which equals `1 + I(X;Y)/H(X,Y)` by Part II eq. (7)
    /// (\[Stu97\], cited in Part III §3.2.3); invariant to the overlap's size.
    /// 1 when `H(X,Y) = 0`.
    #[must_use]
    pub fn studholme_nmi(&self) -> f64 {
        1.0 + self.mi_over_joint()
    }

    /// Entropy correlation coefficient `2 I(X;Y) / (H(X) + H(Y))` in
    /// `[0, 1]`, the symmetric uncertainty of Maes et al. (1997): a monotone
    /// function of [`Self::studholme_nmi`], `ECC = 2 − 2/NMI`. 0 when
    /// `H(X) + H(Y) = 0`.
    #[must_use]
    pub fn entropy_correlation(&self) -> f64 {
        let s = self.h_x + self.h_y;
        if s > 0.0 { (2.0 * self.mutual_information / s).clamp(0.0, 1.0) } else { 0.0 }
    }
}

/// Every entropy of a joint distribution, in `base`, allocation-free.
///
/// Three compensated passes over the matrix: entries, row sums and column
/// sums (in blocks of 256 columns on the stack). Differences that are
/// non-negative in exact arithmetic are clamped at 0 against rounding.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`], then as [`entropy`].
pub fn joint_entropies<T: Real>(joint: &[T], rows: usize, cols: usize, base: Base) -> Result<JointEntropies, Error> {
    let m = MatrixRef::new(joint, rows, cols)?;
    let all = mass_xlnx(joint)?;
    check_normalized::<T>(all.sum)?;
    let s = all.sum;
    let h_xy = entropy_nats(all);
    // Row marginal, normalised by the total mass.
    let mut hx = Neumaier::new();
    for i in 0..rows {
        hx.add(xlnx(sum_map(m.row(i), |x| x) / s));
    }
    let mut hy = Neumaier::new();
    for_column_blocks::<T, f64>(&m, None, |_, col| {
        for &q in col {
            hy.add(xlnx(q / s));
        }
    });
    let (h_x, h_y) = (-hx.value(), -hy.value());
    let k = base.per_nat();
    let clamp = |v: f64| if v < 0.0 { 0.0 } else { v };
    Ok(JointEntropies {
        h_x: h_x * k,
        h_y: h_y * k,
        h_xy: h_xy * k,
        h_x_given_y: clamp(h_xy - h_y) * k,
        h_y_given_x: clamp(h_xy - h_x) * k,
        mutual_information: clamp(h_x + h_y - h_xy) * k,
    })
}

/// Mutual information `I(X;Y)` of a joint distribution (Part II eq. (7)).
///
/// # Errors
/// As [`joint_entropies`].
pub fn mutual_information<T: Real>(joint: &[T], rows: usize, cols: usize, base: Base) -> Result<T, Error> {
    joint_entropies(joint, rows, cols, base).map(|j| T::from_f64(j.mutual_information))
}

/// Conditional entropy `H(X|Y)` of a joint distribution, rows `x` and
/// columns `y` (Part II eq. (5)).
///
/// # Errors
/// As [`joint_entropies`].
pub fn conditional_entropy<T: Real>(joint: &[T], rows: usize, cols: usize, base: Base) -> Result<T, Error> {
    joint_entropies(joint, rows, cols, base).map(|j| T::from_f64(j.h_x_given_y))
}

/// Rényi entropy of order `alpha`: `H_α(p) = log(Σ p_i^α) / (1 − α)`.
///
/// `alpha = 1` is Shannon's entropy (the limit), `alpha = 0` the log of the
/// support size (Hartley), `alpha = +∞` the min-entropy `−log max p`.
/// `H_α` is non-increasing in `α`.
///
/// Near `α = 1` the textbook form divides a cancelled logarithm by `1 − α`
/// (at `α = 1 + 1e-14` it was off by 1%). With `ε = α − 1` and `ℓ_i = ln p_i`,
/// `Σ p^α = Σ p_i e^{εℓ_i}` is the moment generating function of `ℓ` under
/// `p`, so `ln Σ p^α = K(ε)`, its cumulant generating function, and
///
/// ```text
/// H_α = −K(ε)/ε = H − κ₂ ε/2 − κ₃ ε²/6 − κ₄ ε³/24 − O(κ₅ ε⁴)
/// ```
/// with `H = −κ₁` Shannon's entropy and `κ_k` the cumulants of `ℓ`
/// (`renyi_series`); it is used while `|ε|·max|ℓ| ≤ 10⁻⁴`, where the next
/// term is below 10⁻¹⁷ of `H`. For `½ ≤ α ≤ 3/2` otherwise, the exact
/// `H_α = −log1p(Σ p_i expm1(εℓ_i)) / ε`, whose sum has terms of one sign
/// (no cancellation); further out, the form below with `p_max` factored out.
///
/// # Errors
/// [`Error::InvalidParameter`] for `alpha` NaN or negative, then as [`entropy`].
pub fn renyi_entropy<T: Real>(p: &[T], alpha: f64, base: Base) -> Result<T, Error> {
    if alpha.is_nan() || alpha < 0.0 {
        return Err(Error::InvalidParameter { name: "alpha", value: alpha });
    }
    non_empty(p.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    if alpha == 1.0 {
        return entropy(p, base);
    }
    let max = p.iter().map(|x| x.to_f64()).fold(0.0, f64::max);
    let eps = alpha - 1.0;
    let nats = if alpha == f64::INFINITY {
        -ln(max / s)
    } else if alpha == 0.0 {
        let support = p.iter().filter(|x| x.to_f64() > 0.0).count();
        ln(support as f64)
    } else if let Some(h) = near_one(p, s, eps).map(|m| renyi_series(&m, eps)) {
        h
    } else if eps.abs() <= 0.5 {
        -libm::log1p(sum_map(p, |x| expm1_term(x / s, eps))) / eps
    } else {
        // Factor out p_max: H_α = α/(1−α) ln p_max + 1/(1−α) ln Σ (p_i/p_max)^α.
        // The sum is ≥ 1 (the largest term is 1), so it never underflows to 0
        // for large α (Σ p^α did: ln 0 then gave a finite wrong value).
        let sa = sum_map(p, |x| if x > 0.0 { libm::pow(x / max, alpha) } else { 0.0 });
        let pmax = max / s;
        alpha / (1.0 - alpha) * ln(pmax) + ln(sa) / (1.0 - alpha)
    };
    Ok(T::from_f64(if nats < 0.0 { 0.0 } else { nats * base.per_nat() }))
}

/// Tsallis entropy of index `q`: `S_q(p) = (1 − Σ p_i^q) / (q − 1)`.
///
/// Not logarithmic, so it takes no base; `q = 1` is Shannon's entropy in nats.
/// With `ε = q − 1` and `ℓ_i = ln p_i`, `1 − Σ p^q = −Σ p_i expm1(εℓ_i)`, a
/// sum of terms of one sign, so `S_q = −Σ p_i expm1(εℓ_i)/ε` has no
/// cancellation (`1 − Σ p^q` lost every digit near `q = 1`). Expanding
/// `expm1`, `S_q = −(m₁ + m₂ ε/2 + m₃ ε²/6 + m₄ ε³/24) − O(m₅ ε⁴)` with
/// `m_k = Σ p_i ℓ_i^k` and `−m₁ = H`, the series used while
/// `|ε|·max|ℓ| ≤ 10⁻⁴` (`tsallis_series`).
///
/// # Errors
/// [`Error::InvalidParameter`] for `q` NaN, infinite or negative, then as [`entropy`].
pub fn tsallis_entropy<T: Real>(p: &[T], q: f64) -> Result<T, Error> {
    if !q.is_finite() || q < 0.0 {
        return Err(Error::InvalidParameter { name: "q", value: q });
    }
    non_empty(p.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    if q == 1.0 {
        return entropy(p, Base::Nats);
    }
    let eps = q - 1.0;
    let v = match near_one(p, s, eps) {
        Some(m) => tsallis_series(&m, eps),
        None => -sum_map(p, |x| expm1_term(x / s, eps)) / eps,
    };
    Ok(T::from_f64(v))
}

/// `p^(1+ε) − p = p·expm1(ε ln p)` for `0 ≤ p ≤ 1` without overflow (for
/// `ε < 0` and tiny `p`, `expm1` alone overflows where `p^(1+ε)` does not).
fn expm1_term(p: f64, eps: f64) -> f64 {
    if p <= 0.0 {
        return 0.0;
    }
    let t = eps * ln(p);
    if t < 700.0 { p * libm::expm1(t) } else { libm::pow(p, 1.0 + eps) - p }
}

/// Moments of `ℓ = ln p` under `p` (of `p / s`): the raw `m₁…m₄` and the
/// central `c₂…c₄`.
#[derive(Debug, Clone, Copy)]
struct LogMoments {
    raw: [f64; 4],
    central: [f64; 3],
}

/// The moments of [`LogMoments`] when `|ε|·max|ln p_i| ≤ 10⁻⁴`, where the
/// series of [`renyi_series`] and [`tsallis_series`] are exact to rounding;
/// `None` further from 1.
fn near_one<T: Real>(p: &[T], s: f64, eps: f64) -> Option<LogMoments> {
    let lmax = p.iter().map(|x| x.to_f64() / s).filter(|&x| x > 0.0).map(|x| -ln(x)).fold(0.0, f64::max);
    if !(eps.abs() * lmax <= 1e-4) {
        return None;
    }
    let moment = |f: &dyn Fn(f64) -> f64| sum_map(p, |x| if x > 0.0 { (x / s) * f(ln(x / s)) } else { 0.0 });
    let raw = [moment(&|l| l), moment(&|l| l * l), moment(&|l| l * l * l), moment(&|l| (l * l) * (l * l))];
    let mu = raw[0];
    let central = [
        moment(&|l| (l - mu) * (l - mu)),
        moment(&|l| (l - mu) * (l - mu) * (l - mu)),
        moment(&|l| {
            let d = (l - mu) * (l - mu);
            d * d
        }),
    ];
    Some(LogMoments { raw, central })
}

/// `H_α` in nats near `α = 1 + ε` from the cumulants of `ln p`:
/// `κ₁ = m₁ = −H`, `κ₂ = c₂`, `κ₃ = c₃`, `κ₄ = c₄ − 3c₂²`, and
/// `H_α = −κ₁ − κ₂ε/2 − κ₃ε²/6 − κ₄ε³/24` (see [`renyi_entropy`]).
fn renyi_series(m: &LogMoments, eps: f64) -> f64 {
    let [c2, c3, c4] = m.central;
    let k4 = c4 - 3.0 * c2 * c2;
    -m.raw[0] - eps * (c2 / 2.0 + eps * (c3 / 6.0 + eps * k4 / 24.0))
}

/// `S_q` near `q = 1 + ε` from the raw moments of `ln p`:
/// `S_q = −(m₁ + m₂ε/2 + m₃ε²/6 + m₄ε³/24)` (see [`tsallis_entropy`]).
fn tsallis_series(m: &LogMoments, eps: f64) -> f64 {
    let [m1, m2, m3, m4] = m.raw;
    -(m1 + eps * (m2 / 2.0 + eps * (m3 / 6.0 + eps * m4 / 24.0)))
}

/// Estimate of the continuous (differential) entropy `H^c(X)` from a
/// histogram with bins of width `delta`, by Part II eq. (32):
/// `H^c ≈ H(X^Δ) + log Δ`.
///
/// # Errors
/// [`Error::InvalidParameter`] if `delta` is not positive and finite, then as [`entropy`].
pub fn differential_entropy_from_bins<T: Real>(p: &[T], delta: f64, base: Base) -> Result<T, Error> {
    if !(delta > 0.0 && delta.is_finite()) {
        return Err(Error::InvalidParameter { name: "delta", value: delta });
    }
    let h = entropy(p, Base::Nats)?.to_f64();
    Ok(T::from_f64((h + ln(delta)) * base.per_nat()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entropy_and_kl_of_sums_match_the_direct_forms() {
        let w = [3.0, 1.0, 0.0, 4.0];
        let (s, x) = (8.0, w.iter().map(|&v| xlnx(v)).sum::<f64>());
        let direct = entropy_of_weights(&w, Base::Nats).unwrap();
        assert!((entropy_nats_of_sums(s, x) - direct).abs() <= 1e-15);
        assert_eq!(entropy_nats_of_sums(0.0, 0.0), 0.0);
        assert!(entropy_nats_of_sums(f64::NAN, 0.0).is_nan());
        // Rounding below 0 is clamped: one weight has entropy 0.
        assert_eq!(entropy_nats_of_sums(3.0, xlnx(3.0) * (1.0 + 1e-15)), 0.0);
        let q = [0.25, 0.25, 0.25, 0.25];
        let a = w.iter().zip(&q).map(|(&m, &q)| crate::kl_term(m, q)).sum::<f64>();
        let p = w.map(|v| v / s);
        let kl = crate::kl_divergence(&p, &q, Base::Nats).unwrap();
        assert!((kl_nats_of_sums(a, s) - kl).abs() <= 1e-15, "{} vs {kl}", kl_nats_of_sums(a, s));
        assert_eq!(kl_nats_of_sums(0.0, 0.0), 0.0);
        let f = 0.01;
        assert!((crate::log_area_form_factor(50.0, f) - libm::log(0.5)).abs() <= 1e-15);
        // A product that overflows is a sum of logarithms.
        let big = crate::log_area_form_factor(1e300, 1e300);
        assert!((big - 2.0 * libm::log(1e300)).abs() <= 1e-12, "{big}");
    }

    #[test]
    fn bad_input_table() {
        let nan = f64::NAN;
        let cases: &[(&[f64], Error)] = &[
            (&[], Error::Empty),
            (&[0.5, nan, 0.5], Error::NonFinite { index: 1 }),
            (&[0.5, f64::INFINITY], Error::NonFinite { index: 1 }),
            (&[1.5, -0.5], Error::Negative { index: 1 }),
            (&[0.0, 0.0], Error::ZeroMass),
            (&[0.5, 0.6], Error::NotNormalized { sum: 1.1 }),
        ];
        for (p, e) in cases {
            let got = entropy(p, Base::Bits).unwrap_err();
            match (got, e) {
                (Error::NotNormalized { sum: a }, Error::NotNormalized { sum: b }) => {
                    assert!((a - b).abs() < 1e-12)
                }
                _ => assert_eq!(got, *e, "{p:?}"),
            }
        }
        // -0.0 is a zero, not a negative.
        assert_eq!(entropy(&[-0.0, 1.0], Base::Bits).unwrap(), 0.0);
    }

    /// The running-sum forms refuse what has no entropy: a negative or
    /// non-finite weight, a sum that is not finite, no mass.
    #[test]
    fn weight_sums_bad_input() {
        assert_eq!(weight_log_term(-1.0f64), Err(Error::Negative { index: 0 }));
        assert_eq!(weight_log_term(f64::NAN), Err(Error::NonFinite { index: 0 }));
        assert_eq!(weight_log_term(0.0f64), Ok(0.0));
        assert_eq!(entropy_of_weight_sums(0.0f64, 0.0, Base::Bits), Err(Error::ZeroMass));
        assert_eq!(entropy_of_weight_sums(1.0f64, f64::INFINITY, Base::Bits), Err(Error::NonFinite { index: 1 }));
        assert_eq!(
            mutual_information_of_weight_sums(1.0f64, 0.0, f64::NAN, 0.0, Base::Bits),
            Err(Error::NonFinite { index: 2 })
        );
        assert_eq!(mutual_information_of_weight_sums(0.0f64, 0.0, 0.0, 0.0, Base::Bits), Err(Error::ZeroMass));
        assert_eq!(specific_information_of_weight_sums(1.0f64, 0.0, 0.0, 0.0, Base::Bits), Err(Error::ZeroMass));
        // A row of one weight 2, alone in its column, of a total 4:
        // p(y|x) = 1, p(y) = 1/2, so I(x;Y) = 1 bit.
        let i = specific_information_of_weight_sums(4.0f64, 2.0, 2.0 * 2f64.ln(), 2.0 * 2f64.ln(), Base::Bits).unwrap();
        assert!((i - 1.0).abs() < 1e-15, "{i}");
    }

    /// Found by the `entropy` fuzz target: a single subnormal weight gave
    /// H = 0.001 through the precision lost in `x ln x`.
    #[test]
    fn weights_at_extreme_scales() {
        assert_eq!(entropy_of_weights(&[1.23e-321f64], Base::Bits).unwrap(), 0.0);
        let h: f64 = entropy_of_weights(&[5e-324, 5e-324], Base::Bits).unwrap();
        assert!((h - 1.0).abs() < 1e-15, "{h}");
        let h: f64 = entropy_of_weights(&[1e308, 1e308, 1e308, 1e308], Base::Bits).unwrap();
        assert!((h - 2.0).abs() < 1e-15, "{h}");
    }

    #[test]
    fn bad_element_found_in_a_late_block() {
        let mut p = [1.0f64 / 1000.0; 1000];
        p[777] = f64::NAN;
        assert_eq!(entropy(&p, Base::Bits), Err(Error::NonFinite { index: 777 }));
    }

    #[test]
    fn renyi_limits() {
        let p = [0.5f64, 0.25, 0.125, 0.125];
        let h1 = entropy(&p, Base::Bits).unwrap();
        let near = renyi_entropy(&p, 1.0 + 1e-7, Base::Bits).unwrap();
        assert!((near - h1).abs() < 1e-6);
        assert!((renyi_entropy(&p, 0.0, Base::Bits).unwrap() - 2.0).abs() < 1e-15);
        assert!((renyi_entropy(&p, f64::INFINITY, Base::Bits).unwrap() - 1.0).abs() < 1e-15);
        assert!((tsallis_entropy(&p, 2.0).unwrap() - (1.0 - (0.25 + 0.0625 + 2.0 * 0.015625))).abs() < 1e-15);
    }

    /// Regression (issue 9): for α = 2000, Σ p^α underflowed to 0 and the
    /// result was 0.539 bits. By hand, H_α(½, ¼, ¼) = α/(α−1) · 1 bit +
    /// log₂(1 + 2^(1−α))/(1−α), and the second term is below 2^-1999.
    #[test]
    fn renyi_large_alpha_is_stable() {
        let p = [0.5f64, 0.25, 0.25];
        for alpha in [2000.0, 1e6, 1e300] {
            let h = renyi_entropy(&p, alpha, Base::Bits).unwrap();
            let want = alpha / (alpha - 1.0);
            assert!((h - want).abs() < 1e-14, "alpha {alpha}: {h} vs {want}");
            assert!(h >= renyi_entropy(&p, f64::INFINITY, Base::Bits).unwrap());
        }
        // Two tied maxima: H_α = 1 bit for every α.
        let h = renyi_entropy(&[0.5f64, 0.5], 5000.0, Base::Bits).unwrap();
        assert!((h - 1.0).abs() < 1e-15, "{h}");
    }

    /// Issue 24: `--alpha 1.00000000000001` on (½, ¼, ¼) gave 1.5103 bits,
    /// 0.999999999999999 gave 1.623 > log₂ 3, and Tsallis near q = 1 gave
    /// 1.37778 for ln 4 on the uniform four.
    #[test]
    fn renyi_tsallis_at_one_plus_rounding() {
        let p = [0.5f64, 0.25, 0.25];
        for a in [1.000_000_000_000_01, 0.999_999_999_999_999, 1.0 + f64::EPSILON, 1.0 - f64::EPSILON / 2.0] {
            let h = renyi_entropy(&p, a, Base::Bits).unwrap();
            assert!((h - 1.5).abs() < 1e-12, "alpha {a}: {h}");
        }
        let u = [0.25f64; 4];
        for q in [1.000_000_000_000_01, 0.999_999_999_999_999] {
            let s = tsallis_entropy(&u, q).unwrap();
            assert!((s - 4f64.ln()).abs() < 1e-12, "q {q}: {s}");
            let h = renyi_entropy(&u, q, Base::Bits).unwrap();
            assert!((h - 2.0).abs() < 1e-12, "alpha {q}: {h}");
        }
    }

    use alloc::vec::Vec;
    use proptest::prelude::*;

    fn pmf() -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(prop_oneof![1 => Just(0.0), 4 => 1e-9..1.0f64], 1..20).prop_map(|mut w| {
            w[0] += 1e-3;
            let s: f64 = w.iter().sum();
            w.iter().map(|x| x / s).collect()
        })
    }

    proptest! {
        /// The series of [`renyi_series`] and [`tsallis_series`] against the
        /// exact `expm1`/`log1p` forms (no cancellation, see
        /// [`renyi_entropy`]) across the band where the series is used,
        /// `|ε|·max|ln p| ≤ 10⁻⁴`, and a little beyond.
        #[test]
        fn series_match_exact_forms(p in pmf(), t in 1e-7..2e-4f64, neg in any::<bool>()) {
            let lmax = p.iter().filter(|&&x| x > 0.0).map(|&x| -ln(x)).fold(0.0, f64::max);
            prop_assume!(lmax > 0.0);
            let eps = if neg { -t } else { t } / lmax;
            let m = near_one(&p, 1.0, eps / 2.0).unwrap();
            let sum = sum_map(&p, |x| expm1_term(x, eps));
            let renyi = -libm::log1p(sum) / eps;
            let tsallis = -sum / eps;
            let h = entropy(&p, Base::Nats).unwrap();
            prop_assert!((renyi_series(&m, eps) - renyi).abs() <= 1e-13 * h.max(1e-300) + 1e-300, "{} {}", renyi_series(&m, eps), renyi);
            prop_assert!((tsallis_series(&m, eps) - tsallis).abs() <= 1e-13 * h.max(1e-300) + 1e-300);
        }
    }
}
