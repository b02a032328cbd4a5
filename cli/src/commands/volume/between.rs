//! `--path-between A,B`: a smooth camera path from object A's
//! characteristic view to object B's (Part VI §3.1 after [VFSG06], whose
//! guided navigation changes the viewpoint smoothly to the characteristic
//! view of the object in focus). The path is the great circle between the
//! two directions (`volume::paths::geodesic`), `K` steps equally spaced in
//! angle; each step is cast like a viewpoint of the sphere and measured
//! against the sphere's marginals: VMI `D_KL(p(Z|v) ‖ p(Z))` and object VMI
//! `D_KL(p(O|v) ‖ p(O))` (Part V eq. (7), through the core's
//! `SparseChannel`), VE `H(Z|v)` (eq. (2)), and the shares `p(A|v)`,
//! `p(B|v)` of the two objects in what the step sees.

use glam::DVec3;
use itgfx_backends::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointWeights};
use itgfx_backends::volume::Volume;
use itgfx_backends::volume::cast::VolumeCaster;
use itgfx_backends::volume::objects::{object_channel, object_channel_fuzzy};
use itgfx_backends::volume::paths::{geodesic, turn};
use itgfx_backends::volume::{VolumeChannelOptions, volume_channel};

use super::routes::ObjectMeasures;
use crate::progress::Progress;
use crate::report::Report;
use crate::{CliError, core_err};

/// The picture of the path's renders under `--out`.
pub(super) const PICTURE: &str = "path-between.png";

/// The two objects (0-based) and the number of steps.
pub(super) struct Between {
    pub(super) from: usize,
    pub(super) to: usize,
    pub(super) steps: usize,
}

/// Resolves `A,B` to two different labels of `v` (names or numbers
/// `1..`), before any work.
pub(super) fn labels(v: &Volume, spec: &str, steps: usize) -> Result<Between, CliError> {
    if v.labels.is_none() {
        return Err(CliError::usage(format!("--path-between {spec:?}: {} has no labelled objects", v.name)));
    }
    let Some((a, b)) = spec.split_once(',') else {
        return Err(CliError::usage(format!("--path-between {spec:?}: want two labels A,B")));
    };
    let find = |s: &str| {
        let s = s.trim();
        super::input::label(v, s).map(|k| k - 1).ok_or_else(|| {
            CliError::usage(format!(
                "--path-between: {s:?} is not a label of {} ({})",
                v.name,
                v.label_names.join(", ")
            ))
        })
    };
    let (from, to) = (find(a)?, find(b)?);
    if from == to {
        return Err(CliError::usage(format!("--path-between {spec:?}: the same object twice")));
    }
    Ok(Between { from, to, steps })
}

/// The measured path.
pub(super) struct Path {
    pub(super) directions: Vec<DVec3>,
    pub(super) report: Report,
}

/// Casts and measures the path (see the module docs). `voxel_p` is the
/// sphere's `p(Z)`, `objects` the sphere's object channel measures.
#[allow(clippy::too_many_arguments)]
pub(super) fn path(
    b: &Between,
    v: &Volume,
    caster: &dyn VolumeCaster,
    dirs: &[DVec3],
    objects: &ObjectMeasures,
    voxel_p: &[f64],
    opts: (f64, u32),
    base: itgfx_core::Base,
) -> Result<Path, CliError> {
    let unit = Some(base.unit());
    let names = &v.label_names;
    let seen = |k: usize| {
        objects.characteristic[k].ok_or_else(|| {
            CliError::usage(format!(
                "--path-between: no viewpoint sees {:?}, so it has no characteristic view",
                names[k]
            ))
        })
    };
    let (ca, cb) = (seen(b.from)?, seen(b.to)?);
    let directions = geodesic(dirs[ca], dirs[cb], b.steps);
    let copts = VolumeChannelOptions { directions: directions.clone(), distance: opts.0, size: opts.1 };
    let mut progress = Progress::new();
    let ch = volume_channel(caster, &copts, &mut |d, t| progress.update(d, t))
        .map_err(|e| CliError::usage(e.to_string()))?;
    let och = match (&v.membership, &v.labels) {
        (Some(m), _) => object_channel_fuzzy(&ch, m, names.len()),
        (None, Some(l)) => object_channel(&ch, l, names.len()),
        (None, None) => return Err(CliError::usage("--path-between: no labelled objects")),
    };
    let err = |e| core_err("path between objects", e);
    // Each step's own row against the sphere's marginals; p(v) plays no part in a row's measures.
    let row_measures =
        |ch: &ViewpointChannel, target: &[f64]| -> Result<(ViewpointAnalysis, Vec<f64>, Vec<f64>), CliError> {
            let an = ViewpointAnalysis::new(ch, ViewpointWeights::Uniform, false).map_err(err)?;
            let core = an.channel().map_err(err)?;
            let (mut d, mut h) = (vec![0.0; an.rows()], vec![0.0; an.rows()]);
            core.specific_information_into(target, base, &mut d).map_err(err)?;
            core.row_entropies_into(base, &mut h).map_err(err)?;
            let (d, h) = (an.expand(&d, f64::NAN), an.expand(&h, f64::NAN));
            Ok((an, d, h))
        };
    // VE over everything a step sees; VMI over the voxels the sphere's views see too (p(z) > 0:
    // a step between the sampled views may graze a voxel none of them sees, whose KL term would
    // be infinite), with the share of the step's visibility left out reported beside it.
    let (_, _, ve) = row_measures(&ch, voxel_p)?;
    let (inside, outside) = restrict(&ch, voxel_p);
    let (_, vmi, _) = row_measures(&inside, voxel_p)?;
    let (oan, ovmi, _) = row_measures(&och, &objects.p_o)?;
    let share = |step: usize, k: usize| {
        oan.row_of(step).map_or(0.0, |x| {
            let (cols, p) = oan.row(x);
            cols.iter().position(|&c| c as usize == k).map_or(0.0, |i| p[i])
        })
    };
    let finite = |x: f64| Some(x).filter(|x| x.is_finite());
    let steps = (0..directions.len())
        .map(|k| {
            let mut x = Report::new();
            x.count("step", k as u64).reals("direction", directions[k].to_array().to_vec());
            x.maybe_real("VMI", finite(vmi[k]), unit).maybe_real("VE", finite(ve[k]), unit);
            x.real("unseen_by_sphere_share", outside[k], None);
            x.maybe_real("object_VMI", finite(ovmi[k]), unit);
            x.real("p_from", share(k, b.from), None).real("p_to", share(k, b.to), None);
            x
        })
        .collect();
    let mut r = Report::new();
    r.text("from", names[b.from].clone()).text("to", names[b.to].clone());
    r.count("from_view", ca as u64).count("to_view", cb as u64);
    r.real("angle_deg", turn(dirs[ca], dirs[cb]).to_degrees(), None);
    r.text("path", "great circle (slerp), steps equally spaced in angle");
    r.records("steps", steps);
    Ok(Path { directions, report: r })
}

/// The channel with each row kept to the outputs of positive `target`
/// mass, and per row the share of its visibility left out.
fn restrict(ch: &ViewpointChannel, target: &[f64]) -> (ViewpointChannel, Vec<f64>) {
    let (mut starts, mut patch, mut solid_angle, mut outside) = (vec![0], Vec::new(), Vec::new(), Vec::new());
    for v in 0..ch.viewpoints() {
        let (z, vis) = ch.row(v);
        let (mut all, mut out) = (0.0, 0.0);
        for (&z, &x) in z.iter().zip(vis) {
            all += x;
            if target[z as usize] > 0.0 {
                patch.push(z);
                solid_angle.push(x);
            } else {
                out += x;
            }
        }
        starts.push(patch.len());
        outside.push(if all > 0.0 { out / all } else { 0.0 });
    }
    let kept = ViewpointChannel { starts, patch, solid_angle, ..ch.clone() };
    (kept, outside)
}
