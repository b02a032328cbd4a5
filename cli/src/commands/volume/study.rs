//! One volume's run, past its checks: what it reads before any work
//! ([`Inputs`]), the measures of its channel and routes ([`Study`]), its
//! report and its pictures; `run_in` in `mod.rs` puts them in order.

use std::path::PathBuf;

use glam::DVec3;
use itgfx_backends::backend::open_volume;
use itgfx_backends::viewpoint::ViewpointChannel;
use itgfx_backends::viewpoint::selection::{BestViews, Exploration, best_views, exploration};
use itgfx_backends::volume::raycast::Caster;
use itgfx_backends::volume::{Volume, VolumeMeasures, volume_measures};

use super::routes::{IsoRoute, ObjectMeasures, correlation, iso_route, object_measures};
use super::{VolumeOptions, between, input, pictures, weights};
use crate::report::Report;
use crate::values::argmin;
use crate::{CliError, core_err};

/// The volume and what the options name in it, with every output path,
/// read and checked before any work.
pub(super) struct Inputs {
    pub(super) volume: Volume,
    /// `--focus`: the importance per voxel and the object's name.
    pub(super) focus: Option<(Vec<f64>, String)>,
    /// `--path-between`'s two objects and its steps.
    pub(super) between: Option<between::Between>,
    /// The pictures and `volume.json` under `--out`.
    pub(super) outputs: Vec<PathBuf>,
    /// The montages under `--out`: the path between two objects, the guided
    /// tour, each object's characteristic view (labelled volumes).
    pub(super) between_png: Option<PathBuf>,
    pub(super) tour_png: Option<PathBuf>,
    pub(super) objects_png: Option<PathBuf>,
}

impl Inputs {
    /// Reads the volume and checks the shard options, the objects named and
    /// the output paths.
    pub(super) fn read(o: &VolumeOptions, spec: &str) -> Result<Self, CliError> {
        super::shard::check(o)?;
        let outputs = super::out_paths(o, &pictures::PICTURES)?;
        let volume = input::load(o, spec)?;
        let focus = o.focus.as_deref().map(|f| input::focus(&volume, f)).transpose()?;
        let between =
            o.path_between.as_deref().map(|s| between::labels(&volume, s, o.path_steps.unwrap_or(8))).transpose()?;
        let between_png = o.out.as_ref().filter(|_| between.is_some()).map(|d| d.join(between::PICTURE));
        let tour_png = o.out.as_ref().map(|d| d.join(pictures::TOUR));
        let objects_png = o.out.as_ref().filter(|_| volume.labels.is_some()).map(|d| d.join(pictures::OBJECTS));
        for p in [&between_png, &tour_png, &objects_png].into_iter().flatten() {
            crate::output::check("--out", p)?;
        }
        let (lo, hi) = volume.range();
        if lo >= hi {
            return Err(CliError::usage(format!(
                "{}: constant volume (every voxel is {lo}): nothing to see",
                volume.name
            )));
        }
        Ok(Self { volume, focus, between, outputs, between_png, tour_png, objects_png })
    }
}

/// Every measure of the run: the voxel channel's (Part VI), the selections
/// of Part V over it, and the routes the options ask for.
pub(super) struct Study {
    pub(super) m: VolumeMeasures,
    pub(super) objects: Option<ObjectMeasures>,
    pub(super) best_n: BestViews,
    pub(super) tour: Exploration,
    pub(super) instability: Vec<f64>,
    /// The visibility each viewpoint gathers (`seen_angle`, per viewpoint).
    pub(super) seen: Vec<f64>,
    pub(super) iso: Option<IsoRoute>,
    pub(super) path_between: Option<between::Path>,
    pub(super) entries: u64,
    pub(super) rays_per_viewpoint: u64,
    /// Seconds the channel's measures took (objects' included).
    pub(super) measures_seconds: f64,
}

impl Study {
    /// Measures the channel `ch` of `inputs`' volume seen from `dirs`, each
    /// with `rays²` rays.
    pub(super) fn run(
        o: &VolumeOptions,
        inputs: &Inputs,
        caster: &Caster,
        ch: ViewpointChannel,
        (dirs, rays): (&[DVec3], u32),
    ) -> Result<Self, CliError> {
        let t0 = std::time::Instant::now();
        let (base, volume) = (o.common.base, &inputs.volume);
        let err = |e| core_err("volume channel", e);
        // What needs the raw rows comes first: the measures normalise them in place.
        let (entries, rays_per_viewpoint, neighbours) =
            (ch.patch.len() as u64, ch.rays_per_viewpoint, ch.neighbours(6));
        let objects = volume
            .labels
            .as_ref()
            .map(|l| object_measures(&ch, volume, l, &volume.label_names, weights(o), base))
            .transpose()?;
        let focus = inputs.focus.as_ref().map(|f| f.0.as_slice());
        let m = volume_measures(ch, dirs, &caster.voxel_opacity, focus, weights(o), base).map_err(err)?;
        let measures_seconds = t0.elapsed().as_secs_f64();
        let v = &m.views;
        let best_n = best_views(&m.analysis, v, o.selection.capture, o.selection.best_n, base, None).map_err(err)?;
        let tour = exploration(&m.analysis, &neighbours, v.best, o.selection.explore, base).map_err(err)?;
        // Without a logarithm held per entry: the memory estimate counts 12 bytes an entry.
        let instability = m.analysis.instability_lean(&neighbours, base).map_err(err)?;
        let seen = m.analysis.expand(&m.analysis.seen_angle, 0.0);
        let iso = o.iso.map(|f| iso_route(volume, f, dirs, o.distance, rays, base)).transpose()?;
        let path_between = match (&inputs.between, &objects) {
            (Some(b), Some(ob)) => {
                let backend = open_volume(o.backend, caster).map_err(|e| CliError::usage(e.to_string()))?;
                Some(between::path(b, volume, &*backend, dirs, ob, &m.analysis.p_o, (o.distance, rays), base)?)
            }
            _ => None,
        };
        Ok(Self {
            m,
            objects,
            best_n,
            tour,
            instability,
            seen,
            iso,
            path_between,
            entries,
            rays_per_viewpoint,
            measures_seconds,
        })
    }

    /// The report: the volume, the channel, its measures and selections,
    /// the routes, one record per viewpoint.
    pub(super) fn report(&self, o: &VolumeOptions, inputs: &Inputs, dirs: &[DVec3]) -> Report {
        let unit = Some(o.common.base.unit());
        let (volume, m, v) = (&inputs.volume, &self.m, &self.m.views);
        let mut r = Report::new();
        r.text("volume", volume.name.clone()).text("backend", o.backend.name());
        r.counts("dims", volume.dims.iter().map(|&d| d as u64).collect());
        r.count("voxels", volume.voxels() as u64).count("viewpoints", dirs.len() as u64);
        r.count("rays_per_viewpoint", self.rays_per_viewpoint).real("step_voxels", o.step, None);
        r.count("channel_entries", self.entries);
        r.count("voxels_seen", m.analysis.p_o.iter().filter(|&&p| p > 0.0).count() as u64);
        r.text("p_v", if o.uniform_input { "uniform" } else { "visibility gathered" });
        r.real("H_V", m.h_v, unit).real("H_Z", v.object_entropy, unit);
        r.real("H_Z_given_V", v.conditional_entropy, unit).real("I_VZ", v.total_mutual_information, unit);
        r.count("best_view", v.best as u64).count("worst_view", v.worst as u64);
        r.reals("best_view_direction", dirs[v.best].to_array().to_vec());
        r.reals("worst_view_direction", dirs[v.worst].to_array().to_vec());
        r.count("best_EVMI_opacity_view", argmin(&m.evmi_opacity) as u64);
        r.count("best_EVMI_VoMI_view", argmin(&m.evmi_vomi) as u64);
        let nw = &m.noteworthiness_entropy;
        let best_nw = (0..nw.len()).max_by(|&a, &b| nw[a].total_cmp(&nw[b]).then(b.cmp(&a))).unwrap_or(0);
        r.count("best_noteworthiness_VE_view", best_nw as u64);
        if let (Some(f), Some((_, name))) = (&m.evmi_focus, &inputs.focus) {
            r.text("focus", name.clone()).count("best_focus_view", argmin(f) as u64);
            r.reals("best_focus_direction", dirs[argmin(f)].to_array().to_vec());
        }
        let vomi_max = m.vomi.iter().copied().fold(0.0, f64::max);
        let vomi_mean: f64 = m.vomi.iter().zip(&m.analysis.p_o).map(|(i, p)| i * p).sum();
        r.real("VoMI_max", vomi_max, unit).real("VoMI_mean_pz", vomi_mean, unit);
        let (best_n, tour) = (&self.best_n, &self.tour);
        r.counts("best_n_views", best_n.views.iter().map(|&x| x as u64).collect());
        r.reals("best_n_merged_VMI", best_n.merged_information.clone());
        r.reals("best_n_captured", best_n.captured.clone());
        r.counts("exploration_path", tour.path.iter().map(|&x| x as u64).collect());
        if let Some(iso) = &self.iso {
            self.iso_report(iso, dirs, unit, &mut r);
        }
        if let Some(ob) = &self.objects {
            objects_report(ob, volume, dirs, unit, &mut r);
        }
        if let Some(p) = &self.path_between {
            r.records("path_between", vec![p.report.clone()]);
        }
        r.records("views", (0..dirs.len()).map(|k| self.view_record(k, dirs[k], unit)).collect());
        r
    }

    /// The iso-surface route against the voxels' (Part VI §2.1).
    fn iso_report(&self, iso: &IsoRoute, dirs: &[DVec3], unit: Option<&'static str>, r: &mut Report) {
        let v = &self.m.views;
        r.real("iso", iso.value, None).count("iso_triangles", iso.triangles as u64);
        r.real("iso_I_VO", iso.measures.total_mutual_information, unit);
        r.count("iso_best_view", iso.measures.best as u64).count("iso_worst_view", iso.measures.worst as u64);
        r.reals("iso_best_direction", dirs[iso.measures.best].to_array().to_vec());
        let angle = dirs[iso.measures.best].angle_between(dirs[v.best]).to_degrees();
        r.real("iso_best_angle_to_voxel_best_deg", angle, None);
        // Symmetric volumes have many equally good views: the rank of the
        // iso-surface's best view among the voxel route's VMIs says more than the angle.
        let b = v.mutual_information[iso.measures.best];
        let rank = v.mutual_information.iter().filter(|&&x| x < b - 1e-9 * b.abs()).count();
        r.count("iso_best_voxel_rank", rank as u64);
        let c = correlation(&iso.measures.mutual_information, &v.mutual_information);
        r.maybe_real("iso_voxel_VMI_correlation", c, None);
    }

    /// One viewpoint's record.
    fn view_record(&self, k: usize, d: DVec3, unit: Option<&'static str>) -> Report {
        let (m, v) = (&self.m, &self.m.views);
        let mut x = Report::new();
        x.reals("direction", d.to_array().to_vec());
        x.real("p_v", v.weight[k], None).real("H_Z_given_v", v.entropy[k], unit);
        x.real("VMI", v.mutual_information[k], unit);
        x.real("EVMI_opacity", m.evmi_opacity[k], unit).real("EVMI_VoMI", m.evmi_vomi[k], unit);
        x.real("VE_noteworthiness", m.noteworthiness_entropy[k], unit);
        if let Some(f) = &m.evmi_focus {
            x.real("EVMI_focus", f[k], unit);
        }
        if let Some(iso) = &self.iso {
            x.real("iso_VMI", iso.measures.mutual_information[k], unit);
        }
        if let Some(ob) = &self.objects {
            x.real("object_VMI", ob.measures.mutual_information[k], unit);
        }
        x.maybe_real("instability", Some(self.instability[k]).filter(|x| x.is_finite()), unit);
        x.real("visibility", self.seen[k] / self.rays_per_viewpoint as f64, None);
        x
    }

    /// The pictures, montages and `volume.json` under `dir`; `r` gets the
    /// list of files and is the JSON written.
    pub(super) fn write(
        &self,
        o: &VolumeOptions,
        dir: &std::path::Path,
        inputs: &Inputs,
        caster: &Caster,
        dirs: &[DVec3],
        r: &mut Report,
    ) -> Result<(), CliError> {
        let shots =
            pictures::Shots { caster, dirs, distance: o.distance, side: o.image, radius: caster.content_radius() };
        shots.write(dir, &self.m, &self.best_n.views)?;
        let mut files: Vec<String> = inputs.outputs.iter().map(|p| p.display().to_string()).collect();
        let mut montages: Vec<(&PathBuf, Vec<DVec3>)> = Vec::new();
        if let (Some(p), Some(png)) = (&self.path_between, &inputs.between_png) {
            montages.push((png, p.directions.clone()));
        }
        if let Some(png) = &inputs.tour_png {
            montages.push((png, self.tour.path.iter().map(|&v| dirs[v]).collect()));
        }
        if let (Some(ob), Some(png)) = (&self.objects, &inputs.objects_png) {
            montages.push((png, ob.characteristic.iter().flatten().map(|&v| dirs[v]).collect()));
        }
        for (png, directions) in montages {
            pictures::montage_of(caster, &directions, o.distance, shots.radius, o.image, png)?;
            files.push(png.display().to_string());
        }
        r.texts("wrote", files);
        let json = r.to_json().to_string();
        crate::output::write(&dir.join(pictures::PICTURES[6]), json.as_bytes())
    }
}

/// The object channel of a labelled volume (Part VI §3.1), one record per object.
fn objects_report(ob: &ObjectMeasures, volume: &Volume, dirs: &[DVec3], unit: Option<&'static str>, r: &mut Report) {
    r.real("object_I_VO", ob.measures.total_mutual_information, unit);
    r.count("object_best_view", ob.measures.best as u64);
    r.reals("object_best_direction", dirs[ob.measures.best].to_array().to_vec());
    let recs = volume
        .label_names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let mut x = Report::new();
            x.text("name", name.clone()).real("p_o", ob.p_o[k], None).real("I_o_V", ob.information[k], unit);
            if let Some(c) = ob.characteristic[k] {
                x.count("characteristic_view", c as u64).reals("characteristic_direction", dirs[c].to_array().to_vec());
            }
            x
        })
        .collect();
    r.records("objects", recs);
}
