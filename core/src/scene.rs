//! The scene visibility channel (Part III §2–§8): positional entropy `H_P`,
//! scene entropy `H_S`, joint entropy `H_J`, mutual information `I_S`, their
//! normalisations, the mutual information matrix, the continuous mutual
//! information `I_S^c` and the discretisation error `δ_ij`.
//!
//! Inputs are patch areas (any positive unit; only `a_i = A_i / A_T` is
//! used) and either a dense form-factor matrix or sparse line counts.

use crate::math::{ln, xlnx};
use crate::matrix::MatrixRef;
use crate::scan::{entropy_nats, mass, mass_xlnx, non_empty, same_len, weights_entropy_nats};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// Scene visibility measures, all in one unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneMeasures {
    /// Number of patches `n_p`.
    pub patches: usize,
    /// Patches no line reached (their `H_i` is unknown and counted as 0).
    pub unsampled_patches: usize,
    /// `H_P = −Σ a_i log a_i` (Part III eq. (43)).
    pub positional_entropy: f64,
    /// `H_S = Σ a_i H_i = −Σ a_i Σ F_ij log F_ij` (Part III eqs. (39)–(41)).
    pub scene_entropy: f64,
    /// `H_J = H_P + H_S` (Part III eq. (44) and §2.3).
    pub joint_entropy: f64,
    /// `I_S = H_P − H_S` (Part III eq. (45)).
    pub mutual_information: f64,
    /// `H_S / H_P` (Part III eq. (50)); 0 when `H_P = 0`.
    pub normalized_entropy: f64,
    /// `I_S / H_P` (Part III eq. (51)); 0 when `H_P = 0`.
    pub normalized_mutual_information: f64,
    /// `H_S / H_J` (Part III §3.2.3).
    pub entropy_over_joint: f64,
    /// `I_S / H_J` (Part III §3.2.3).
    pub mutual_information_over_joint: f64,
}

impl SceneMeasures {
    /// The measures in `base` from `H_P` and `H_S` in nats (eqs. (43),
    /// (39)–(41)): `H_J` and `I_S` by eqs. (44)–(45), the ratios by (50)–(51).
    /// Measures computed in nats give the same bits in another base through
    /// this as computed there.
    #[must_use]
    pub fn from_nats(patches: usize, unsampled: usize, hp: f64, hs: f64, base: Base) -> Self {
        let k = base.per_nat();
        let hj = hp + hs;
        let is = hp - hs;
        let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
        Self {
            patches,
            unsampled_patches: unsampled,
            positional_entropy: hp * k,
            scene_entropy: hs * k,
            joint_entropy: hj * k,
            mutual_information: is * k,
            normalized_entropy: ratio(hs, hp),
            normalized_mutual_information: ratio(is, hp),
            entropy_over_joint: ratio(hs, hj),
            mutual_information_over_joint: ratio(is, hj),
        }
    }
}

fn relative_area_entropy<T: Real>(areas: &[T]) -> Result<(f64, f64), Error> {
    non_empty(areas.len())?;
    let total = mass(areas)?;
    let h = weights_entropy_nats(areas)?.ok_or(Error::ZeroMass)?;
    if !total.is_finite() {
        return Err(Error::InvalidParameter { name: "total_area", value: total });
    }
    Ok((total, h))
}

/// Scene measures from patch areas and a dense `n × n` form-factor matrix
/// (rows must sum to 1: a closed scene, Part III eq. (9)).
///
/// # Errors
/// Area errors as [`crate::entropy_of_weights`]; matrix errors as
/// [`MatrixRef::check_stochastic`].
///
/// # Examples
/// ```
/// use itgfx_core::{scene_measures, Base};
/// // Regular tetrahedron seen from inside: each face sees the other three equally.
/// let t = 1.0 / 3.0;
/// let f = [0.0, t, t, t, t, 0.0, t, t, t, t, 0.0, t, t, t, t, 0.0];
/// let m = scene_measures(&[1.0f64; 4], &f, Base::Bits).unwrap();
/// assert!((m.mutual_information - (4.0f64 / 3.0).log2()).abs() < 1e-12);
/// ```
pub fn scene_measures<T: Real>(areas: &[T], form_factors: &[T], base: Base) -> Result<SceneMeasures, Error> {
    let n = areas.len();
    let (total, hp) = relative_area_entropy(areas)?;
    let f = MatrixRef::new(form_factors, n, n)?;
    f.check_stochastic()?;
    let mut hs = Neumaier::new();
    for (i, a) in areas.iter().enumerate() {
        let a = a.to_f64() / total;
        if a > 0.0 {
            hs.add(a * entropy_nats(mass_xlnx(f.row(i))?));
        }
    }
    Ok(SceneMeasures::from_nats(n, 0, hp, hs.value(), base))
}

/// Number of lines (or line segments) that joined patch `from` to patch `to`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(C)]
pub struct PairCount {
    /// Source patch `i`.
    pub from: u32,
    /// Destination patch `j`.
    pub to: u32,
    /// `N_ij`.
    pub count: u64,
}

/// Scene measures from sparse line counts, with `F_ij = N_ij / N_i` and
/// `N_i = Σ_j N_ij` (Part III eqs. (30)–(31)).
///
/// `pairs` may list a pair several times (shards are simply concatenated);
/// `row_totals` is caller scratch of `n` values and receives `N_i`.
/// Relative areas come from the exact `areas`, as in Part III's tables.
/// The one-pass form used is
/// `H_S = Σ_i a_i ln N_i − Σ_(i,j) (a_i/N_i) N_ij ln N_ij` when each pair
/// appears once; repeated pairs are first summed, which needs `pairs`
/// sorted by `(from, to)`: unsorted input with repeats is refused.
///
/// # Errors
/// Area errors as [`crate::entropy_of_weights`]; [`Error::LengthMismatch`]
/// for `row_totals`; [`Error::LabelOutOfRange`] for a patch index `≥ n`;
/// [`Error::InvalidParameter`] (`name = "pairs"`) for unsorted pairs.
pub fn scene_measures_from_counts<T: Real>(
    areas: &[T],
    pairs: &[PairCount],
    row_totals: &mut [u64],
    base: Base,
) -> Result<SceneMeasures, Error> {
    scene_measures_from_counts_with(areas, pairs, row_totals, base, |c| xlnx(c as f64))
}

/// [`scene_measures_from_counts`] with `N_ij ln N_ij` taken from
/// `count_xlnx(N_ij)`, which must be [`xlnx`]`(N_ij as f64)` bit for bit
/// (a table of them: a logarithm per pair was most of this pass). The same
/// sum in the same order, so the same bits.
///
/// # Errors
/// As [`scene_measures_from_counts`].
pub fn scene_measures_from_counts_with<T: Real>(
    areas: &[T],
    pairs: &[PairCount],
    row_totals: &mut [u64],
    base: Base,
    count_xlnx: impl Fn(u64) -> f64,
) -> Result<SceneMeasures, Error> {
    let n = areas.len();
    let sum = SceneEntropySum::new(areas)?;
    same_len(n, row_totals.len())?;
    row_totals.iter_mut().for_each(|t| *t = 0);
    let mut prev: Option<(u32, u32)> = None;
    for (index, p) in pairs.iter().enumerate() {
        for idx in [p.from, p.to] {
            if idx as usize >= n {
                return Err(Error::LabelOutOfRange { index, label: idx as usize, groups: n });
            }
        }
        if let Some(pr) = prev
            && (p.from, p.to) < pr
        {
            return Err(Error::InvalidParameter { name: "pairs", value: index as f64 });
        }
        prev = Some((p.from, p.to));
        row_totals[p.from as usize] += p.count;
    }
    // Sum runs of equal pairs, then their terms, one at a time.
    let totals = &*row_totals;
    let mut k = 0;
    let terms = core::iter::from_fn(|| {
        let (i, j) = (pairs.get(k)?.from, pairs[k].to);
        let mut c = 0u64;
        while k < pairs.len() && pairs[k].from == i && pairs[k].to == j {
            c += pairs[k].count;
            k += 1;
        }
        let a = sum.relative_area(areas[i as usize]);
        Some(SceneEntropySum::pair_term(a, totals[i as usize], c, || count_xlnx(c)))
    });
    Ok(sum.measures(areas, totals, terms.flatten(), base))
}

/// `H_S` from sparse line counts (Part III eqs. (30)–(31) into (39)) as
/// [`scene_measures_from_counts_with`] sums it, for callers that hold the
/// row totals `N_i` and walk the pairs their own way (in pieces, on several
/// threads): `H_S = Σ_i a_i ln N_i − Σ_(i,j) (a_i/N_i) N_ij ln N_ij`, one
/// compensated sum of the row terms in row order, then of the pair terms
/// ([`SceneEntropySum::pair_term`]) in pair order: the same terms in the
/// same order give the same bits.
#[derive(Clone, Copy, Debug)]
pub struct SceneEntropySum {
    total: f64,
    hp: f64,
}

impl SceneEntropySum {
    /// The sum for patches of `areas` (their total and `H_P`).
    ///
    /// # Errors
    /// Area errors as [`crate::entropy_of_weights`].
    pub fn new<T: Real>(areas: &[T]) -> Result<Self, Error> {
        let (total, hp) = relative_area_entropy(areas)?;
        Ok(Self { total, hp })
    }

    /// The relative area `a_i = A_i / A_T` the sum weights row `i` by.
    #[inline]
    #[must_use]
    pub fn relative_area<T: Real>(&self, area: T) -> f64 {
        area.to_f64() / self.total
    }

    /// The term `−(a_i/N_i) N_ij ln N_ij` of pair `(i, j)` with count
    /// `count` in a row of relative area `a` and total `row_total`, its
    /// `N_ij ln N_ij` from `count_xlnx` ([`xlnx`] of the count, bit for bit);
    /// `None` where the sum adds nothing (no count, or a row of no area).
    #[inline]
    pub fn pair_term(a: f64, row_total: u64, count: u64, count_xlnx: impl FnOnce() -> f64) -> Option<f64> {
        (count > 0 && a > 0.0).then(|| -a / row_total as f64 * count_xlnx())
    }

    /// The measures from the row totals `N_i` (one per patch of `areas`)
    /// and the pair terms in pair order, in `base`.
    #[must_use]
    pub fn measures<T: Real>(
        &self,
        areas: &[T],
        row_totals: &[u64],
        pair_terms: impl IntoIterator<Item = f64>,
        base: Base,
    ) -> SceneMeasures {
        let mut running = self.rows(areas, row_totals);
        pair_terms.into_iter().for_each(|t| running.add(t));
        running.measures(base)
    }

    /// The sum begun with the row terms `a_i ln N_i` of the row totals
    /// `N_i` (one per patch of `areas`), in row order: the pair terms
    /// follow, in pair order, through [`SceneEntropyRunning::add`].
    #[must_use]
    pub fn rows<T: Real>(&self, areas: &[T], row_totals: &[u64]) -> SceneEntropyRunning {
        let mut hs = Neumaier::new();
        let mut unsampled = 0;
        for (&a, &t) in areas.iter().zip(row_totals) {
            let a = self.relative_area(a);
            if t == 0 {
                unsampled += usize::from(a > 0.0);
            } else if a > 0.0 {
                hs.add(a * ln(t as f64));
            }
        }
        SceneEntropyRunning { hs, unsampled, patches: areas.len(), hp: self.hp }
    }
}

/// A [`SceneEntropySum`] under way: its row terms added, the pair terms
/// being added in pair order.
#[derive(Clone, Copy, Debug)]
pub struct SceneEntropyRunning {
    hs: Neumaier,
    unsampled: usize,
    patches: usize,
    hp: f64,
}

impl SceneEntropyRunning {
    /// Adds the next pair term ([`SceneEntropySum::pair_term`]).
    #[inline]
    pub fn add(&mut self, pair_term: f64) {
        self.hs.add(pair_term);
    }

    /// The measures of the terms added, in `base`.
    #[must_use]
    pub fn measures(&self, base: Base) -> SceneMeasures {
        let hs = self.hs.value().max(0.0);
        SceneMeasures::from_nats(self.patches, self.unsampled, self.hp, hs, base)
    }
}

/// The mutual information matrix `I_ij = a_i F_ij log(F_ij / a_j)`
/// (Part III eq. (64)) into `out` (row-major `n × n`), and the per-patch
/// information transfer `I_i = Σ_j I_ij` (eq. (65)) into `per_patch`.
/// `Σ_i I_i` is `I_S` by eq. (63)/(66) when `F` is reciprocal.
/// A patch `j` of zero area seen with `F_ij > 0` (not reciprocal) gives
/// `I_ij = +∞`, the convention `p log(p/0) = +∞` of Part II eq. (8).
///
/// # Errors
/// As [`scene_measures`], and [`Error::LengthMismatch`] for the outputs.
pub fn mutual_information_matrix_into<T: Real>(
    areas: &[T],
    form_factors: &[T],
    base: Base,
    out: &mut [T],
    per_patch: &mut [T],
) -> Result<(), Error> {
    let n = areas.len();
    let (total, _) = relative_area_entropy(areas)?;
    let f = MatrixRef::new(form_factors, n, n)?;
    f.check_stochastic()?;
    same_len(n * n, out.len())?;
    same_len(n, per_patch.len())?;
    let k = base.per_nat();
    for i in 0..n {
        let ai = areas[i].to_f64() / total;
        let mut row = Neumaier::new();
        for j in 0..n {
            let fij = f.row(i)[j].to_f64();
            let aj = areas[j].to_f64() / total;
            // ln a_j; where A_j/A_T left the normal range (0 included), from
            // the two logarithms, so a tiny positive area keeps a finite log.
            let ln_aj = if aj >= f64::MIN_POSITIVE { ln(aj) } else { ln(areas[j].to_f64()) - ln(total) };
            let v = if fij > 0.0 && ai > 0.0 { ai * fij * (ln(fij) - ln_aj) } else { 0.0 };
            out[i * n + j] = T::from_f64(v * k);
            row.add(v);
        }
        per_patch[i] = T::from_f64(row.value() * k);
    }
    Ok(())
}

/// Point-to-point form factor `F(x, y) = cos θ_x cos θ_y / (π r²)` for
/// mutually visible points (Part III eq. (7)).
#[must_use]
#[inline]
pub fn point_form_factor(cos_x: f64, cos_y: f64, r2: f64) -> f64 {
    cos_x * cos_y / (core::f64::consts::PI * r2)
}

/// Running Monte Carlo estimate of the continuous scene mutual information
/// `I_S^c ≈ (1/N) Σ_k log(A_T F(x_k, y_k))` (Part III eq. (59)), mergeable
/// across shards, with the sample variance for a standard error.
///
/// For global lines a sample is one segment (a pair of consecutive
/// intersections facing each other); for local lines, one line (§6.1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContinuousMutualInformation {
    total_area: f64,
    samples: u64,
    sum: Neumaier,
    sum_sq: Neumaier,
}

impl ContinuousMutualInformation {
    /// An empty estimate for a scene of total area `A_T`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `total_area` is positive and finite.
    pub fn new(total_area: f64) -> Result<Self, Error> {
        if !(total_area > 0.0 && total_area.is_finite()) {
            return Err(Error::InvalidParameter { name: "total_area", value: total_area });
        }
        Ok(Self { total_area, ..Self::default() })
    }

    /// Adds one sample given its point-to-point form factor `F(x, y) > 0`.
    /// Non-positive or non-finite values are ignored and return `false`.
    #[inline]
    pub fn add_form_factor(&mut self, f: f64) -> bool {
        if !(f > 0.0 && f.is_finite()) {
            return false;
        }
        let l = log_area_form_factor(self.total_area, f);
        self.samples += 1;
        self.sum.add(l);
        self.sum_sq.add(l * l);
        true
    }

    /// Adds one sample from its geometry (cosines at both ends, squared length).
    #[inline]
    pub fn add_segment(&mut self, cos_x: f64, cos_y: f64, r2: f64) -> bool {
        self.add_form_factor(point_form_factor(cos_x, cos_y, r2))
    }

    /// Merges another shard's estimate (same scene).
    pub fn merge(&mut self, other: &Self) {
        self.samples += other.samples;
        self.sum.merge(&other.sum);
        self.sum_sq.merge(&other.sum_sq);
    }

    /// Number of samples.
    #[must_use]
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// `(A_T, N, Σ log(A_T F), Σ log²(A_T F))` in nats, for saving a shard.
    #[must_use]
    pub fn to_parts(&self) -> (f64, u64, f64, f64) {
        (self.total_area, self.samples, self.sum.value(), self.sum_sq.value())
    }

    /// Rebuilds an estimate saved with [`ContinuousMutualInformation::to_parts`].
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a bad area or non-finite sums.
    pub fn from_parts(total_area: f64, samples: u64, sum: f64, sum_sq: f64) -> Result<Self, Error> {
        let mut s = Self::new(total_area)?;
        if !(sum.is_finite() && sum_sq.is_finite() && sum_sq >= 0.0) {
            return Err(Error::InvalidParameter { name: "sum", value: sum });
        }
        s.samples = samples;
        s.sum.add(sum);
        s.sum_sq.add(sum_sq);
        Ok(s)
    }

    /// `I_S^c` in `base`; `None` before the first sample.
    #[must_use]
    pub fn estimate(&self, base: Base) -> Option<f64> {
        (self.samples > 0).then(|| self.sum.value() / self.samples as f64 * base.per_nat())
    }

    /// Standard error of the estimate (sample standard deviation over `√N`),
    /// treating samples as independent; `None` below two samples.
    #[must_use]
    pub fn standard_error(&self, base: Base) -> Option<f64> {
        if self.samples < 2 {
            return None;
        }
        let n = self.samples as f64;
        let mean = self.sum.value() / n;
        let var = ((self.sum_sq.value() - n * mean * mean) / (n - 1.0)).max(0.0);
        Some(libm::sqrt(var / n) * base.per_nat())
    }
}

/// One sample `ln(A_T F(x, y))` of `I_S^c` (Part III eq. (59)) in nats,
/// infallible: meant for `A_T > 0` and `F > 0` finite (then the result is
/// finite), as a sum of two logarithms where the product under- or
/// overflows (the logarithm of a product rounded to 0 or ∞ would be ∓∞).
#[inline]
#[must_use]
pub fn log_area_form_factor(total_area: f64, f: f64) -> f64 {
    let af = total_area * f;
    if (f64::MIN_POSITIVE..=f64::MAX).contains(&af) { ln(af) } else { ln(total_area) + ln(f) }
}

/// `I_S^c` from a slice of point-to-point form factors (Part III eq. (59)).
///
/// # Errors
/// [`Error::Empty`], [`Error::InvalidParameter`] for `total_area`,
/// [`Error::NonFinite`], [`Error::Negative`], and [`Error::ZeroMass`] if
/// no sample is positive.
pub fn continuous_mutual_information<T: Real>(
    total_area: f64,
    point_form_factors: &[T],
    base: Base,
) -> Result<T, Error> {
    non_empty(point_form_factors.len())?;
    mass(point_form_factors)?;
    let mut acc = ContinuousMutualInformation::new(total_area)?;
    for f in point_form_factors {
        acc.add_form_factor(f.to_f64());
    }
    acc.estimate(base).map(T::from_f64).ok_or(Error::ZeroMass)
}

fn check_areas(area_i: f64, area_j: f64, total: f64) -> Result<(), Error> {
    for (name, v) in [("area_i", area_i), ("area_j", area_j), ("total_area", total)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(Error::InvalidParameter { name, value: v });
        }
    }
    Ok(())
}

/// Visibility discretisation error between two patches from `N_ij`
/// patch-to-patch random lines, i.e. uniform area sampling (Part III eq. (73)):
///
/// ```text
/// δ_ij = (A_i A_j / A_T) ( mean_k F_k log F_k − mean_k F_k · log mean_k F_k )  ≥ 0
/// ```
/// `point_form_factors` are `F(x_k, y_k)`, zero for occluded pairs. The
/// bracket is the log-sum gap (Part II eq. (18)) and is never negative.
///
/// # Errors
/// [`Error::Empty`], [`Error::InvalidParameter`] for an area,
/// [`Error::NonFinite`], [`Error::Negative`].
pub fn discretisation_error_area_sampling<T: Real>(
    area_i: f64,
    area_j: f64,
    total_area: f64,
    point_form_factors: &[T],
    base: Base,
) -> Result<f64, Error> {
    check_areas(area_i, area_j, total_area)?;
    non_empty(point_form_factors.len())?;
    let m = mass_xlnx(point_form_factors)?;
    let n = point_form_factors.len() as f64;
    let mean = m.sum / n;
    let gap = m.xlnx / n - xlnx(mean);
    let gap = if gap < 0.0 { 0.0 } else { gap };
    Ok(area_i * area_j / total_area * gap * base.per_nat())
}

/// Visibility discretisation error between two patches from the `N_ij`
/// local lines or global-line segments joining them (Part III eq. (75)):
///
/// ```text
/// δ_ij = (A_i F_ij / A_T) ( (1/N_ij) Σ_k log F(x_k, y_k) − log(F_ij / A_j) )
/// ```
/// Non-negative in expectation (Jensen), but a Monte Carlo estimate can dip
/// below 0 at low counts; it is returned as computed.
///
/// # Errors
/// As [`discretisation_error_area_sampling`], plus [`Error::InvalidParameter`]
/// for `f_ij ∉ (0, 1]` and [`Error::ZeroMass`] if a sample is zero.
pub fn discretisation_error_lines<T: Real>(
    area_i: f64,
    area_j: f64,
    total_area: f64,
    f_ij: f64,
    point_form_factors: &[T],
    base: Base,
) -> Result<f64, Error> {
    check_areas(area_i, area_j, total_area)?;
    if !(f_ij > 0.0 && f_ij <= 1.0) {
        return Err(Error::InvalidParameter { name: "f_ij", value: f_ij });
    }
    non_empty(point_form_factors.len())?;
    mass(point_form_factors)?;
    let mut s = Neumaier::new();
    for f in point_form_factors {
        let f = f.to_f64();
        if f <= 0.0 {
            return Err(Error::ZeroMass);
        }
        s.add(ln(f));
    }
    let mean_ln = s.value() / point_form_factors.len() as f64;
    let r = f_ij / area_j;
    let ln_r = if (f64::MIN_POSITIVE..=f64::MAX).contains(&r) { ln(r) } else { ln(f_ij) - ln(area_j) };
    Ok(area_i * f_ij / total_area * (mean_ln - ln_r) * base.per_nat())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table of `x ln x` in [`scene_measures_from_counts_with`] gives the
    /// bits of [`scene_measures_from_counts`], repeated pairs included.
    #[test]
    fn counts_with_a_table_are_the_plain_counts_bits() {
        let areas = [1.0, 2.5, 0.75, 3.0];
        let pairs = [(0, 1, 3), (0, 1, 4), (0, 3, 1), (1, 0, 7), (1, 2, 90), (2, 2, 12), (3, 0, 5), (3, 1, 1 << 40)]
            .map(|(from, to, count)| PairCount { from, to, count });
        let table: [f64; 128] = core::array::from_fn(|c| xlnx(c as f64));
        let lookup = |c: u64| table.get(c as usize).copied().unwrap_or_else(|| xlnx(c as f64));
        for base in [Base::Nats, Base::Bits] {
            let plain = scene_measures_from_counts(&areas, &pairs, &mut [0; 4], base).unwrap();
            let with = scene_measures_from_counts_with(&areas, &pairs, &mut [0; 4], base, lookup).unwrap();
            assert_eq!(plain.scene_entropy.to_bits(), with.scene_entropy.to_bits());
            assert_eq!(plain.mutual_information.to_bits(), with.mutual_information.to_bits());
            assert_eq!(plain, with);
        }
    }
}
