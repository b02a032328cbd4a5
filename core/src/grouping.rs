//! The grouping property of entropy (Part II Fig. 1; Part IV eq. (24)).

use crate::math::{ln, xlnx};
use crate::scan::{check_normalized, mass, same_len};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// The two parts of the recursive decomposition `H(X) = H_in + H_out`
/// (Part IV eq. (24)) for a partition of the outcomes into groups.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grouping {
    /// `H_in = Σ_j q_j H(Y_j)`: information still hidden inside the groups.
    pub h_in: f64,
    /// `H_out = −Σ_j q_j log q_j`: information acquired by knowing the group.
    pub h_out: f64,
}

impl Grouping {
    /// `H_in + H_out`, which equals `H(X)`.
    #[must_use]
    pub fn total(&self) -> f64 {
        self.h_in + self.h_out
    }
}

/// Decomposes `H(p)` over the partition `labels` (outcome `k` is in group
/// `labels[k] < groups`); `scratch` holds the `groups` group masses `q_j`.
/// Its size follows the largest label: for arbitrary label values use
/// [`grouping_by_label`], whose scratch follows the number of outcomes.
///
/// `H_in` is computed term by term as `−Σ_k p_k log(p_k / q_{label(k)})`,
/// not as a difference, so the identity `H = H_in + H_out` is a real check.
///
/// # Errors
/// As [`crate::Pmf::new`]; [`Error::LengthMismatch`] for `labels` or
/// `scratch`; [`Error::LabelOutOfRange`].
pub fn grouping<T: Real>(
    p: &[T],
    labels: &[usize],
    groups: usize,
    scratch: &mut [f64],
    base: Base,
) -> Result<Grouping, Error> {
    same_len(p.len(), labels.len())?;
    same_len(groups, scratch.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    scratch.iter_mut().for_each(|q| *q = 0.0);
    for (index, (&label, x)) in labels.iter().zip(p).enumerate() {
        if label >= groups {
            return Err(Error::LabelOutOfRange { index, label, groups });
        }
        scratch[label] += x.to_f64() / s;
    }
    let mut out = Neumaier::new();
    for &q in scratch.iter() {
        out.add(-xlnx(q));
    }
    let mut inner = Neumaier::new();
    for (&label, x) in labels.iter().zip(p) {
        let x = x.to_f64() / s;
        if x > 0.0 {
            inner.add(-x * (ln(x) - ln(scratch[label])));
        }
    }
    let k = base.per_nat();
    Ok(Grouping { h_in: inner.value() * k, h_out: out.value() * k })
}

/// [`grouping`] for arbitrary label values: outcomes with equal labels form
/// a group, whatever the labels are (`0` and `99_999_999` are two groups).
///
/// Scratch is sized by the number of outcomes `n`, never by the largest
/// label: `order` (`n` indices) receives the outcomes sorted by label
/// (stable), and `masses[..g]` the `g` group masses `q_j` in increasing label
/// order; `g` is returned beside the decomposition. `core`'s unstable sort of
/// `(label, index)` keys needs no allocation.
///
/// # Errors
/// As [`crate::Pmf::new`]; [`Error::LengthMismatch`] for `labels`, `order`
/// or `masses`.
pub fn grouping_by_label<T: Real>(
    p: &[T],
    labels: &[usize],
    order: &mut [usize],
    masses: &mut [f64],
    base: Base,
) -> Result<(Grouping, usize), Error> {
    same_len(p.len(), labels.len())?;
    same_len(p.len(), order.len())?;
    same_len(p.len(), masses.len())?;
    let s = mass(p)?;
    check_normalized::<T>(s)?;
    order.iter_mut().enumerate().for_each(|(k, o)| *o = k);
    order.sort_unstable_by_key(|&k| (labels[k], k));
    masses.iter_mut().for_each(|q| *q = 0.0);
    // Runs of equal labels in `order` are the groups.
    let mut out = Neumaier::new();
    let mut inner = Neumaier::new();
    let mut g = 0;
    let mut start = 0;
    while start < order.len() {
        let label = labels[order[start]];
        let end = start + order[start..].iter().take_while(|&&k| labels[k] == label).count();
        let run = &order[start..end];
        let mut q = Neumaier::new();
        run.iter().for_each(|&k| q.add(p[k].to_f64() / s));
        let q = q.value();
        masses[g] = q;
        out.add(-xlnx(q));
        for &k in run {
            let x = p[k].to_f64() / s;
            if x > 0.0 {
                inner.add(-x * (ln(x) - ln(q)));
            }
        }
        g += 1;
        start = end;
    }
    let k = base.per_nat();
    Ok((Grouping { h_in: inner.value() * k, h_out: out.value() * k }, g))
}
