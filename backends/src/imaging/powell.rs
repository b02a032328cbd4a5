//! Powell's direction-set minimiser with Brent's line searches (the
//! derivative-free method of Numerical Recipes §10.5, §10.2): each
//! iteration minimises along every direction in turn, then replaces the
//! direction of largest decrease by the iteration's net displacement when
//! Powell's test says the set stays conjugate.

/// Stopping rules.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowellOptions {
    /// Stop when an iteration lowers `f` by less than `ftol·(|f| + |f'|)/2`.
    pub ftol: f64,
    /// Absolute tolerance of a line search, in units of the direction's length.
    pub xtol: f64,
    /// Most outer iterations.
    pub max_iterations: usize,
    /// Farthest a bracket may expand, in units of the direction's length.
    pub max_step: f64,
}

/// What the minimiser found.
#[derive(Clone, Debug, PartialEq)]
pub struct PowellResult<const N: usize> {
    /// The minimiser.
    pub x: [f64; N],
    /// `f(x)`.
    pub fx: f64,
    /// Outer iterations done.
    pub iterations: usize,
    /// Evaluations of `f`.
    pub evaluations: usize,
    /// `f` at the start, then after each outer iteration.
    pub trace: Vec<f64>,
}

const GOLD: f64 = 1.618_033_988_749_895;
const CGOLD: f64 = 0.381_966_011_250_105;

struct Counted<F> {
    f: F,
    n: usize,
}

impl<F> Counted<F> {
    fn eval<const N: usize>(&mut self, x: &[f64; N]) -> f64
    where
        F: FnMut(&[f64; N]) -> f64,
    {
        self.n += 1;
        let v = (self.f)(x);
        if v.is_nan() { f64::INFINITY } else { v }
    }
}

/// Relative change of `f` below which two values are the same: rounding
/// (a metric flat along a direction, such as an image constant along `y`
/// shifted along `y`, differs by a few ulps from point to point).
const FLAT: f64 = 1e-12;

/// Whether `new` is lower than `old` by more than rounding ([`FLAT`]).
fn lower(new: f64, old: f64) -> bool {
    old - new > FLAT * (old.abs() + 1.0)
}

fn along<const N: usize>(x: &[f64; N], d: &[f64; N], t: f64) -> [f64; N] {
    core::array::from_fn(|i| x[i] + t * d[i])
}

/// Minimises along `d` from `x` (where `f(x) = fx`); returns the new point
/// and value. The point moves only for a decrease beyond rounding
/// ([`lower`]): along a flat direction it stays, where accepting ulp-sized
/// "decreases" let the bracket run to `max_step` and the registration of an
/// image constant along `y` with itself wander 47 pixels (issue 24).
fn line_minimise<const N: usize, F: FnMut(&[f64; N]) -> f64>(
    f: &mut Counted<F>,
    x: &[f64; N],
    fx: f64,
    d: &[f64; N],
    o: &PowellOptions,
) -> ([f64; N], f64) {
    let mut g = |t: f64| f.eval(&along(x, d, t));
    // Bracket: a downhill pair, then golden expansion until f rises.
    let (mut a, mut fa, mut b, mut fb) = (0.0, fx, 1.0, g(1.0));
    if fb > fa {
        (a, fa, b, fb) = (b, fb, a, fa);
    }
    let mut c = b + GOLD * (b - a);
    let mut fc = g(c);
    while lower(fc, fb) && c.abs() < o.max_step {
        (a, fa, b, fb) = (b, fb, c, fc);
        c = b + GOLD * (b - a);
        fc = g(c);
    }
    let _ = fa;
    if lower(fc, fb) {
        // Ran to the step limit still descending: take the farthest point.
        return if lower(fc, fx) { (along(x, d, c), fc) } else { (*x, fx) };
    }
    // Brent on the bracket [a, c] around b.
    let (mut lo, mut hi) = if a < c { (a, c) } else { (c, a) };
    let (mut xb, mut w, mut v) = (b, b, b);
    let (mut fxb, mut fw, mut fv) = (fb, fb, fb);
    let (mut dd, mut e): (f64, f64) = (0.0, 0.0);
    let tol1 = o.xtol;
    let tol2 = 2.0 * tol1;
    for _ in 0..100 {
        let xm = 0.5 * (lo + hi);
        if (xb - xm).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (xb - w) * (fxb - fv);
            let mut q = (xb - v) * (fxb - fw);
            let mut p = (xb - v) * q - (xb - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            if !(p.abs() >= (0.5 * q * etemp).abs() || p <= q * (lo - xb) || p >= q * (hi - xb)) {
                e = dd;
                dd = p / q;
                let u = xb + dd;
                if u - lo < tol2 || hi - u < tol2 {
                    dd = tol1.copysign(xm - xb);
                }
                golden = false;
            }
        }
        if golden {
            e = if xb >= xm { lo - xb } else { hi - xb };
            dd = CGOLD * e;
        }
        let u = if dd.abs() >= tol1 { xb + dd } else { xb + tol1.copysign(dd) };
        let fu = g(u);
        if fu <= fxb {
            if u >= xb {
                lo = xb;
            } else {
                hi = xb;
            }
            (v, fv, w, fw, xb, fxb) = (w, fw, xb, fxb, u, fu);
        } else {
            if u < xb {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == xb {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == xb || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    if lower(fxb, fx) { (along(x, d, xb), fxb) } else { (*x, fx) }
}

/// Minimises `f` from `x0`, starting with the directions `scales[i]·e_i`.
pub fn minimise<const N: usize, F: FnMut(&[f64; N]) -> f64>(
    f: F,
    x0: [f64; N],
    scales: [f64; N],
    o: &PowellOptions,
) -> PowellResult<N> {
    let mut f = Counted { f, n: 0 };
    let mut dirs: [[f64; N]; N] =
        core::array::from_fn(|i| core::array::from_fn(|j| if i == j { scales[i] } else { 0.0 }));
    let mut x = x0;
    let mut fx = f.eval(&x);
    let mut pt = x;
    let mut trace = vec![fx];
    let mut iterations = 0;
    while iterations < o.max_iterations {
        iterations += 1;
        let fp = fx;
        let (mut ibig, mut del) = (0, 0.0);
        for (i, d) in dirs.iter().enumerate() {
            let before = fx;
            (x, fx) = line_minimise(&mut f, &x, fx, d, o);
            if before - fx > del {
                (ibig, del) = (i, before - fx);
            }
        }
        trace.push(fx);
        if 2.0 * (fp - fx) <= o.ftol * (fp.abs() + fx.abs()) + 1e-15 {
            break;
        }
        let ptt: [f64; N] = core::array::from_fn(|i| 2.0 * x[i] - pt[i]);
        let xit: [f64; N] = core::array::from_fn(|i| x[i] - pt[i]);
        pt = x;
        let fptt = f.eval(&ptt);
        if fptt < fp {
            let t = 2.0 * (fp - 2.0 * fx + fptt) * (fp - fx - del).powi(2) - del * (fp - fptt).powi(2);
            if t < 0.0 && xit.iter().any(|v| *v != 0.0) {
                (x, fx) = line_minimise(&mut f, &x, fx, &xit, o);
                dirs[ibig] = dirs[N - 1];
                dirs[N - 1] = xit;
            }
        }
    }
    PowellResult { x, fx, iterations, evaluations: f.n, trace }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A function flat in `p[1]` but for rounding noise: the minimiser
    /// finds `p[0]` and leaves `p[1]` where it started.
    #[test]
    fn a_flat_direction_is_not_followed() {
        let o = PowellOptions { ftol: 1e-7, xtol: 0.01, max_iterations: 50, max_step: 8.0 };
        let r = minimise(
            |p: &[f64; 2]| {
                let noise = f64::EPSILON * (p[1] * 12.9898).sin();
                (p[0] - 1.0).powi(2) + 3.5 * (1.0 + noise)
            },
            [0.0, 0.0],
            [1.0, 1.0],
            &o,
        );
        assert!((r.x[0] - 1.0).abs() < 0.01 && r.x[1] == 0.0, "{r:?}");
    }

    #[test]
    fn finds_the_minimum_of_a_rotated_valley() {
        let o = PowellOptions { ftol: 1e-12, xtol: 1e-7, max_iterations: 200, max_step: 100.0 };
        let r = minimise(
            |p: &[f64; 3]| {
                let (u, v) = (p[0] + p[1] - 3.0, p[0] - p[1] + 1.0);
                10.0 * u * u + 0.1 * v * v + (p[2] - 0.5).powi(2) + 2.0
            },
            [0.0; 3],
            [1.0; 3],
            &o,
        );
        assert!((r.x[0] - 1.0).abs() < 1e-4 && (r.x[1] - 2.0).abs() < 1e-4 && (r.x[2] - 0.5).abs() < 1e-4, "{r:?}");
        assert!(r.trace.windows(2).all(|w| w[1] <= w[0]));
    }
}
