//! Quantiles of the normal and Student's t distributions (for the
//! confidence test of Part IV eq. (5)).

use core::f64::consts::{PI, SQRT_2};

/// Standard normal quantile `Φ⁻¹(p)` for `p ∈ (0, 1)`: Acklam's rational
/// approximation refined by one Halley step on `libm::erfc` (about 1e-15
/// relative).
pub(crate) fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] =
        [7.784_695_709_041_462e-3, 3.224_671_290_700_398e-1, 2.445_134_137_142_996, 3.754_408_661_907_416];
    let lo = 0.02425;
    let x = if p < lo {
        let q = libm::sqrt(-2.0 * libm::log(p));
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - lo {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        let q = libm::sqrt(-2.0 * libm::log(1.0 - p));
        -(((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    // One Halley step: e = Φ(x) − p.
    let e = 0.5 * libm::erfc(-x / SQRT_2) - p;
    let u = e * libm::sqrt(2.0 * PI) * libm::exp(x * x / 2.0);
    x - u / (1.0 + x * u / 2.0)
}

/// Student's t quantile `t_{p, ν}` for `p ∈ (0.5, 1)`, `ν ≥ 1`, by Hill's
/// algorithm 396 (1970), accurate to about 1e-8 for the orders used here.
pub(crate) fn student_t_quantile(p: f64, dof: usize) -> f64 {
    let n = dof.max(1) as f64;
    // Hill works with the two-tailed probability.
    let p2 = 2.0 * (1.0 - p);
    if dof == 1 {
        let a = p2 * PI / 2.0;
        return libm::cos(a) / libm::sin(a);
    }
    if dof == 2 {
        return libm::sqrt(2.0 / (p2 * (2.0 - p2)) - 2.0);
    }
    let a = 1.0 / (n - 0.5);
    let b = 48.0 / (a * a);
    let mut c = ((20700.0 * a / b - 98.0) * a - 16.0) * a + 96.36;
    let d = ((94.5 / (b + c) - 3.0) / b + 1.0) * libm::sqrt(a * PI / 2.0) * n;
    let mut x = d * p2;
    let mut y = libm::pow(x, 2.0 / n);
    if y > 0.05 + a {
        x = normal_quantile(p2 * 0.5);
        y = x * x;
        if dof < 5 {
            c += 0.3 * (n - 4.5) * (x + 0.6);
        }
        c += (((0.05 * d * x - 5.0) * x - 7.0) * x - 2.0) * x + b;
        y = (((((0.4 * y + 6.3) * y + 36.0) * y + 94.5) / c - y - 3.0) / b + 1.0) * x;
        y = a * y * y;
        y = if y > 0.002 { libm::exp(y) - 1.0 } else { 0.5 * y * y + y };
    } else {
        y = ((1.0 / (((n + 6.0) / (n * y) - 0.089 * d - 0.822) * (n + 2.0) * 3.0) + 0.5 / (n + 4.0)) * y - 1.0)
            * (n + 1.0)
            / (n + 2.0)
            + 1.0 / y;
    }
    libm::sqrt(n * y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table values of Student's t and the normal distribution (any
    /// statistics text, e.g. the NIST/SEMATECH e-Handbook tables), 6 digits.
    #[test]
    fn quantiles_match_tables() {
        let t = [
            (0.95, 1, 6.313752),
            (0.95, 7, 1.894579),
            (0.975, 7, 2.364624),
            (0.975, 30, 2.042272),
            (0.995, 4, 4.604095),
            (0.95, 2, 2.919986),
        ];
        for (p, dof, want) in t {
            let got = student_t_quantile(p, dof);
            assert!((got - want).abs() < 2e-6, "t({p}, {dof}) = {got}, table {want}");
        }
        for (p, want) in [(0.975, 1.959964), (0.95, 1.644854), (0.995, 2.575829), (0.01, -2.326348)] {
            let got = normal_quantile(p);
            assert!((got - want).abs() < 1e-6, "z({p}) = {got}");
        }
    }
}
