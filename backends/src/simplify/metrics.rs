//! What a user checks after simplifying: renders of the original and the
//! simplified mesh from viewpoints the simplifier did not use (image RMSE
//! of the shading and of the silhouette), and the symmetric Hausdorff and
//! mean surface distances by sampling both surfaces.

use glam::DVec3;
use rayon::prelude::*;

use super::mesh::IndexedMesh;
use crate::backend::{BackendChoice, BackendError, open};
use crate::camera::Camera;
use crate::lines::Line;
use crate::tracer::Hit;

/// `n` directions on a Fibonacci spiral (golden-angle steps, `z` from
/// `1 − 1/n` to `−1 + 1/n`): none is a vertex of the subdivided icosahedra
/// the channel uses, so errors are measured from views the simplifier did
/// not optimise for.
#[must_use]
pub fn evaluation_directions(n: usize) -> Vec<DVec3> {
    crate::viewpoint::fibonacci_sphere(n)
}

/// A grey render: `|cos|` between the ray and the surface normal at the
/// first hit (either side, flat per triangle), 0 on the background.
#[derive(Clone, Debug, PartialEq)]
pub struct Render {
    /// Width and height.
    pub size: u32,
    /// Shading in `[0, 1]`, row-major from the top.
    pub shade: Vec<f32>,
    /// Whether each pixel sees the object.
    pub covered: Vec<bool>,
}

/// Renders `mesh` from `eye` (the mesh's normalised frame) looking at the origin.
///
/// # Errors
/// Backend errors.
pub fn render(
    mesh: &IndexedMesh,
    backend: BackendChoice,
    eyes: &[DVec3],
    size: u32,
) -> Result<Vec<Render>, BackendError> {
    let prepared = mesh.prepared();
    let tracer = open(backend, &prepared)?;
    eyes.iter()
        .map(|&eye| {
            let cam = Camera::framing_unit_sphere(eye);
            let reach = eye.length() + 2.0;
            let lines: Vec<Line> = (0..size)
                .flat_map(|y| (0..size).map(move |x| (x, y)))
                .map(|(x, y)| cam.ray(f64::from(x) + 0.5, f64::from(y) + 0.5, size, size, reach))
                .collect();
            let mut hits: Vec<Option<Hit>> = Vec::new();
            tracer.closest_hit(&lines, &mut hits)?;
            Ok(Render {
                size,
                shade: hits.iter().map(|h| h.map_or(0.0, |h| h.cos.abs())).collect(),
                covered: hits.iter().map(Option::is_some).collect(),
            })
        })
        .collect()
}

/// Root-mean-square differences between two sets of renders of the same views.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// RMSE of the shading over every pixel of every view (`[0, 1]` scale).
    pub shading: f64,
    /// RMSE of the silhouettes (coverage 0 or 1): the square root of the
    /// fraction of pixels covered in one render and not the other.
    pub silhouette: f64,
}

/// Image RMSE of `b` against `a` (same views, same sizes).
#[must_use]
pub fn image_error(a: &[Render], b: &[Render]) -> ImageError {
    let (mut s, mut c, mut n) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for i in 0..x.shade.len().min(y.shade.len()) {
            let d = f64::from(x.shade[i] - y.shade[i]);
            s += d * d;
            c += f64::from(u8::from(x.covered[i] != y.covered[i]));
            n += 1.0;
        }
    }
    let n = if n > 0.0 { n } else { 1.0 };
    ImageError { shading: (s / n).sqrt(), silhouette: (c / n).sqrt() }
}

/// Surface distances in the mesh's normalised frame (units of the
/// original's bounding-box half diagonal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceDistance {
    /// Symmetric Hausdorff distance `max(h(A,B), h(B,A))` over the samples.
    pub hausdorff: f64,
    /// Mean of the two one-sided mean distances.
    pub mean: f64,
    /// Points sampled on each surface.
    pub samples: usize,
}

/// A deterministic generator (SplitMix64) for the surface samples.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` points uniform by area on the mesh (seeded, so repeatable).
fn sample(mesh: &IndexedMesh, n: usize, seed: u64) -> Vec<DVec3> {
    let mut cdf = Vec::with_capacity(mesh.faces.len());
    let mut acc = 0.0;
    for f in 0..mesh.faces.len() {
        let [a, b, c] = mesh.corners(f);
        acc += 0.5 * (b - a).cross(c - a).length();
        cdf.push(acc);
    }
    let mut rng = SplitMix(seed);
    let mut pts: Vec<DVec3> = Vec::with_capacity(n + mesh.positions.len());
    // Every vertex in use is a sample too, so corners and tips are never missed.
    let mut used = vec![false; mesh.positions.len()];
    for t in &mesh.faces {
        for &v in t {
            used[v as usize] = true;
        }
    }
    pts.extend(mesh.positions.iter().zip(&used).filter(|(_, u)| **u).map(|(p, _)| *p));
    for _ in 0..n {
        let x = rng.next() * acc;
        let f = cdf.partition_point(|&c| c < x).min(cdf.len() - 1);
        let [a, b, c] = mesh.corners(f);
        let (mut r1, mut r2) = (rng.next(), rng.next());
        if r1 + r2 > 1.0 {
            r1 = 1.0 - r1;
            r2 = 1.0 - r2;
        }
        pts.push(a + (b - a) * r1 + (c - a) * r2);
    }
    pts
}

/// Closest point of triangle `abc` to `p` (Ericson, Real-Time Collision Detection §5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// A uniform grid of triangles for nearest-surface queries.
struct Grid {
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    starts: Vec<usize>,
    items: Vec<u32>,
}

impl Grid {
    fn new(mesh: &IndexedMesh) -> Self {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &mesh.faces {
            for &v in t {
                lo = lo.min(mesh.positions[v as usize]);
                hi = hi.max(mesh.positions[v as usize]);
            }
        }
        let ext = (hi - lo).max(DVec3::splat(1e-9));
        // About two triangles per cell.
        let cell =
            (ext.x * ext.y * ext.z / (mesh.faces.len() as f64 / 2.0).max(1.0)).cbrt().max(ext.max_element() / 256.0);
        let dims = [0, 1, 2].map(|k| ((ext[k] / cell).ceil() as usize).clamp(1, 256));
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let cell_of = |p: DVec3| [0, 1, 2].map(|k| (((p[k] - lo[k]) / cell) as usize).min(dims[k] - 1));
        let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        for (f, t) in mesh.faces.iter().enumerate() {
            let p = t.map(|v| mesh.positions[v as usize]);
            let (a, b) = (cell_of(p[0].min(p[1]).min(p[2])), cell_of(p[0].max(p[1]).max(p[2])));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        buckets[index([x, y, z])].push(f as u32);
                    }
                }
            }
        }
        let mut starts = vec![0];
        let mut items = Vec::new();
        for b in buckets {
            items.extend(b);
            starts.push(items.len());
        }
        Self { lo, cell, dims, starts, items }
    }

    /// Distance from `p` to the nearest triangle of `mesh`.
    fn distance(&self, mesh: &IndexedMesh, p: DVec3) -> f64 {
        let c = [0, 1, 2].map(|k| ((((p[k] - self.lo[k]) / self.cell).max(0.0)) as usize).min(self.dims[k] - 1));
        let mut best = f64::INFINITY;
        let reach = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=reach {
            let lo = c.map(|x| x.saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        // Only the shell at Chebyshev distance r.
                        let ring = [x, y, z].iter().zip(&c).map(|(&a, &b)| a.abs_diff(b)).max().unwrap_or(0);
                        if ring != r {
                            continue;
                        }
                        let i = (z * self.dims[1] + y) * self.dims[0] + x;
                        for &f in &self.items[self.starts[i]..self.starts[i + 1]] {
                            let [a, b, cc] = mesh.corners(f as usize);
                            best = best.min((closest_on_triangle(p, a, b, cc) - p).length());
                        }
                    }
                }
            }
            // Cells beyond ring r are at least r cells away.
            if best <= r as f64 * self.cell {
                break;
            }
        }
        best
    }
}

/// One-sided distances from `samples` to `mesh`: (max, mean).
fn one_sided(samples: &[DVec3], mesh: &IndexedMesh) -> (f64, f64) {
    let grid = Grid::new(mesh);
    let d: Vec<f64> = samples.par_iter().map(|&p| grid.distance(mesh, p)).collect();
    let max = d.iter().copied().fold(0.0, f64::max);
    (max, d.iter().sum::<f64>() / d.len().max(1) as f64)
}

/// Symmetric Hausdorff and mean distance between `a` and `b` from `n`
/// area-uniform samples on each (plus their vertices), seeded by `seed`.
#[must_use]
pub fn surface_distance(a: &IndexedMesh, b: &IndexedMesh, n: usize, seed: u64) -> SurfaceDistance {
    let (sa, sb) = (sample(a, n, seed), sample(b, n, seed ^ 0x5EED));
    let (ab_max, ab_mean) = one_sided(&sa, b);
    let (ba_max, ba_mean) = one_sided(&sb, a);
    SurfaceDistance { hausdorff: ab_max.max(ba_max), mean: 0.5 * (ab_mean + ba_mean), samples: n }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64) -> IndexedMesh {
        IndexedMesh {
            positions: vec![
                DVec3::new(0.0, 0.0, z),
                DVec3::new(1.0, 0.0, z),
                DVec3::new(1.0, 1.0, z),
                DVec3::new(0.0, 1.0, z),
            ],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn parallel_squares_are_their_gap_apart() {
        let d = surface_distance(&square(0.0), &square(0.25), 500, 7);
        assert!((d.hausdorff - 0.25).abs() < 1e-12, "{d:?}");
        assert!((d.mean - 0.25).abs() < 1e-12, "{d:?}");
        let same = surface_distance(&square(0.0), &square(0.0), 500, 7);
        assert!(same.hausdorff < 1e-12);
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(closest_on_triangle(DVec3::new(-1.0, -1.0, 0.0), a, b, c), a);
        assert_eq!(closest_on_triangle(DVec3::new(0.25, 0.25, 3.0), a, b, c), DVec3::new(0.25, 0.25, 0.0));
        assert_eq!(closest_on_triangle(DVec3::new(0.5, -2.0, 0.0), a, b, c), DVec3::new(0.5, 0.0, 0.0));
    }

    #[test]
    fn fibonacci_directions_are_unit_and_not_icosphere_vertices() {
        let d = evaluation_directions(24);
        let ico = crate::viewpoint::icosphere(1);
        for x in &d {
            assert!((x.length() - 1.0).abs() < 1e-12);
            assert!(ico.iter().all(|y| (*x - *y).length() > 1e-3));
        }
    }
}
