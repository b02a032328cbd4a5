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
use super::rigid::{Rigid2, centre};
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
}
