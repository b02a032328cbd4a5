//! The 3D rigid transform of the registration (6 parameters).

/// A rigid transform of space mapping fixed points to moving points, in
/// physical coordinates (voxel `i` of an axis at `i·spacing`), about the
/// volume centre `c`: `T(p) = R(p − c) + c + t` with
/// `R = R_z(γ)·R_y(β)·R_x(α)` (rotate about `x` first, then `y`, then `z`;
/// right-handed, counter-clockwise seen from the axis' positive end). This is
/// ITK's `Euler3DTransform` with `ComputeZYX` on, angles in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Rigid3 {
    /// `(α, β, γ)`: rotations about `x`, `y`, `z`, degrees.
    pub angles_deg: [f64; 3],
    /// Translation, physical units.
    pub t: [f64; 3],
}

/// A 3 × 3 matrix, rows.
pub type Mat3 = [[f64; 3]; 3];

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    core::array::from_fn(|i| core::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// `M·v`.
#[inline]
#[must_use]
pub fn apply_mat(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    core::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

impl Rigid3 {
    /// The parameter vector `(t_x, t_y, t_z, α°, β°, γ°)` the optimiser moves.
    #[must_use]
    pub fn params(&self) -> [f64; 6] {
        [self.t[0], self.t[1], self.t[2], self.angles_deg[0], self.angles_deg[1], self.angles_deg[2]]
    }

    /// From a parameter vector (see [`Self::params`]).
    #[must_use]
    pub fn from_params(p: [f64; 6]) -> Self {
        Self { t: [p[0], p[1], p[2]], angles_deg: [p[3], p[4], p[5]] }
    }

    /// `R = R_z(γ)·R_y(β)·R_x(α)`.
    #[must_use]
    pub fn matrix(&self) -> Mat3 {
        let [(sa, ca), (sb, cb), (sg, cg)] = self.angles_deg.map(|a| a.to_radians().sin_cos());
        let rx = [[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]];
        let ry = [[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]];
        let rz = [[cg, -sg, 0.0], [sg, cg, 0.0], [0.0, 0.0, 1.0]];
        mul(&rz, &mul(&ry, &rx))
    }

    /// `T(p)` about the centre `c`.
    #[must_use]
    pub fn apply(&self, c: [f64; 3], p: [f64; 3]) -> [f64; 3] {
        let q = apply_mat(&self.matrix(), [p[0] - c[0], p[1] - c[1], p[2] - c[2]]);
        core::array::from_fn(|i| q[i] + c[i] + self.t[i])
    }

    /// `T⁻¹(q) = Rᵀ(q − c − t) + c`.
    #[must_use]
    pub fn apply_inverse(&self, c: [f64; 3], q: [f64; 3]) -> [f64; 3] {
        let r = self.matrix();
        let d: [f64; 3] = core::array::from_fn(|i| q[i] - c[i] - self.t[i]);
        core::array::from_fn(|i| r[0][i] * d[0] + r[1][i] * d[1] + r[2][i] * d[2] + c[i])
    }

    /// The angle of the rotation `R_self·R_otherᵀ` (degrees): how far apart
    /// the two rotations are, whatever the angle convention.
    #[must_use]
    pub fn rotation_distance_deg(&self, other: &Self) -> f64 {
        let (a, b) = (self.matrix(), other.matrix());
        let trace: f64 = (0..3).map(|i| (0..3).map(|k| a[i][k] * b[i][k]).sum::<f64>()).sum();
        ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// Largest displacement between `self` and `other` over the eight
    /// corners of a volume of `dims` voxels of `spacing` (physical units).
    #[must_use]
    pub fn corner_distance(&self, other: &Self, dims: [usize; 3], spacing: [f64; 3]) -> f64 {
        let c: [f64; 3] = core::array::from_fn(|a| (dims[a] as f64 - 1.0) / 2.0 * spacing[a]);
        (0..8)
            .map(|k| {
                let p: [f64; 3] = core::array::from_fn(|a| if (k >> a) & 1 == 1 { 2.0 * c[a] } else { 0.0 });
                let (u, v) = (self.apply(c, p), other.apply(c, p));
                (0..3).map(|a| (u[a] - v[a]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conventions_and_inverse() {
        // γ = 90° about z takes x to y.
        let t = Rigid3 { angles_deg: [0.0, 0.0, 90.0], t: [0.0; 3] };
        let q = t.apply([0.0; 3], [1.0, 0.0, 0.0]);
        assert!((q[0]).abs() < 1e-12 && (q[1] - 1.0).abs() < 1e-12);
        // x first: α = 90° takes y to z, then γ = 90° leaves z alone.
        let t = Rigid3 { angles_deg: [90.0, 0.0, 90.0], t: [0.0; 3] };
        let q = t.apply([0.0; 3], [0.0, 1.0, 0.0]);
        assert!((q[2] - 1.0).abs() < 1e-12, "{q:?}");
        let t = Rigid3 { angles_deg: [7.0, -12.0, 25.0], t: [1.5, -2.0, 3.25] };
        let c = [10.0, 20.0, 5.0];
        let p = t.apply_inverse(c, t.apply(c, [3.0, -4.0, 8.0]));
        assert!((p[0] - 3.0).abs() < 1e-12 && (p[1] + 4.0).abs() < 1e-12 && (p[2] - 8.0).abs() < 1e-12);
        let u = Rigid3 { angles_deg: [7.0, -12.0, 27.0], ..t };
        assert!((t.rotation_distance_deg(&u) - 2.0).abs() < 1e-6);
        assert!(t.rotation_distance_deg(&t) < 1e-6);
        assert!(t.corner_distance(&t, [9, 9, 9], [1.0; 3]) < 1e-12);
        assert_eq!(Rigid3::from_params(t.params()), t);
    }
}
