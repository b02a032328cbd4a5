//! Time-varying volumes (Part VI §2.2 after Bordoloi and Shen 2005 and Ji
//! and Shen 2006): a time series is a list of volumes on one grid, every
//! frame cast with the scalar normalised by the series' common range
//! ([`common_range`]), so one transfer function means the same values in
//! every frame.
//!
//! The built-in series needs no download:
//! * `hydrogen-beat[:N[,T]]`: the hydrogen atom in the superposition
//!   `ψ(t) = (ψ_100 e^{−iE_1 t} + ψ_211 e^{−iE_2 t})/√2` (atomic units,
//!   `E_n = −1/(2n²)`), whose density `|ψ(t)|² = (ψ_100² + |ψ_211|² +
//!   2 ψ_100 |ψ_211| cos(φ − ΔE t))/2` is a lopsided cloud turning about the
//!   z axis once per beat period `2π/ΔE` (`ΔE = 3/8` hartree). `T` frames
//!   (default 8) at `t_k = k/T` of one period on `N³` voxels (default 32),
//!   stored as `√(ρ/ρ_max)` with `ρ_max` over the whole series. Frame `k`
//!   is frame 0 turned by `2πk/T` about z, which the tests use.

use glam::DVec3;

use super::builtin::{SIZES, field, laguerre, legendre};
use super::{Volume, VolumeError};

/// The built-in series' syntax and description.
pub const SERIES_BUILT_IN: (&str, &str) = (
    "hydrogen-beat[:N[,T]]",
    "hydrogen (1s + 2p_+1)/sqrt 2: the density turns about z once in T frames (default 32, 8)",
);

/// Most frames in a series.
pub const MAX_FRAMES: usize = 256;

/// Whether `spec` names the built-in series.
#[must_use]
pub fn is_series_built_in(spec: &str) -> bool {
    spec.split(':').next() == Some("hydrogen-beat")
}

/// The built-in series from its specification, if its values (4 bytes a
/// voxel and frame) fit in `max_bytes`.
///
/// # Errors
/// Bad arguments or too many bytes, one line, before anything is allocated.
pub fn series_built_in(spec: &str, max_bytes: u64) -> Result<Vec<Volume>, VolumeError> {
    let args = spec.split_once(':').map(|(_, a)| a);
    let nums: Vec<i64> = match args {
        None => Vec::new(),
        Some(a) => a
            .split(',')
            .map(|s| s.trim().parse().map_err(|_| VolumeError::new(format!("hydrogen-beat: {s:?} is not an integer"))))
            .collect::<Result<_, _>>()?,
    };
    let (n, t) = match nums.as_slice() {
        [] => (32, 8),
        [n] => (*n, 8),
        [n, t] => (*n, *t),
        _ => return Err(VolumeError::new("hydrogen-beat: give N or N,T")),
    };
    if n < SIZES.0 as i64 || n > SIZES.1 as i64 {
        return Err(VolumeError::new(format!("hydrogen-beat: N = {n} must be in {}..={}", SIZES.0, SIZES.1)));
    }
    if t < 2 || t > MAX_FRAMES as i64 {
        return Err(VolumeError::new(format!("hydrogen-beat: T = {t} frames must be in 2..={MAX_FRAMES}")));
    }
    let bytes = (n as u64).pow(3) * t as u64 * 4;
    if bytes > max_bytes {
        return Err(VolumeError::new(format!(
            "hydrogen-beat:{n},{t}: the frames alone need {:.1} GiB (limit {:.1} GiB): fewer frames or voxels",
            bytes as f64 / f64::from(1u32 << 30),
            max_bytes as f64 / f64::from(1u32 << 30)
        )));
    }
    Ok(hydrogen_beat(n as usize, t as usize))
}

/// Factorial as a real.
fn factorial(n: u32) -> f64 {
    (1..=n).map(f64::from).product()
}

/// The normalised orbital's real amplitude `R_nl(r) N_lm P_l^m(cos θ)`
/// (without `e^{imφ}` and the Condon–Shortley sign, a constant phase) at
/// `p` in Bohr radii: `R_nl = √((2/n)³ (n−l−1)!/(2n (n+l)!)) e^{−ρ/2} ρ^l
/// L_{n−l−1}^{2l+1}(ρ)`, `ρ = 2r/n`, `N_lm = √((2l+1)/(4π) (l−m)!/(l+m)!)`.
pub(super) fn amplitude(n: u32, l: u32, m: u32, p: DVec3) -> f64 {
    let r = p.length();
    let rho = 2.0 * r / f64::from(n);
    let nf = f64::from(n);
    let radial_norm = ((2.0 / nf).powi(3) * factorial(n - l - 1) / (2.0 * nf * factorial(n + l))).sqrt();
    let radial = radial_norm * (-rho / 2.0).exp() * rho.powi(l as i32) * laguerre(n - l - 1, f64::from(2 * l + 1), rho);
    let angular_norm =
        (f64::from(2 * l + 1) / (4.0 * std::f64::consts::PI) * factorial(l - m) / factorial(l + m)).sqrt();
    let ct = if r > 0.0 { p.z / r } else { 1.0 };
    radial * angular_norm * legendre(l, m, ct)
}

/// `|ψ(t)|²` of the beat state at `p` (Bohr radii), `t` in atomic units.
fn beat_density(p: DVec3, t: f64) -> f64 {
    let (a, b) = (amplitude(1, 0, 0, p), amplitude(2, 1, 1, p));
    let phi = p.y.atan2(p.x);
    (a * a + b * b + 2.0 * a * b * (phi - BEAT_ENERGY * t).cos()) / 2.0
}

/// `ΔE = E_2 − E_1 = −1/8 + 1/2` hartree.
const BEAT_ENERGY: f64 = 0.375;

/// The `frames` of one beat period on `size³` voxels (see the module docs).
fn hydrogen_beat(size: usize, frames: usize) -> Vec<Volume> {
    // The grid of the hydrogen built-in for n = 2: 1.5 n² + 3n + 2 Bohr radii.
    let half = 14.0;
    let period = 2.0 * std::f64::consts::PI / BEAT_ENERGY;
    let mut out: Vec<Volume> = (0..frames)
        .map(|k| {
            let t = k as f64 / frames as f64 * period;
            field(&format!("hydrogen-beat:{size},{frames}#{k}"), size, |p| beat_density(p * half, t))
        })
        .collect();
    let max = out.iter().flat_map(|v| v.data.iter().copied()).fold(0.0f32, f32::max);
    if max > 0.0 {
        for v in &mut out {
            v.data.iter_mut().for_each(|x| *x = (x.max(0.0) / max).sqrt());
        }
    }
    out
}

/// Checks that every frame has the first one's grid (dims and spacing).
///
/// # Errors
/// The first frame that differs, one line naming both.
pub fn check_frames(frames: &[Volume]) -> Result<(), VolumeError> {
    let Some(first) = frames.first() else { return Err(VolumeError::new("a time series needs at least 2 frames")) };
    if frames.len() < 2 {
        return Err(VolumeError::new("a time series needs at least 2 frames"));
    }
    if frames.len() > MAX_FRAMES {
        return Err(VolumeError::new(format!("a time series has at most {MAX_FRAMES} frames, not {}", frames.len())));
    }
    for (k, f) in frames.iter().enumerate().skip(1) {
        if f.dims != first.dims || f.spacing != first.spacing {
            return Err(VolumeError::new(format!(
                "frame {k} ({}): grid {:?} spacing {:?}, but frame 0 ({}) has {:?} spacing {:?}",
                f.name, f.dims, f.spacing, first.name, first.dims, first.spacing
            )));
        }
    }
    Ok(())
}

/// The smallest and largest value over every frame.
#[must_use]
pub fn common_range(frames: &[Volume]) -> (f64, f64) {
    frames
        .iter()
        .map(Volume::range)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (lo, hi)| (a.min(f64::from(lo)), b.max(f64::from(hi))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbitals_are_normalised() {
        // ∫ |ψ|² dV by the midpoint rule on a 120³ grid over [−30, 30]³ Bohr radii.
        let (n, half) = (120, 30.0);
        let h = 2.0 * half / f64::from(n);
        for (nn, l, m) in [(1, 0, 0), (2, 1, 1), (2, 1, 0), (3, 2, 1)] {
            let mut sum = 0.0;
            for k in 0..n {
                for j in 0..n {
                    for i in 0..n {
                        let c = |i: u32| (f64::from(i) + 0.5) * h - half;
                        sum += amplitude(nn, l, m, DVec3::new(c(i), c(j), c(k))).powi(2) * h * h * h;
                    }
                }
            }
            assert!((sum - 1.0).abs() < 0.01, "{nn},{l},{m}: {sum}");
        }
    }

    #[test]
    fn the_beat_turns_about_z() {
        let f = series_built_in("hydrogen-beat:12,4", 1 << 30).unwrap();
        assert_eq!(f.len(), 4);
        check_frames(&f).unwrap();
        let n = 12;
        let at = |v: &Volume, i: usize, j: usize, k: usize| v.data[(k * n + j) * n + i];
        // Frame 2 (half a period) is frame 0 turned by π: (x, y) → (−x, −y);
        // frame 1 is frame 0 turned by π/2: (x, y) → (−y, x).
        for (i, j, k) in [(1, 2, 3), (7, 4, 6), (11, 0, 5), (5, 9, 2)] {
            let a = at(&f[0], i, j, k);
            assert!((a - at(&f[2], n - 1 - i, n - 1 - j, k)).abs() < 1e-6);
            assert!((a - at(&f[1], n - 1 - j, i, k)).abs() < 1e-6);
        }
        // Not static: the cloud moves.
        assert!(f[0].data.iter().zip(&f[2].data).any(|(a, b)| (a - b).abs() > 0.1));
        let (lo, hi) = common_range(&f);
        assert!(lo >= 0.0 && (hi - 1.0).abs() < 1e-6);
        assert!(series_built_in("hydrogen-beat:12,1", 1 << 30).is_err());
        assert!(series_built_in("hydrogen-beat:2", 1 << 30).is_err());
        assert!(series_built_in("hydrogen-beat:x", 1 << 30).is_err());
        assert!(series_built_in("hydrogen-beat:64,2", 64 * 64 * 64 * 8 - 1).unwrap_err().0.contains("frames alone"));
        let mut g = f.clone();
        g[3] = series_built_in("hydrogen-beat:10,2", 1 << 30).unwrap().remove(0);
        assert!(check_frames(&g).unwrap_err().0.contains("frame 3"));
        assert!(check_frames(&g[..1]).is_err());
    }
}
