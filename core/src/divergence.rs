//! Divergences between distributions: Kullback–Leibler (Part II eq. (8)),
//! Csiszár f-divergences (Part III-IV eqs. (1)–(9), Table 1), Jensen–Shannon
//! (Part II eq. (17)), and the Bregman and Burbea–Rao families (Part III-IV §2.2).

use crate::kernels::kl_term;
use crate::math::{ln, xlnx};
use crate::matrix::MatrixRef;
use crate::scan::{check_normalized, kl_pass, mass, same_len};
use crate::sum::Neumaier;
use crate::{Base, Error, Real};

/// Kullback–Leibler divergence `D_KL(p‖q) = Σ p_i log(p_i / q_i)`
/// (Part II eq. (8); Part III-IV eq. (7)).
///
/// ```text
/// 0 · log(0/q) = 0,   p · log(p/0) = +∞ (p > 0)
/// ```
/// Returns `+∞` (a value, not an error) when `p` puts mass where `q` has none.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`], [`Error::NonFinite`],
/// [`Error::Negative`], [`Error::ZeroMass`], [`Error::NotNormalized`].
///
/// # Examples
/// ```
/// use itgfx_core::{kl_divergence, Base};
/// let d = kl_divergence(&[0.5f64, 0.5], &[0.25, 0.75], Base::Bits).unwrap();
/// assert!((d - (0.5 * 2f64.log2() + 0.5 * (2.0f64 / 3.0).log2())).abs() < 1e-15);
/// ```
pub fn kl_divergence<T: Real>(p: &[T], q: &[T], base: Base) -> Result<T, Error> {
    same_len(p.len(), q.len())?;
    let (sp, sq, d) = kl_pass(p, q)?;
    check_normalized::<T>(sp)?;
    check_normalized::<T>(sq)?;
    let d = if d < 0.0 { 0.0 } else { d };
    Ok(T::from_f64(d * base.per_nat()))
}

/// A convex generator `f` of a Csiszár f-divergence (Part III-IV Def. 2).
///
/// `f` is convex on `(0, ∞)` with `f(1) = 0`. The extension rules of
/// Part III-IV eqs. (3) and (5) need its two limits.
pub trait FGenerator {
    /// `f(u)` for `u > 0`.
    fn f(&self, u: f64) -> f64;
    /// `f(0) = lim_{u→0⁺} f(u)` (may be `+∞`).
    fn f_at_zero(&self) -> f64;
    /// `lim_{u→∞} f(u)/u` (may be `+∞`).
    fn slope_at_infinity(&self) -> f64;
    /// `q f(p/q)` for `p, q > 0`. The default forms the ratio; where it
    /// overflows (`q` subnormal) it uses `p · lim f(u)/u`, and where it
    /// underflows to 0, `q f(0)`. Generators with a closed form in `p` and
    /// `q` override this so that no ratio is formed (all of this module's do).
    fn term(&self, p: f64, q: f64) -> f64 {
        let u = p / q;
        if u == f64::INFINITY {
            p * self.slope_at_infinity()
        } else if u == 0.0 {
            q * self.f_at_zero()
        } else {
            q * self.f(u)
        }
    }
}

/// `q f(p/q)` with the extension rules of Part III-IV eq. (5).
#[inline]
pub fn f_term<G: FGenerator + ?Sized>(g: &G, p: f64, q: f64) -> f64 {
    if q > 0.0 {
        if p > 0.0 { g.term(p, q) } else { q * g.f_at_zero() }
    } else if p > 0.0 {
        p * g.slope_at_infinity()
    } else {
        0.0
    }
}

/// Csiszár f-divergence `D_f(p, q) = Σ q_i f(p_i / q_i)` (Part III-IV eq. (4)).
///
/// # Errors
/// As [`kl_divergence`].
pub fn f_divergence<T: Real, G: FGenerator + ?Sized>(p: &[T], q: &[T], g: &G) -> Result<T, Error> {
    let (p, q) = validate_pair(p, q)?;
    let mut acc = Neumaier::new();
    for (x, y) in p.iter().zip(q) {
        acc.add(f_term(g, x.to_f64(), y.to_f64()));
    }
    let v = acc.value();
    Ok(T::from_f64(if v < 0.0 { 0.0 } else { v }))
}

fn validate_pair<'a, T: Real>(p: &'a [T], q: &'a [T]) -> Result<(&'a [T], &'a [T]), Error> {
    same_len(p.len(), q.len())?;
    check_normalized::<T>(mass(p)?)?;
    check_normalized::<T>(mass(q)?)?;
    Ok((p, q))
}

/// `f(u) = u ln u`: Kullback–Leibler in nats (Part III-IV eq. (7)).
#[derive(Clone, Copy, Debug, Default)]
pub struct KullbackLeibler;
impl FGenerator for KullbackLeibler {
    fn f(&self, u: f64) -> f64 {
        xlnx(u)
    }
    fn f_at_zero(&self) -> f64 {
        0.0
    }
    fn slope_at_infinity(&self) -> f64 {
        f64::INFINITY
    }
    /// `p ln(p/q)`, with two logarithms where the ratio leaves the doubles.
    fn term(&self, p: f64, q: f64) -> f64 {
        kl_term(p, q)
    }
}

/// `f(u) = (u − 1)²`: Pearson's chi-square (Part III-IV eq. (8)).
#[derive(Clone, Copy, Debug, Default)]
pub struct ChiSquare;
impl FGenerator for ChiSquare {
    fn f(&self, u: f64) -> f64 {
        (u - 1.0) * (u - 1.0)
    }
    fn f_at_zero(&self) -> f64 {
        1.0
    }
    fn slope_at_infinity(&self) -> f64 {
        f64::INFINITY
    }
    /// `(p − q)²/q`: `+∞` only where the true value exceeds the doubles.
    fn term(&self, p: f64, q: f64) -> f64 {
        let d = p - q;
        d * (d / q)
    }
}

/// `f(u) = ½(√u − 1)²`: Hellinger, in `[0, 1]` (Part III-IV eq. (9)).
#[derive(Clone, Copy, Debug, Default)]
pub struct Hellinger;
impl FGenerator for Hellinger {
    fn f(&self, u: f64) -> f64 {
        let r = libm::sqrt(u) - 1.0;
        0.5 * r * r
    }
    fn f_at_zero(&self) -> f64 {
        0.5
    }
    fn slope_at_infinity(&self) -> f64 {
        0.5
    }
    /// `½(√p − √q)²` directly: bounded by `½(p + q)` whatever `q` is (the
    /// ratio `p/q` overflowed for subnormal `q` and gave `+∞`).
    fn term(&self, p: f64, q: f64) -> f64 {
        // √p − √q = (p − q)/(√p + √q): no cancellation when p ≈ q.
        let r = (p - q) / (libm::sqrt(p) + libm::sqrt(q));
        0.5 * r * r
    }
}

/// `f(u) = ½|u − 1|`: total variation, equal to Table 1's Vasershtein–Ornstein
/// `VO(p, q) = 1 − Σ min(p_i, q_i)` on distributions.
#[derive(Clone, Copy, Debug, Default)]
pub struct TotalVariation;
impl FGenerator for TotalVariation {
    fn f(&self, u: f64) -> f64 {
        0.5 * (u - 1.0).abs()
    }
    fn f_at_zero(&self) -> f64 {
        0.5
    }
    fn slope_at_infinity(&self) -> f64 {
        0.5
    }
    /// `½|p − q|` directly (bounded; no ratio to overflow).
    fn term(&self, p: f64, q: f64) -> f64 {
        0.5 * (p - q).abs()
    }
}

/// `f(u) = ((u+1)/2) ln((u+1)/(2√u))`: the arithmetic-geometric mean
/// divergence of Table 1 (Part III-IV), in nats.
///
/// Table 1 prints the summand as `ln(((p+q)/2)/√(pq))`; the standard
/// divergence (Taneja; Pardo–Vajda, whom §2.2 follows) weights each log by
/// the arithmetic mean `(p+q)/2`, which is what makes it an f-divergence.
/// That weighted form is what this generator gives.
#[derive(Clone, Copy, Debug, Default)]
pub struct ArithmeticGeometric;
impl FGenerator for ArithmeticGeometric {
    fn f(&self, u: f64) -> f64 {
        let a = 0.5 * (u + 1.0);
        a * (ln(a) - 0.5 * ln(u))
    }
    fn f_at_zero(&self) -> f64 {
        f64::INFINITY
    }
    fn slope_at_infinity(&self) -> f64 {
        f64::INFINITY
    }
    /// `q f(p/q)`, or `a (ln a − ½ ln p − ½ ln q)` with `a = (p + q)/2`
    /// where the ratio leaves the normal doubles (finite for all `p, q > 0`).
    fn term(&self, p: f64, q: f64) -> f64 {
        let u = p / q;
        if (f64::MIN_POSITIVE..=f64::MAX).contains(&u) {
            q * self.f(u)
        } else {
            let a = 0.5 * p + 0.5 * q;
            a * (ln(a) - 0.5 * (ln(p) + ln(q)))
        }
    }
}

/// Chi-square divergence `Σ (p_i − q_i)² / q_i` (Part III-IV eq. (8)).
///
/// # Errors
/// As [`kl_divergence`].
pub fn chi_square<T: Real>(p: &[T], q: &[T]) -> Result<T, Error> {
    f_divergence(p, q, &ChiSquare)
}

/// Hellinger divergence `½ Σ (√p_i − √q_i)²` (Part III-IV eq. (9)).
///
/// # Errors
/// As [`kl_divergence`].
pub fn hellinger<T: Real>(p: &[T], q: &[T]) -> Result<T, Error> {
    f_divergence(p, q, &Hellinger)
}

/// Vasershtein–Ornstein divergence `1 − Σ min(p_i, q_i)` (Part III-IV Table 1).
///
/// # Errors
/// As [`kl_divergence`].
pub fn vasershtein_ornstein<T: Real>(p: &[T], q: &[T]) -> Result<T, Error> {
    f_divergence(p, q, &TotalVariation)
}

/// Arithmetic-geometric divergence (Part III-IV Table 1; see
/// [`ArithmeticGeometric`] for the form), in `base`.
///
/// # Errors
/// As [`kl_divergence`].
pub fn arithmetic_geometric<T: Real>(p: &[T], q: &[T], base: Base) -> Result<T, Error> {
    f_divergence(p, q, &ArithmeticGeometric).map(|v| T::from_f64(v.to_f64() * base.per_nat()))
}

/// `L_α`-norm divergence `Σ |p_i − q_i|^α` (Part III-IV Table 1; `α ∈ {1, 2}`
/// there, any `α > 0` here).
///
/// # Errors
/// [`Error::InvalidParameter`] for `alpha` not positive and finite, then as [`kl_divergence`].
pub fn l_alpha<T: Real>(p: &[T], q: &[T], alpha: f64) -> Result<T, Error> {
    if !(alpha > 0.0 && alpha.is_finite()) {
        return Err(Error::InvalidParameter { name: "alpha", value: alpha });
    }
    let (p, q) = validate_pair(p, q)?;
    let mut acc = Neumaier::new();
    for (x, y) in p.iter().zip(q) {
        let d = (x.to_f64() - y.to_f64()).abs();
        acc.add(if alpha == 1.0 {
            d
        } else if alpha == 2.0 {
            d * d
        } else {
            libm::pow(d, alpha)
        });
    }
    Ok(T::from_f64(acc.value()))
}

/// All the f-divergences of Part III-IV at once, with their square roots
/// (Def. 4 uses `D^½`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Divergences {
    /// `D_KL(p‖q)` in the requested base (eq. (7)).
    pub kl: f64,
    /// `D_χ²(p, q)` (eq. (8)).
    pub chi_square: f64,
    /// `D_h²(p, q)` (eq. (9)).
    pub hellinger: f64,
    /// `√D_KL`.
    pub kl_sqrt: f64,
    /// `√D_χ²`.
    pub chi_square_sqrt: f64,
    /// `√D_h²` (a metric).
    pub hellinger_sqrt: f64,
    /// Arithmetic-geometric (Table 1) in the requested base.
    pub arithmetic_geometric: f64,
    /// Vasershtein–Ornstein (Table 1).
    pub vasershtein_ornstein: f64,
    /// `L_1` (Table 1).
    pub l1: f64,
    /// `L_2` (Table 1).
    pub l2: f64,
}

/// Computes every [`Divergences`] field for one pair of distributions.
///
/// # Errors
/// As [`kl_divergence`].
pub fn divergences<T: Real>(p: &[T], q: &[T], base: Base) -> Result<Divergences, Error> {
    let kl = kl_divergence(p, q, base)?.to_f64();
    let chi = chi_square(p, q)?.to_f64();
    let hel = hellinger(p, q)?.to_f64();
    Ok(Divergences {
        kl,
        chi_square: chi,
        hellinger: hel,
        kl_sqrt: libm::sqrt(kl),
        chi_square_sqrt: libm::sqrt(chi),
        hellinger_sqrt: libm::sqrt(hel),
        arithmetic_geometric: arithmetic_geometric(p, q, base)?.to_f64(),
        vasershtein_ornstein: vasershtein_ornstein(p, q)?.to_f64(),
        l1: l_alpha(p, q, 1.0)?.to_f64(),
        l2: l_alpha(p, q, 2.0)?.to_f64(),
    })
}

/// Weighted Jensen–Shannon divergence of `N` distributions (Part II eq. (17)):
///
/// ```text
/// JS(π; p_1..p_N) = H(Σ π_i p_i) − Σ π_i H(p_i) = Σ_i π_i D_KL(p_i ‖ Σ_k π_k p_k)
/// ```
/// `dists` is row-major `N × M` (row `i` is `p_i`). The second form is the one
/// computed: every term is non-negative, so no cancellation. With `π = p(X)`
/// and rows `p(Y|x)` it is the mutual information `I(X;Y)` (Part II §5).
///
/// # Errors
/// [`Error::LengthMismatch`] if `dists.len() != N · M` for `N = weights.len()`;
/// the weights and each row must be distributions (as [`kl_divergence`], with
/// [`Error::RowNotNormalized`] for rows).
pub fn jensen_shannon<T: Real>(weights: &[T], dists: &[T], m: usize, base: Base) -> Result<T, Error> {
    let n = weights.len();
    if n == 0 || m == 0 {
        return Err(Error::Empty);
    }
    let mat = MatrixRef::new(dists, n, m)?;
    check_normalized::<T>(mass(weights)?)?;
    mat.check_stochastic()?;
    Ok(T::from_f64(mixture_divergence(weights, &mat) * base.per_nat()))
}

/// `Σ_i w_i D_KL(M_i ‖ Σ_k w_k M_k)` in nats over validated inputs; the
/// kernel of [`jensen_shannon`] and of the channel mutual information.
pub(crate) fn mixture_divergence<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> f64 {
    mixture_divergence_and_entropy(w, m).0
}

/// As [`mixture_divergence`], also returning `H(Σ w_i M_i)` and
/// `Σ_i w_i H(M_i)` in nats: one logarithm per matrix element serves both
/// the divergence and the row entropies.
pub(crate) fn mixture_divergence_and_entropy<T: Real, W: Real>(w: &[W], m: &MatrixRef<'_, T>) -> (f64, f64, f64) {
    crate::dispatch::mixture(w, m)
}

/// A convex function with its derivative, generating Bregman and Burbea–Rao
/// divergences (Part III-IV §2.2).
pub trait ConvexFunction {
    /// `f(u)` for `u ≥ 0`.
    fn f(&self, u: f64) -> f64;
    /// `f'(u)` for `u ≥ 0` (may be `−∞` at 0).
    fn df(&self, u: f64) -> f64;
}

/// `f(u) = u ln u`: Bregman gives KL (in nats) on distributions, Burbea–Rao
/// gives the equal-weight Jensen–Shannon divergence.
#[derive(Clone, Copy, Debug, Default)]
pub struct ULogU;
impl ConvexFunction for ULogU {
    fn f(&self, u: f64) -> f64 {
        xlnx(u)
    }
    fn df(&self, u: f64) -> f64 {
        if u > 0.0 { ln(u) + 1.0 } else { f64::NEG_INFINITY }
    }
}

/// `f(u) = u²`: Bregman gives the squared Euclidean distance.
#[derive(Clone, Copy, Debug, Default)]
pub struct Square;
impl ConvexFunction for Square {
    fn f(&self, u: f64) -> f64 {
        u * u
    }
    fn df(&self, u: f64) -> f64 {
        2.0 * u
    }
}

/// Bregman divergence `Σ f(p_i) − f(q_i) − f'(q_i)(p_i − q_i)` (Part III-IV §2.2).
///
/// # Errors
/// As [`kl_divergence`].
pub fn bregman<T: Real, F: ConvexFunction + ?Sized>(p: &[T], q: &[T], f: &F) -> Result<T, Error> {
    let (p, q) = validate_pair(p, q)?;
    let mut acc = Neumaier::new();
    for (x, y) in p.iter().zip(q) {
        let (x, y) = (x.to_f64(), y.to_f64());
        if x != y {
            acc.add(f.f(x) - f.f(y) - f.df(y) * (x - y));
        }
    }
    let v = acc.value();
    Ok(T::from_f64(if v < 0.0 { 0.0 } else { v }))
}

/// Burbea–Rao divergence `Σ (f(p_i) + f(q_i))/2 − f((p_i + q_i)/2)` (Part III-IV §2.2).
///
/// # Errors
/// As [`kl_divergence`].
pub fn burbea_rao<T: Real, F: ConvexFunction + ?Sized>(p: &[T], q: &[T], f: &F) -> Result<T, Error> {
    let (p, q) = validate_pair(p, q)?;
    let mut acc = Neumaier::new();
    for (x, y) in p.iter().zip(q) {
        let (x, y) = (x.to_f64(), y.to_f64());
        acc.add(0.5 * (f.f(x) + f.f(y)) - f.f(0.5 * (x + y)));
    }
    let v = acc.value();
    Ok(T::from_f64(if v < 0.0 { 0.0 } else { v }))
}

/// The two sides of the log-sum inequality (Part II eq. (18)) for
/// non-negative `a` and `b`: returns `(Σ a_i log(a_i/b_i), A log(A/B))` with
/// `A = Σa`, `B = Σb`. The first is never below the second.
///
/// # Errors
/// [`Error::Empty`], [`Error::LengthMismatch`], [`Error::NonFinite`], [`Error::Negative`].
pub fn log_sum_terms<T: Real>(a: &[T], b: &[T], base: Base) -> Result<(T, T), Error> {
    same_len(a.len(), b.len())?;
    let sa = mass(a)?;
    let sb = mass(b)?;
    let mut lhs = Neumaier::new();
    for (x, y) in a.iter().zip(b) {
        lhs.add(kl_term(x.to_f64(), y.to_f64()));
    }
    let rhs = kl_term(sa, sb);
    let k = base.per_nat();
    Ok((T::from_f64(lhs.value() * k), T::from_f64(rhs * k)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wide channels take the streaming path under `alloc`; it must agree with
    /// the allocation-free blocked path and with H(X) + H(Y) − H(X,Y).
    #[test]
    fn streaming_and_blocked_agree_on_wide_channels() {
        let (r, c) = (7, 700);
        let mut s: u64 = 0x1234_5678_9ABC_DEF1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut m: [f64; 4900] = [0.0; 4900];
        for row in m.chunks_mut(c) {
            for x in row.iter_mut() {
                let u = next();
                *x = if u < 0.2 { 0.0 } else { u };
            }
            let t: f64 = row.iter().sum();
            row.iter_mut().for_each(|x| *x /= t);
        }
        let w = [0.05, 0.1, 0.2, 0.0, 0.3, 0.15, 0.2];
        let mat = MatrixRef::new(&m[..], r, c).unwrap();
        let blocked = crate::kernels::mixture_blocked(&w, &mat);
        let body = crate::kernels::mixture_body(&w, &mat);
        for (a, b) in [(blocked.0, body.0), (blocked.1, body.1), (blocked.2, body.2)] {
            assert!((a - b).abs() < 1e-12 * a.abs().max(1.0), "{a} vs {b}");
        }
        let mut joint = [0.0; 4900];
        for i in 0..r {
            for j in 0..c {
                joint[i * c + j] = w[i] * m[i * c + j];
            }
        }
        let e = crate::joint_entropies(&joint[..], r, c, Base::Nats).unwrap();
        assert!((e.mutual_information - body.0).abs() < 1e-10, "{} vs {}", e.mutual_information, body.0);
        assert!((e.h_y - body.1).abs() < 1e-10);
    }
}
