//! A labelled phantom rendered in two "modalities" with a known rigid
//! transform between them: the test pairs of the registration, with no
//! download.
//!
//! Seven labels (background, a body and five asymmetric inclusions, so no
//! rotation or flip maps the phantom onto itself). The fixed image gives
//! label `ℓ` intensity `A[ℓ]`, the moving image `B[ℓ]`, a non-monotone,
//! mostly inverted mapping (a bright structure in one is dark in the other):
//! only a statistical dependence such as mutual information relates them.
//! The moving image also gets a multiplicative bias field, both get
//! Gaussian noise, and everything is supersampled 3 × 3 so edges are
//! partial-volume mixtures.

use super::gray::Gray;
use super::gray3::Gray3;
use super::rigid::{Rigid2, centre};
use super::rigid3::Rigid3;
use crate::lines::LineRng;

/// Intensity of each label in the fixed "modality".
pub const MODALITY_A: [f32; 7] = [0.0, 0.5, 0.85, 0.3, 1.0, 0.65, 0.15];
/// Intensity of each label in the moving "modality" (non-monotone in `A`).
pub const MODALITY_B: [f32; 7] = [0.9, 0.35, 0.1, 0.75, 0.55, 0.2, 0.6];

/// `(centre u, centre v, radius u, radius v, angle°)` in coordinates
/// normalised to `[−1, 1]` across the image; later ellipses cover earlier.
const ELLIPSES: [(f64, f64, f64, f64, f64); 6] = [
    (0.0, 0.0, 0.8, 0.7, 0.0),
    (-0.3, -0.2, 0.25, 0.35, 20.0),
    (0.35, 0.1, 0.2, 0.15, 0.0),
    (0.0, 0.45, 0.4, 0.1, 0.0),
    (0.1, -0.45, 0.12, 0.12, 0.0),
    (-0.35, 0.35, 0.1, 0.18, -30.0),
];

/// The phantom's label at continuous pixel coordinates of a `w × h` image.
#[must_use]
pub fn label_at(w: usize, h: usize, x: f64, y: f64) -> usize {
    let (cx, cy) = centre(w, h);
    let (u, v) = ((x - cx) / (w as f64 / 2.0), (y - cy) / (h as f64 / 2.0));
    let mut label = 0;
    for (k, &(eu, ev, ru, rv, a)) in ELLIPSES.iter().enumerate() {
        let (s, c) = a.to_radians().sin_cos();
        let (du, dv) = (u - eu, v - ev);
        let (p, q) = (c * du + s * dv, -s * du + c * dv);
        if (p / ru).powi(2) + (q / rv).powi(2) <= 1.0 {
            label = k + 1;
        }
    }
    label
}

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhantomOptions {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The true transform: fixed points to moving points.
    pub truth: Rigid2,
    /// Standard deviation of the Gaussian noise, intensity units (`[0, 1]`).
    pub noise: f64,
    /// Strength of the moving image's bias field: a factor
    /// `1 + b·(0.6u + 0.4v − 0.3uv)` over normalised coordinates `u, v`.
    pub bias: f64,
    /// Seed of the noise; the same seed gives the same images.
    pub seed: u64,
}

/// Renders the pair `(fixed, moving)` with `moving(T(x)) ≈ B[label(x)]`
/// where `fixed(x) ≈ A[label(x)]`; samples clamped to `[0, 1]`.
#[must_use]
pub fn render(o: &PhantomOptions) -> (Gray, Gray) {
    let (w, h) = (o.width, o.height);
    let inv = o.truth.inverse();
    let c = centre(w, h);
    let (mut fixed, mut moving) = (Gray::new(w, h), Gray::new(w, h));
    const SS: usize = 3;
    for y in 0..h {
        for x in 0..w {
            let (mut a, mut b) = (0.0f32, 0.0f32);
            for j in 0..SS {
                for i in 0..SS {
                    let px = x as f64 + (i as f64 + 0.5) / SS as f64 - 0.5;
                    let py = y as f64 + (j as f64 + 0.5) / SS as f64 - 0.5;
                    a += MODALITY_A[label_at(w, h, px, py)];
                    let (qx, qy) = inv.apply(c, px, py);
                    b += MODALITY_B[label_at(w, h, qx, qy)];
                }
            }
            let n = (SS * SS) as f32;
            let k = y * w + x;
            let (u, v) = ((x as f64 - c.0) / (w as f64 / 2.0), (y as f64 - c.1) / (h as f64 / 2.0));
            let field = 1.0 + o.bias * (0.6 * u + 0.4 * v - 0.3 * u * v);
            let rng = LineRng::new(o.seed, k as u64);
            let (na, nb) = (gauss(&rng, 0) * o.noise, gauss(&rng, 2) * o.noise);
            fixed.data[k] = (f64::from(a / n) + na).clamp(0.0, 1.0) as f32;
            moving.data[k] = (f64::from(b / n) * field + nb).clamp(0.0, 1.0) as f32;
        }
    }
    (fixed, moving)
}

/// The 3D phantom: `(centre u v w, radii u v w, angle about w°, angle about
/// u°)` in coordinates normalised to `[−1, 1]` across the volume; later
/// ellipsoids cover earlier. The inclusions sit at different heights and
/// tilts, so no rotation or flip maps the phantom onto itself.
const ELLIPSOIDS: [([f64; 3], [f64; 3], f64, f64); 6] = [
    ([0.0, 0.0, 0.0], [0.8, 0.7, 0.75], 0.0, 0.0),
    ([-0.3, -0.2, 0.1], [0.25, 0.35, 0.3], 20.0, 0.0),
    ([0.35, 0.1, -0.2], [0.2, 0.15, 0.25], 0.0, 30.0),
    ([0.0, 0.45, 0.0], [0.4, 0.1, 0.2], 0.0, 0.0),
    ([0.1, -0.45, 0.3], [0.12, 0.12, 0.12], 0.0, 0.0),
    ([-0.35, 0.35, -0.35], [0.1, 0.18, 0.14], -30.0, 15.0),
];

/// The 3D phantom's label at physical point `p` of a volume of `dims`
/// voxels of `spacing` (voxel `i` at `i·spacing`).
#[must_use]
pub fn label_at3(dims: [usize; 3], spacing: [f64; 3], p: [f64; 3]) -> usize {
    let u: [f64; 3] = core::array::from_fn(|a| {
        let c = (dims[a] as f64 - 1.0) / 2.0 * spacing[a];
        (p[a] - c) / (dims[a] as f64 * spacing[a] / 2.0)
    });
    let mut label = 0;
    for (k, &(e, r, about_w, about_u)) in ELLIPSOIDS.iter().enumerate() {
        let d = [u[0] - e[0], u[1] - e[1], u[2] - e[2]];
        let (s, c) = about_w.to_radians().sin_cos();
        let (a, b) = (c * d[0] + s * d[1], -s * d[0] + c * d[1]);
        let (s, c) = about_u.to_radians().sin_cos();
        let (bb, w) = (c * b + s * d[2], -s * b + c * d[2]);
        if (a / r[0]).powi(2) + (bb / r[1]).powi(2) + (w / r[2]).powi(2) <= 1.0 {
            label = k + 1;
        }
    }
    label
}

/// What to render in 3D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phantom3Options {
    /// Voxels along `x`, `y`, `z`.
    pub dims: [usize; 3],
    /// Voxel edge lengths (physical units).
    pub spacing: [f64; 3],
    /// The true transform: fixed points to moving points (physical units).
    pub truth: Rigid3,
    /// Standard deviation of the Gaussian noise, intensity units (`[0, 1]`).
    pub noise: f64,
    /// Strength of the moving volume's bias field: a factor
    /// `1 + b·(0.6u + 0.4v − 0.3uv + 0.2w)` over normalised coordinates.
    pub bias: f64,
    /// Seed of the noise; the same seed gives the same volumes.
    pub seed: u64,
}

/// Renders the pair `(fixed, moving)` of volumes, as [`render`] does images:
/// `fixed(p) ≈ A[label(p)]`, `moving(T(p)) ≈ B[label(p)]`, 2 × 2 × 2
/// supersampling, the moving volume times the bias field, both noisy;
/// samples clamped to `[0, 1]`.
#[must_use]
pub fn render3(o: &Phantom3Options) -> (Gray3, Gray3) {
    const SS: usize = 2;
    let (d, sp) = (o.dims, o.spacing);
    let (mut fixed, mut moving) = (Gray3::new(d, sp), Gray3::new(d, sp));
    let c = fixed.centre();
    let n = (SS * SS * SS) as f32;
    let mut k = 0;
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                let (mut a, mut b) = (0.0f32, 0.0f32);
                for s in 0..SS * SS * SS {
                    let sub = [s % SS, (s / SS) % SS, s / (SS * SS)];
                    let p: [f64; 3] = core::array::from_fn(|ax| {
                        let i = [x, y, z][ax] as f64 + (sub[ax] as f64 + 0.5) / SS as f64 - 0.5;
                        i * sp[ax]
                    });
                    a += MODALITY_A[label_at3(d, sp, p)];
                    b += MODALITY_B[label_at3(d, sp, o.truth.apply_inverse(c, p))];
                }
                let u: [f64; 3] =
                    core::array::from_fn(|ax| ([x, y, z][ax] as f64 * sp[ax] - c[ax]) / (d[ax] as f64 * sp[ax] / 2.0));
                let field = 1.0 + o.bias * (0.6 * u[0] + 0.4 * u[1] - 0.3 * u[0] * u[1] + 0.2 * u[2]);
                let rng = LineRng::new(o.seed, k as u64);
                let (na, nb) = (gauss(&rng, 0) * o.noise, gauss(&rng, 2) * o.noise);
                fixed.data[k] = (f64::from(a / n) + na).clamp(0.0, 1.0) as f32;
                moving.data[k] = (f64::from(b / n) * field + nb).clamp(0.0, 1.0) as f32;
                k += 1;
            }
        }
    }
    (fixed, moving)
}

/// A standard normal from draws `k, k + 1` (Box–Muller).
fn gauss(rng: &LineRng, k: u32) -> f64 {
    let (u, v) = (rng.uniform(k), rng.uniform(k + 1));
    (-2.0 * u.ln()).sqrt() * (core::f64::consts::TAU * v).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_and_transformed() {
        let o = PhantomOptions {
            width: 48,
            height: 40,
            truth: Rigid2 { angle_deg: 0.0, tx: 0.0, ty: 0.0 },
            noise: 0.0,
            bias: 0.0,
            seed: 1,
        };
        let (f, m) = render(&o);
        // Identity, no noise: the moving image is the B-mapping of the fixed labels.
        let mut inside = 0;
        for y in 0..40 {
            for x in 0..48 {
                let (px, py) = (x as f64, y as f64);
                let l = label_at(48, 40, px, py);
                let corners = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)];
                if corners.iter().all(|(dx, dy)| label_at(48, 40, px + dx, py + dy) == l) {
                    inside += 1;
                    assert!((f.data[y * 48 + x] - MODALITY_A[l]).abs() < 1e-6);
                    assert!((m.data[y * 48 + x] - MODALITY_B[l]).abs() < 1e-6);
                }
            }
        }
        assert!(inside > 48 * 40 / 2);
        let noisy = PhantomOptions { noise: 0.05, ..o };
        assert_eq!(render(&noisy), render(&noisy));
        assert_ne!(render(&noisy).0, render(&PhantomOptions { seed: 2, ..noisy }).0);
    }

    /// At the identity without noise or bias, interior voxels carry their
    /// label's two intensities; the same seed gives the same volumes.
    #[test]
    fn seeded_and_labelled_in_3d() {
        let o = Phantom3Options {
            dims: [20, 18, 16],
            spacing: [1.0, 1.0, 1.5],
            truth: Rigid3::default(),
            noise: 0.0,
            bias: 0.0,
            seed: 1,
        };
        let (f, m) = render3(&o);
        let mut inside = 0;
        for (k, (a, b)) in f.data.iter().zip(&m.data).enumerate() {
            let (x, y, z) = (k % 20, (k / 20) % 18, k / 360);
            let p = [x as f64, y as f64, z as f64 * 1.5];
            let l = label_at3(o.dims, o.spacing, p);
            let mut corners = (0..8).map(|c: usize| {
                let q: [f64; 3] = core::array::from_fn(|a| {
                    let side = if (c >> a) & 1 == 1 { 0.5 } else { -0.5 };
                    p[a] + side * o.spacing[a]
                });
                label_at3(o.dims, o.spacing, q)
            });
            if corners.all(|v| v == l) {
                inside += 1;
                assert!((a - MODALITY_A[l]).abs() < 1e-6 && (b - MODALITY_B[l]).abs() < 1e-6);
            }
        }
        assert!(inside > f.data.len() / 2);
        assert!((1..=6).all(|l| f.data.iter().any(|v| (v - MODALITY_A[l]).abs() < 1e-6)));
        let noisy = Phantom3Options { noise: 0.05, ..o };
        assert_eq!(render3(&noisy), render3(&noisy));
        assert_ne!(render3(&noisy).0, render3(&Phantom3Options { seed: 2, ..noisy }).0);
    }
}
