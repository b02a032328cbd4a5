//! The two other routes of `itgfx volume`: the object channel `V → O` of a
//! labelled volume (Part VI §3.1) and the iso-surface handed to the
//! polygonal viewpoint channel (Part VI §2.1).

use glam::DVec3;
use itgfx_backends::scene::Scene;
use itgfx_backends::tracer::Prepared;
use itgfx_backends::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointMeasures, ViewpointWeights};
use itgfx_backends::volume::Volume;
use itgfx_backends::volume::iso::iso_surface;
use itgfx_backends::volume::objects::{object_channel, object_channel_fuzzy};
use itgfx_backends::{BackendChoice, open};

use crate::progress::Progress;
use crate::{CliError, core_err};

/// The object channel's measures (Part VI §3.1).
pub(super) struct ObjectMeasures {
    pub(super) measures: ViewpointMeasures,
    pub(super) p_o: Vec<f64>,
    /// `I(o;V)` per object.
    pub(super) information: Vec<f64>,
    /// Per object, the viewpoint with the largest `p(v|o) ∝ p(v) p(o|v)`: the one
    /// that sees most of it relative to the rest.
    pub(super) characteristic: Vec<Option<usize>>,
}

pub(super) fn object_measures(
    ch: &ViewpointChannel,
    volume: &Volume,
    labels: &[u8],
    names: &[String],
    weights: ViewpointWeights,
    base: itgfx_core::Base,
) -> Result<ObjectMeasures, CliError> {
    let err = |e| core_err("object channel", e);
    // Fuzzy membership p(o|z) when the volume has one, else the crisp labels.
    let och = match &volume.membership {
        Some(m) => object_channel_fuzzy(ch, m, names.len()),
        None => object_channel(ch, labels, names.len()),
    };
    let an = ViewpointAnalysis::new(&och, weights, false).map_err(err)?;
    let measures = an.measures(&vec![1.0; names.len()], base).map_err(err)?;
    let information = an.polygonal_information(base).map_err(err)?;
    let mut best = vec![(0.0, None); names.len()];
    for (x, &v) in an.seen.iter().enumerate() {
        let (cols, p) = an.row(x);
        for (&o, &q) in cols.iter().zip(p) {
            let w = an.p_v[x] * q;
            if w > best[o as usize].0 {
                best[o as usize] = (w, Some(v));
            }
        }
    }
    Ok(ObjectMeasures {
        measures,
        p_o: an.p_o.clone(),
        information,
        characteristic: best.into_iter().map(|b| b.1).collect(),
    })
}

/// The iso-surface route: the surface and its polygonal viewpoint measures.
pub(super) struct IsoRoute {
    pub(super) value: f64,
    pub(super) triangles: usize,
    pub(super) measures: ViewpointMeasures,
}

/// Most triangles of an iso-surface.
const MAX_ISO_TRIANGLES: usize = 4_000_000;

/// Extracts the iso-surface at `value`, one patch per triangle, and runs the
/// viewpoint channel of Part V on it (the ray grid of `rays²` rays per
/// viewpoint, as many as the voxel route casts).
pub(super) fn iso_route(
    v: &Volume,
    value: f64,
    dirs: &[DVec3],
    distance: f64,
    rays: u32,
    base: itgfx_core::Base,
) -> Result<IsoRoute, CliError> {
    let tris = iso_surface(v, value, MAX_ISO_TRIANGLES).ok_or_else(|| {
        CliError::usage(format!("--iso {value}: more than {MAX_ISO_TRIANGLES} triangles; a coarser volume"))
    })?;
    if tris.is_empty() {
        return Err(CliError::usage(format!("--iso {value}: {} has no surface at that value", v.name)));
    }
    let mut scene = Scene::named(&format!("{} iso {value}", v.name));
    for t in &tris {
        scene.add_triangles(String::new(), std::slice::from_ref(t), 0);
    }
    scene.validate().map_err(|e| CliError::usage(format!("--iso {value}: {e}")))?;
    let prepared = Prepared::new(&scene);
    let tracer = open(BackendChoice::Cpu, &prepared).map_err(|e| CliError::usage(e.to_string()))?;
    let mut progress = Progress::new();
    let ch = ViewpointChannel::build(&prepared, tracer.as_ref(), dirs, distance, rays, &mut |d, t| {
        progress.update(d, t);
    })
    .map_err(|e| CliError::usage(e.to_string()))?;
    let an = ViewpointAnalysis::new(&ch, ViewpointWeights::ProjectedArea, false)
        .map_err(|e| core_err("iso-surface channel", e))?;
    let measures = an.measures(&scene.areas(), base).map_err(|e| core_err("iso-surface channel", e))?;
    Ok(IsoRoute { value, triangles: tris.len(), measures })
}

/// Pearson correlation of two per-view series over the views finite in both.
pub(super) fn correlation(a: &[f64], b: &[f64]) -> Option<f64> {
    let pairs: Vec<(f64, f64)> =
        a.iter().zip(b).filter(|(x, y)| x.is_finite() && y.is_finite()).map(|(x, y)| (*x, *y)).collect();
    let n = pairs.len() as f64;
    if n < 3.0 {
        return None;
    }
    let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    (saa > 0.0 && sbb > 0.0).then(|| sab / (saa * sbb).sqrt())
}
