//! Built-in volumes that need no download.
//!
//! * `hydrogen[:n,l,m[,N]]`: the electron density `|ψ_nlm|²` of the hydrogen
//!   atom (atomic units), sampled on `N³` voxels (like the classic 128³
//!   "hydrogen" data set of Part VI Fig. 1). With complex orbitals the
//!   density is `R_nl(r)² P_l^|m|(cos θ)²`: symmetric about the z axis and
//!   under `z → −z`, which the tests use. The value stored is the amplitude
//!   `√(ρ/ρ_max)` in `[0, 1]`, which compresses the density's range as the
//!   classic 8-bit data set does.
//! * `phantom[:N[,W]]`: five labelled objects in `N³` voxels: an ellipsoidal
//!   shell (0.3), a central sphere (0.6), a sphere (0.9) and a cube (0.8)
//!   side by side, and a rod (1.0). With `W` (1..=4 voxels) the boundaries
//!   are fuzzy: `p(o|z)` is the share of `4³` points spread over a cube of
//!   side `W` voxels about the voxel's centre that lie in object `o` (later
//!   objects taking precedence, as in the crisp phantom), the rest being the
//!   background, and the value is the membership-weighted mean of the
//!   objects' values (a partial-volume phantom). `W = 0` is the crisp one.
//! * `cube[:N]`: a solid cube filling the middle half of each axis (value
//!   1, else 0): with a step transfer function, the volume counterpart of the
//!   polygonal cube of Part V.
//! * `sphere[:N]`: a radial Gaussian, value `exp(−8 r²)`: every direction is
//!   equivalent.
//! * `marschner-lobb[:N]`: the Marschner–Lobb test signal (Marschner and
//!   Lobb 1994, the usual test of volume reconstruction filters): a slow
//!   sine along z plus a radial ripple of frequency `f_M = 6`, `α = 0.25`,
//!   values in `[0, 1]`; sampled at 41³ by default as in the paper (near
//!   the Nyquist rate of its ripple, so resampling it shows aliasing).
//!
//! Every built-in spans [`REFERENCE_SIZE`] world units whatever `N`, so its
//! voxel spacing is `64/N`: opacity being per world unit, `hydrogen` at
//! `N = 32` and at `N = 64` are the same semi-transparent object sampled
//! twice as finely (the resolution test of VMI against VE needs that).

use glam::DVec3;

use super::objects::Membership;
use super::{Volume, VolumeError};

/// One built-in volume: its syntax and what it is.
#[derive(Clone, Copy, Debug)]
pub struct BuiltInVolume {
    /// How to write it.
    pub syntax: &'static str,
    /// What it is.
    pub description: &'static str,
}

/// The built-in volumes.
pub const BUILT_IN: &[BuiltInVolume] = &[
    BuiltInVolume {
        syntax: "hydrogen[:n,l,m[,N]]",
        description: "hydrogen orbital |psi_nlm|^2 on N^3 voxels (default 3,2,0,64), stored as sqrt(rho/max)",
    },
    BuiltInVolume {
        syntax: "phantom[:N[,W]]",
        description: "five labelled objects on N^3 voxels (default 64); W 1..=4: fuzzy boundaries W voxels wide",
    },
    BuiltInVolume { syntax: "cube[:N]", description: "a solid cube, the middle half of each axis (default 32)" },
    BuiltInVolume { syntax: "sphere[:N]", description: "a radial Gaussian exp(-8 r^2) (default 32)" },
    BuiltInVolume {
        syntax: "marschner-lobb[:N]",
        description: "the Marschner-Lobb test signal, f_M 6, alpha 0.25 (default N 41, as in the paper)",
    },
];

/// Extent of every built-in in world units: a voxel of a built-in at
/// `N = 64` is one unit wide.
pub const REFERENCE_SIZE: f64 = 64.0;

/// Smallest and largest `N` of a built-in.
pub const SIZES: (usize, usize) = (4, 512);

fn numbers(name: &str, args: Option<&str>) -> Result<Vec<i64>, VolumeError> {
    let Some(a) = args else { return Ok(Vec::new()) };
    a.split(',')
        .map(|s| s.trim().parse::<i64>().map_err(|_| VolumeError::new(format!("{name}: {s:?} is not an integer"))))
        .collect()
}

fn size(name: &str, n: i64) -> Result<usize, VolumeError> {
    if n < SIZES.0 as i64 || n > SIZES.1 as i64 {
        return Err(VolumeError::new(format!("{name}: N = {n} must be in {}..={}", SIZES.0, SIZES.1)));
    }
    Ok(n as usize)
}

/// Whether `spec` names a built-in volume (by its name before `:`).
#[must_use]
pub fn is_built_in(spec: &str) -> bool {
    let name = spec.split(':').next().unwrap_or("");
    BUILT_IN.iter().any(|b| b.syntax.split(['[', ':']).next() == Some(name))
}

/// Builds a built-in volume from its specification.
///
/// # Errors
/// An unknown name, bad arguments or sizes, one line.
pub fn built_in(spec: &str) -> Result<Volume, VolumeError> {
    let (name, args) = match spec.split_once(':') {
        Some((n, a)) => (n, Some(a)),
        None => (spec, None),
    };
    let a = numbers(name, args)?;
    match name {
        "hydrogen" => {
            let (n, l, m, size_n) = match a.as_slice() {
                [] => (3, 2, 0, 64),
                [n, l, m] => (*n, *l, *m, 64),
                [n, l, m, s] => (*n, *l, *m, *s),
                _ => return Err(VolumeError::new("hydrogen: give n,l,m or n,l,m,N")),
            };
            if !(1..=8).contains(&n) || l < 0 || l >= n || m.abs() > l {
                return Err(VolumeError::new(format!("hydrogen:{n},{l},{m}: need 1 <= n <= 8, 0 <= l < n, |m| <= l")));
            }
            Ok(hydrogen(n as u32, l as u32, m.unsigned_abs() as u32, size("hydrogen", size_n)?))
        }
        "phantom" => match a.as_slice() {
            [] => Ok(phantom(64, 0)),
            [s] => Ok(phantom(size(name, *s)?, 0)),
            [s, w] => {
                let s = size(name, *s)?;
                if !(0..=MAX_FUZZY_WIDTH).contains(w) {
                    return Err(VolumeError::new(format!("phantom: W = {w} must be in 0..={MAX_FUZZY_WIDTH} voxels")));
                }
                if *w > 0 && s > MAX_FUZZY_SIZE {
                    return Err(VolumeError::new(format!(
                        "phantom: a fuzzy phantom (W > 0) has N <= {MAX_FUZZY_SIZE} (64 membership samples a voxel)"
                    )));
                }
                Ok(phantom(s, *w as u32))
            }
            _ => Err(VolumeError::new("phantom: give N or N,W")),
        },
        "cube" | "sphere" | "marschner-lobb" => {
            let default = if name == "marschner-lobb" { 41 } else { 32 };
            let s = match a.as_slice() {
                [] => default,
                [s] => *s,
                _ => return Err(VolumeError::new(format!("{name}: give one size N"))),
            };
            let s = size(name, s)?;
            Ok(match name {
                "cube" => field(&format!("cube:{s}"), s, |p| {
                    if p.x.abs() < 0.5 && p.y.abs() < 0.5 && p.z.abs() < 0.5 { 1.0 } else { 0.0 }
                }),
                "marschner-lobb" => field(&format!("marschner-lobb:{s}"), s, marschner_lobb),
                _ => field(&format!("sphere:{s}"), s, |p| (-8.0 * p.length_squared()).exp()),
            })
        }
        _ => Err(VolumeError::new(format!(
            "{spec:?}: not a built-in volume ({}) nor a volume file",
            BUILT_IN.iter().map(|b| b.syntax).collect::<Vec<_>>().join(", ")
        ))),
    }
}

/// The Marschner–Lobb signal at `p` in `[-1, 1]³`:
/// `(1 − sin(π z / 2) + α (1 + cos(2π f_M cos(π r / 2)))) / (2 (1 + α))`,
/// `r = √(x² + y²)`, `f_M = 6`, `α = 1/4`.
fn marschner_lobb(p: DVec3) -> f64 {
    use std::f64::consts::PI;
    const F_M: f64 = 6.0;
    const ALPHA: f64 = 0.25;
    let r = (p.x * p.x + p.y * p.y).sqrt();
    let ripple = (2.0 * PI * F_M * (PI * r / 2.0).cos()).cos();
    (1.0 - (PI * p.z / 2.0).sin() + ALPHA * (1.0 + ripple)) / (2.0 * (1.0 + ALPHA))
}

/// A field over `[-1, 1]³` sampled at the centres of `n³` voxels.
pub(super) fn field(name: &str, n: usize, mut f: impl FnMut(DVec3) -> f64) -> Volume {
    let mut data = Vec::with_capacity(n * n * n);
    let c = |i: usize| (i as f64 + 0.5) / n as f64 * 2.0 - 1.0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                data.push(f(DVec3::new(c(i), c(j), c(k))) as f32);
            }
        }
    }
    // 64 world units across whatever the resolution: opacity is per world
    // unit (see `raycast`), so a built-in resampled keeps its optical depth.
    let h = REFERENCE_SIZE / n as f64;
    Volume {
        name: name.into(),
        dims: [n; 3],
        spacing: [h; 3],
        data,
        labels: None,
        label_names: Vec::new(),
        membership: None,
    }
}

/// Generalised Laguerre polynomial `L_k^(α)(x)` by its three-term recurrence.
pub(super) fn laguerre(k: u32, alpha: f64, x: f64) -> f64 {
    let (mut a, mut b) = (1.0, 1.0 + alpha - x);
    if k == 0 {
        return a;
    }
    for i in 1..k {
        let i = f64::from(i);
        let c = ((2.0 * i + 1.0 + alpha - x) * b - (i + alpha) * a) / (i + 1.0);
        a = b;
        b = c;
    }
    b
}

/// Associated Legendre function `P_l^m(x)` (`m ≥ 0`, up to sign).
pub(super) fn legendre(l: u32, m: u32, x: f64) -> f64 {
    let s = (1.0 - x * x).max(0.0).sqrt();
    let mut pmm = 1.0;
    for i in 0..m {
        pmm *= f64::from(2 * i + 1) * s;
    }
    if l == m {
        return pmm;
    }
    let mut pm1 = x * f64::from(2 * m + 1) * pmm;
    for ll in m + 2..=l {
        let p = (f64::from(2 * ll - 1) * x * pm1 - f64::from(ll + m - 1) * pmm) / f64::from(ll - m);
        pmm = pm1;
        pm1 = p;
    }
    pm1
}

/// `|ψ_nlm|²` (up to a constant) at `p` in Bohr radii.
fn density(n: u32, l: u32, m: u32, p: DVec3) -> f64 {
    let r = p.length();
    let rho = 2.0 * r / f64::from(n);
    let radial = (-rho / 2.0).exp() * rho.powi(l as i32) * laguerre(n - l - 1, f64::from(2 * l + 1), rho);
    let ct = if r > 0.0 { p.z / r } else { 1.0 };
    let angular = legendre(l, m, ct);
    (radial * angular).powi(2)
}

/// The hydrogen orbital `n, l, m` on `size³` voxels over a cube of half
/// width `1.5 n² + 3n + 2` Bohr radii (where the density has fallen to
/// about 10⁻³ of its peak or less).
fn hydrogen(n: u32, l: u32, m: u32, size: usize) -> Volume {
    let half = 1.5 * f64::from(n * n) + 3.0 * f64::from(n) + 2.0;
    let mut v = field(&format!("hydrogen:{n},{l},{m},{size}"), size, |p| density(n, l, m, p * half));
    let max = v.data.iter().copied().fold(0.0f32, f32::max);
    if max > 0.0 {
        v.data.iter_mut().for_each(|x| *x = (*x / max).sqrt());
    }
    v
}

/// The labelled phantom: (label name, value, inside test) per object, in
/// order of precedence (later objects overwrite earlier ones).
type Object = (&'static str, f32, fn(DVec3) -> bool);

const OBJECTS: [Object; 5] = [
    ("shell", 0.3, |p| {
        let e = |a: f64, b: f64, c: f64| (p.x / a).powi(2) + (p.y / b).powi(2) + (p.z / c).powi(2);
        e(0.9, 0.75, 0.6) <= 1.0 && e(0.8, 0.65, 0.5) > 1.0
    }),
    ("core", 0.6, |p| p.length() <= 0.3),
    ("left", 0.9, |p| (p - DVec3::new(-0.5, 0.15, 0.0)).length() <= 0.15),
    ("right", 0.8, |p| {
        let d = p - DVec3::new(0.5, 0.15, 0.0);
        d.x.abs() <= 0.12 && d.y.abs() <= 0.12 && d.z.abs() <= 0.12
    }),
    ("rod", 1.0, |p| ((p.x).powi(2) + (p.y + 0.45).powi(2)).sqrt() <= 0.07 && p.z.abs() <= 0.45),
];

/// Widest fuzzy boundary of the phantom, in voxels.
const MAX_FUZZY_WIDTH: i64 = 4;

/// Largest `N` of a fuzzy phantom (each voxel tests 64 points).
const MAX_FUZZY_SIZE: usize = 256;

/// The label (`0` = none) at `p`: the last object holding it.
fn label_at(p: DVec3) -> u8 {
    OBJECTS.iter().enumerate().rev().find(|(_, o)| (o.2)(p)).map_or(0, |(k, _)| k as u8 + 1)
}

/// The phantom on `n³` voxels; `width > 0` voxels makes its boundaries fuzzy.
fn phantom(n: usize, width: u32) -> Volume {
    let name = if width == 0 { format!("phantom:{n}") } else { format!("phantom:{n},{width}") };
    let mut labels = Vec::with_capacity(n * n * n);
    let mut m = Membership { starts: vec![0], objects: Vec::new(), weights: Vec::new() };
    // Sub-sample offsets in voxels: 4 per axis, evenly over [−W/2, W/2].
    const SUB: usize = 4;
    let offsets: Vec<f64> =
        (0..SUB).map(|i| (i as f64 + 0.5) / SUB as f64 * f64::from(width) - f64::from(width) / 2.0).collect();
    let voxel = 2.0 / n as f64;
    let value_of = |l: u8| if l == 0 { 0.0 } else { f64::from(OBJECTS[usize::from(l) - 1].1) };
    let mut v = field(&name, n, |p| {
        let centre = label_at(p);
        labels.push(centre);
        if width == 0 {
            return value_of(centre);
        }
        let mut count = [0u32; OBJECTS.len() + 1];
        for &dz in &offsets {
            for &dy in &offsets {
                for &dx in &offsets {
                    count[usize::from(label_at(p + DVec3::new(dx, dy, dz) * voxel))] += 1;
                }
            }
        }
        let total = (SUB * SUB * SUB) as f64;
        let mut value = 0.0;
        for (l, &c) in count.iter().enumerate().skip(1) {
            if c > 0 {
                m.objects.push(l as u8);
                m.weights.push(f64::from(c) / total);
                value += f64::from(c) / total * value_of(l as u8);
            }
        }
        m.starts.push(m.objects.len());
        value
    });
    v.labels = Some(labels);
    v.label_names = OBJECTS.iter().map(|o| o.0.to_string()).collect();
    if width > 0 {
        v.membership = Some(m);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hydrogen_ground_state_is_radial() {
        // 1s: ρ ∝ e^{-2r}.
        let a = density(1, 0, 0, DVec3::new(1.0, 0.0, 0.0));
        let b = density(1, 0, 0, DVec3::new(0.0, 0.0, 2.0));
        assert!((b / a - (-2.0f64).exp()).abs() < 1e-12);
        // 2p_z (n=2, l=1, m=0): node in the xy plane, ρ ∝ r² e^{-r} cos²θ.
        assert!(density(2, 1, 0, DVec3::new(1.0, 1.0, 0.0)).abs() < 1e-20);
        let (p, q) = (DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 2.0));
        let ratio = density(2, 1, 0, q) / density(2, 1, 0, p);
        assert!((ratio - 4.0 * (-1.0f64).exp()).abs() < 1e-12, "{ratio}");
        // 2s has a radial node at r = 2 (L_1^1(ρ) = 2 − ρ, ρ = r).
        assert!(density(2, 0, 0, DVec3::new(2.0, 0.0, 0.0)).abs() < 1e-20);
    }

    #[test]
    fn marschner_lobb_is_the_published_signal() {
        // On the z axis r = 0: cos(2π·6·1) = 1, so ρ = (1 − sin(πz/2) + 2α) / (2(1 + α)).
        assert!((marschner_lobb(DVec3::ZERO) - 1.5 / 2.5).abs() < 1e-15);
        assert!((marschner_lobb(DVec3::Z) - 0.5 / 2.5).abs() < 1e-15);
        assert!((marschner_lobb(-DVec3::Z) - 2.5 / 2.5).abs() < 1e-15);
        // Where cos(π r / 2) = 1/12 the ripple is cos(π) = −1: ρ = (1 − sin(πz/2)) / 2.5.
        let r = (1.0f64 / 12.0).acos() * 2.0 / std::f64::consts::PI;
        assert!((marschner_lobb(DVec3::new(r, 0.0, 0.0)) - 1.0 / 2.5).abs() < 1e-12);
        let v = built_in("marschner-lobb").unwrap();
        assert_eq!(v.dims, [41; 3]);
        let (lo, hi) = v.range();
        assert!(lo >= 0.0 && hi <= 1.0 && hi > 0.9 && lo < 0.1, "{lo} {hi}");
        // Symmetric about the z axis: x -> -x and x <-> y swap voxels exactly.
        let n = 41;
        let at = |i: usize, j: usize, k: usize| v.data[(k * n + j) * n + i];
        for (i, j, k) in [(3, 7, 11), (20, 5, 40), (0, 40, 17)] {
            assert_eq!(at(i, j, k), at(n - 1 - i, j, k));
            assert_eq!(at(i, j, k), at(j, i, k));
        }
        assert!(built_in("marschner-lobb:3").is_err());
        assert!(built_in("marschner-lobb:8,8").is_err());
    }

    #[test]
    fn specs() {
        let v = built_in("hydrogen:2,1,1,8").unwrap();
        assert_eq!(v.dims, [8; 3]);
        assert!((v.range().1 - 1.0).abs() < 1e-6);
        assert!(built_in("hydrogen:2,2,0").is_err());
        assert!(built_in("hydrogen:2,1,2").is_err());
        assert!(built_in("phantom:3").is_err());
        assert!(built_in("phantom:x").is_err());
        assert!(built_in("nothing").is_err());
        let p = built_in("phantom:16").unwrap();
        let labels = p.labels.as_ref().unwrap();
        for l in 1..=5u8 {
            assert!(labels.contains(&l), "label {l} missing at 16^3");
        }
        assert!(is_built_in("cube:8") && !is_built_in("x.raw"));
    }

    #[test]
    fn fuzzy_phantom_rows_sum_to_one_and_width_0_is_crisp() {
        let crisp = built_in("phantom:16").unwrap();
        assert_eq!(built_in("phantom:16,0").unwrap(), crisp);
        assert!(crisp.membership.is_none());
        let f = built_in("phantom:16,2").unwrap();
        let m = f.membership.as_ref().unwrap();
        assert_eq!(m.voxels(), 16 * 16 * 16);
        assert_eq!(f.labels, crisp.labels, "labels stay the centres' crisp labels");
        let (mut fuzzy, mut inside) = (0, 0);
        for z in 0..m.voxels() {
            let (l, w) = m.row(z);
            let sum: f64 = w.iter().sum();
            // Objects and the background share the voxel: p(o|z) sum to 1 with p(background|z).
            assert!(w.iter().all(|&x| x > 0.0 && x <= 1.0) && sum <= 1.0 + 1e-15, "{z}: {w:?}");
            assert!(l.windows(2).all(|p| p[0] < p[1]));
            fuzzy += usize::from(w.iter().any(|&x| x < 1.0));
            inside += usize::from(!l.is_empty());
            // The value is the membership-weighted mean of the objects' values.
            let value: f64 = l.iter().zip(w).map(|(&l, &w)| w * f64::from(OBJECTS[usize::from(l) - 1].1)).sum();
            assert!((f64::from(f.data[z]) - value).abs() < 1e-6);
        }
        assert!(fuzzy > 100 && inside > fuzzy, "{fuzzy} fuzzy voxels of {inside}");
        assert!(built_in("phantom:16,5").is_err());
        assert!(built_in("phantom:300,1").is_err());
        assert!(built_in("phantom:16,1,1").is_err());
    }
}
