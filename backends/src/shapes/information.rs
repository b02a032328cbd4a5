//! The information descriptor: histograms of the viewpoint channel `V → O`
//! of Part V, evaluated on a fixed viewpoint sphere around the mesh in its
//! own [`Frame`] and built by the exact solid-angle estimator
//! ([`crate::viewpoint::solid_angle`]). Its blocks (docs/SHAPES.md says why):
//!
//! * `VMI`: the distribution over the sphere of the viewpoint mutual
//!   information `I(v;O)` (Part V eq. (7));
//! * `VKL`: of the viewpoint Kullback–Leibler distance to the polygons'
//!   relative areas (Part V eq. (3));
//! * `p(v)`: of the object's projected solid angle relative to its mean over
//!   the sphere, `N_v · p(v)` with `p(v) = a_t(v) / Σ a_t` (Part V §3);
//! * `JS`: the joint distribution of (angle between two viewpoints, their
//!   Jensen–Shannon dissimilarity, Part V §4 / Part II eq. (17)) over all
//!   pairs: how fast the view changes as the eye moves.
//!
//! Each is a distribution over viewpoints or pairs of viewpoints of a sphere
//! that does not turn with the object, so it is rotation invariant up to the
//! sphere's sampling; VMI, VKL and the dissimilarity are ratios of `p(o|v)`
//! to `p(o)` (or to `a_o / A_T`), which do not change when a polygon is
//! split into parts seen alike, so they are nearly remeshing invariant.

use glam::{DVec3, Vec3A};
use itgfx_core::Base;
use rayon::prelude::*;

use super::{Block, Frame, ShapeError, soft_histogram};
use crate::BackendChoice;
use crate::scene::Scene;
use crate::tracer::Prepared;
use crate::viewpoint::solid_angle::Refinement;
use crate::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights, icosphere};

/// Which blocks the descriptor keeps (a bit each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Blocks {
    /// The VMI distribution.
    pub vmi: bool,
    /// The VKL distribution.
    pub vkl: bool,
    /// The relative projected solid angle `N_v p(v)`.
    pub area: bool,
    /// The (angle, dissimilarity) joint distribution of viewpoint pairs.
    pub pairs: bool,
}

impl Blocks {
    /// Parses a comma-separated list of `vmi`, `vkl`, `area`, `js`.
    ///
    /// # Errors
    /// A message naming the unknown block, or an empty list.
    pub fn parse(s: &str) -> Result<Self, String> {
        let mut b = Self { vmi: false, vkl: false, area: false, pairs: false };
        for w in s.split(',') {
            match w.trim() {
                "vmi" => b.vmi = true,
                "vkl" => b.vkl = true,
                "area" => b.area = true,
                "js" => b.pairs = true,
                other => return Err(format!("unknown block {other:?} (expected vmi, vkl, area, js)")),
            }
        }
        Ok(b)
    }
}

/// How the information descriptor is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Viewpoint sphere: the subdivided icosahedron of this level (2: 162 views).
    pub level: u32,
    /// Viewpoint distance in frame radii (> 1).
    pub distance: f64,
    /// Relative VMI tolerance of the solid-angle estimator.
    pub tolerance: f64,
    /// Its largest subdivision of partly hidden triangles.
    pub max_subdivision: u32,
    /// Bins of each one-dimensional block.
    pub bins: usize,
    /// Angle bins of the `JS` block (its dissimilarity axis has `bins / 2`).
    pub angle_bins: usize,
    /// The blocks kept.
    pub blocks: Blocks,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            level: 2,
            distance: 3.0,
            tolerance: 0.05,
            max_subdivision: 8,
            bins: 32,
            angle_bins: 6,
            // Chosen on the tuning part of the retrieval set (docs/SHAPES.md).
            blocks: Blocks { vmi: false, vkl: false, area: false, pairs: true },
        }
    }
}

/// Upper ends of the histogram ranges (bits; the last bin takes what is above).
const VMI_MAX: f64 = 3.0;
const VKL_MAX: f64 = 3.0;
const AREA_MAX: f64 = 2.0;
const JS_MAX: f64 = 1.0;

/// `scene`'s triangles in `frame`, ready to trace (the viewpoint sphere is
/// placed around the frame's unit ball, not the bounding box).
#[must_use]
pub fn prepared_in(scene: &Scene, frame: &Frame) -> Prepared {
    let mut p = Prepared::new(scene);
    p.triangles = scene.triangles.iter().map(|t| [0, 1, 2].map(|k| Vec3A::from(frame.map(t[k]).as_vec3()))).collect();
    p.centre = frame.centre;
    p.scale = frame.radius;
    p
}

/// The information descriptor's blocks.
///
/// # Errors
/// [`ShapeError::Channel`] when tracing fails or nothing is seen.
pub fn blocks(scene: &Scene, frame: &Frame, s: &Settings, backend: BackendChoice) -> Result<Vec<Block>, ShapeError> {
    let err = |e: &dyn std::fmt::Display| ShapeError::Channel(e.to_string());
    let prepared = prepared_in(scene, frame);
    let tracer = crate::open(backend, &prepared).map_err(|e| err(&e))?;
    let dirs = icosphere(s.level);
    let refine = Refinement {
        distance: s.distance,
        tolerance: s.tolerance,
        max: s.max_subdivision,
        first: Refinement::default().first.min(s.max_subdivision),
        weights: ViewpointWeights::ProjectedArea,
        background: false,
    };
    let (ch, _) = ViewpointChannel::build_solid_angle(&prepared, tracer.as_ref(), &dirs, &refine, &mut |_, _| {})
        .map_err(|e| err(&e))?;
    if ch.is_blind() {
        return Err(ShapeError::Channel("no viewpoint sees the mesh".into()));
    }
    let positions: Vec<DVec3> = ch.positions.iter().map(|p| p.normalize()).collect();
    let an = ViewpointAnalysis::from_channel(ch, ViewpointWeights::ProjectedArea).map_err(|e| err(&e))?;
    let m = an.measures(&scene.areas(), Base::Bits).map_err(|e| err(&e))?;
    let rows = an.rows();
    let pick = |x: &[f64]| -> Vec<f64> { an.seen.iter().map(|&v| x[v]).collect() };
    let mut out = Vec::new();
    if s.blocks.vmi {
        out.push(Block { name: "VMI", p: soft_histogram(&pick(&m.mutual_information), None, 0.0, VMI_MAX, s.bins) });
    }
    if s.blocks.vkl {
        out.push(Block { name: "VKL", p: soft_histogram(&pick(&m.kullback_leibler), None, 0.0, VKL_MAX, s.bins) });
    }
    if s.blocks.area {
        // Viewpoints that see nothing count as 0 (weight 1/N_v each).
        let n = dirs.len() as f64;
        let rel: Vec<f64> = m.weight.iter().map(|w| w * n).collect();
        out.push(Block { name: "p(v)", p: soft_histogram(&rel, None, 0.0, AREA_MAX, s.bins) });
    }
    if s.blocks.pairs {
        let logs = an.entry_logs();
        let (na, nj) = (s.angle_bins.max(1), (s.bins / 2).max(2));
        let per_row: Vec<Result<Vec<(usize, f64)>, itgfx_core::Error>> = (0..rows)
            .into_par_iter()
            .map(|a| {
                (a + 1..rows)
                    .map(|b| {
                        let c = positions[an.seen[a]].dot(positions[an.seen[b]]).clamp(-1.0, 1.0);
                        // Equal-width bins of the angle.
                        let k = ((c.acos() / std::f64::consts::PI * na as f64) as usize).min(na - 1);
                        Ok((k, an.dissimilarity_logs(a, b, &logs, Base::Bits)?))
                    })
                    .collect()
            })
            .collect();
        let mut by_angle: Vec<Vec<f64>> = vec![Vec::new(); na];
        for r in per_row {
            for (k, js) in r.map_err(|e| err(&e))? {
                by_angle[k].push(js);
            }
        }
        let total: usize = by_angle.iter().map(Vec::len).sum();
        let mut p = Vec::with_capacity(na * nj);
        for v in &by_angle {
            let share = if total > 0 { v.len() as f64 / total as f64 } else { 0.0 };
            p.extend(soft_histogram(v, None, 0.0, JS_MAX, nj).into_iter().map(|x| x * share));
        }
        super::normalise(&mut p);
        out.push(Block { name: "JS", p });
    }
    Ok(out)
}
