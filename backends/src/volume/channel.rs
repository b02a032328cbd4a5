//! The viewpoint channel over voxels `V → Z` and its measures (Part VI §2.2
//! with the measures of Part V §3).
//!
//! Row `v` holds `vis(z|v)` from [`Caster::visibility`]; it is stored in the
//! polygonal code's [`ViewpointChannel`] (voxels as patches) and normalised
//! by [`ViewpointAnalysis`], so `p(z|v)`, `p(v)`, `p(z)`, `H(Z|v)`, VMI and
//! `I(V;Z)` are the very functions used for meshes. Added here, from the
//! same sparse channel of the core:
//! * `H(V)`, the entropy of `p(V)`;
//! * VoMI, the voxel mutual information `I(z;V) = Σ_v p(v|z) log(p(v|z)/p(v))`
//!   (the output specific information, as polygonal mutual information);
//! * colour VoMI: the terms of VoMI weighted by a colour per viewpoint
//!   ([`viewpoint_colour`]), so a voxel takes the colours of the viewpoints
//!   that tell most about it;
//! * EVMI: VMI against a target `p'(Z)` that weights `p(z)` by an
//!   importance, the voxel's opacity or its VoMI (or a focus object,
//!   Viola et al. 2006), through the viewpoint code's
//!   [`importance_information`] (with its 1% floor of `p(z)`).

use glam::DVec3;
use itgfx_core::{Base, Error, entropy, entropy_of_weights};
use rayon::prelude::*;

use super::cast::VolumeCaster;
use super::raycast::{Caster, viewpoint_camera};
use crate::backend::BackendError;
use crate::viewpoint::selection::importance_information;
use crate::viewpoint::{ViewpointAnalysis, ViewpointChannel, ViewpointMeasures, ViewpointWeights};

/// How the channel is sampled.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeChannelOptions {
    /// Viewpoint directions (unit).
    pub directions: Vec<DVec3>,
    /// Viewpoint distance in bounding-sphere radii (> 1).
    pub distance: f64,
    /// Image side: `size²` rays per viewpoint.
    pub size: u32,
}

/// The voxels that can receive visibility ([`Caster::receiving_voxels`]):
/// a row of the channel holds at most this many entries.
#[must_use]
pub fn seeable_voxels(caster: &Caster<'_>) -> usize {
    caster.receiving_voxels().len()
}

/// Bytes of memory the channel and its measures may need at most, from the
/// `seeable` voxels ([`seeable_voxels`]): one 12-byte entry (voxel index and
/// value) per viewpoint and seeable voxel, held once (the measures normalise
/// the rows in place, [`ViewpointAnalysis::from_channel`]); per viewpoint in
/// flight (two per worker thread) a dense row over the seeable voxels and
/// its sparse copy (20 bytes per seeable voxel); and per voxel of the grid
/// 13 bytes for the caster (opacity and active cells) and the map from voxel
/// to seeable slot, plus 72 bytes for the per-voxel measures (`p(z)`, VoMI,
/// colour VoMI, EVMI's targets and the VoMI pictures).
#[must_use]
pub fn channel_memory(caster: &Caster<'_>, seeable: usize, viewpoints: usize) -> u64 {
    let seeable = seeable as u64;
    let threads = rayon::current_num_threads() as u64 * 2;
    let voxels = caster.volume.voxels() as u64;
    viewpoints as u64 * seeable * 12 + threads * seeable * 20 + voxels * (13 + 72)
}

/// Casts `size²` rays from every viewpoint and gathers `vis(z|v)`.
/// Viewpoints are cast in parallel, each by one thread in a fixed order, so
/// the numbers do not depend on the thread count. A viewpoint in flight sums
/// its visibility over the seeable voxels only ([`Caster::receiving_voxels`],
/// a dense row of that length), then keeps its positive entries: the same
/// sums, in the same order, as a row over every voxel. `progress(done,
/// total)` counts viewpoints. The rays are cast by `backend` (the CPU's
/// [`Caster`] or a device, [`crate::backend::open_volume`]): every backend gives these
/// rows bit for bit.
///
/// # Errors
/// The backend's (a device that fails).
pub fn volume_channel(
    backend: &dyn VolumeCaster,
    o: &VolumeChannelOptions,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<ViewpointChannel, BackendError> {
    let caster = backend.caster();
    let voxels = caster.volume.voxels();
    let seeable = caster.receiving_voxels();
    let mut slot = vec![u32::MAX; voxels];
    for (k, &z) in seeable.iter().enumerate() {
        slot[z as usize] = k as u32;
    }
    let total = o.directions.len() as u64;
    let wave = (rayon::current_num_threads() * 2).max(2);
    let mut starts = vec![0];
    let (mut patch, mut solid_angle, mut background) = (Vec::new(), Vec::new(), Vec::new());
    // At most one entry per viewpoint and seeable voxel (what
    // `channel_memory` counts): the entries grow fallibly up to that.
    let most = o.directions.len().saturating_mul(seeable.len());
    let short = |e: std::collections::TryReserveError| BackendError::TooLarge {
        backend: backend.name(),
        reason: format!("the channel's entries: {e} (fewer viewpoints or a smaller volume)"),
    };
    for (w, dirs) in o.directions.chunks(wave).enumerate() {
        let rows: Vec<(Vec<u32>, Vec<f64>, f64)> = dirs
            .par_iter()
            .map(|&d| {
                let mut vis = vec![0.0; seeable.len()];
                let bg = backend.visibility_row(&viewpoint_camera(d, o.distance, 1.0), o.size, &slot, &mut vis)?;
                let (mut idx, mut val) = (Vec::new(), Vec::new());
                for (&z, &x) in seeable.iter().zip(&vis) {
                    if x > 0.0 {
                        idx.push(z);
                        val.push(x);
                    }
                }
                Ok((idx, val, bg))
            })
            .collect::<Result<_, BackendError>>()?;
        for (idx, val, bg) in rows {
            crate::memory::try_grow(&mut patch, idx.len(), most).map_err(short)?;
            crate::memory::try_grow(&mut solid_angle, val.len(), most).map_err(short)?;
            patch.extend(idx);
            solid_angle.extend(val);
            background.push(bg);
            starts.push(patch.len());
        }
        progress((w * wave + dirs.len()) as u64, total);
    }
    Ok(ViewpointChannel {
        positions: o.directions.iter().map(|d| d.normalize() * o.distance).collect(),
        starts,
        patch,
        solid_angle,
        background,
        patches: voxels,
        rays_per_viewpoint: u64::from(o.size) * u64::from(o.size),
    })
}

/// Viewpoint entropy with noteworthiness (Bordoloi and Shen 2005, Part VI
/// §2.2): per viewpoint, the entropy of `q(z|v) ∝ vis(z|v) / W(z)` over the
/// voxels of positive noteworthiness `W` (the transfer function's opacity of
/// the voxel), highest when each voxel is seen in proportion to its
/// noteworthiness, so the best view is the maximum. 0 for a viewpoint that
/// sees no noteworthy voxel.
///
/// # Errors
/// [`Error::LengthMismatch`] if `noteworthiness` is not one per voxel.
pub fn noteworthiness_entropy(ch: &ViewpointChannel, noteworthiness: &[f64], base: Base) -> Result<Vec<f64>, Error> {
    if noteworthiness.len() != ch.patches {
        return Err(Error::LengthMismatch { expected: ch.patches, found: noteworthiness.len() });
    }
    (0..ch.viewpoints())
        .into_par_iter()
        .map(|v| {
            let (z, vis) = ch.row(v);
            let q: Vec<f64> = z
                .iter()
                .zip(vis)
                .filter_map(|(&z, &x)| {
                    let w = noteworthiness[z as usize];
                    (w > 0.0).then(|| x / w)
                })
                .collect();
            if q.iter().all(|&x| x <= 0.0) { Ok(0.0) } else { entropy_of_weights(&q, base) }
        })
        .collect()
}

/// A colour for a viewpoint direction, each channel in `[0, 1]`:
/// `(d + 1) / 2`, so opposite viewpoints get complementary colours.
#[must_use]
pub fn viewpoint_colour(d: DVec3) -> [f64; 3] {
    let d = d.normalize();
    [(d.x + 1.0) / 2.0, (d.y + 1.0) / 2.0, (d.z + 1.0) / 2.0]
}

/// The measures of the channel over voxels, in one unit.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeMeasures {
    /// The normalised channel (rows: viewpoints that see something).
    pub analysis: ViewpointAnalysis,
    /// Per-viewpoint measures of Part V: `p(v)`, `H(Z|v)`, VMI, `I(V;Z)`,
    /// `H(Z|V)`, `H(Z)`, best and worst.
    pub views: ViewpointMeasures,
    /// `H(V)`.
    pub h_v: f64,
    /// VoMI `I(z;V)` per voxel (0 where no viewpoint sees it).
    pub vomi: Vec<f64>,
    /// Colour VoMI per voxel (viewpoint colours from [`viewpoint_colour`]).
    pub colour_vomi: Vec<[f64; 3]>,
    /// EVMI with the voxels' opacity as importance, per viewpoint.
    pub evmi_opacity: Vec<f64>,
    /// EVMI with VoMI as importance, per viewpoint.
    pub evmi_vomi: Vec<f64>,
    /// EVMI with a focus importance, per viewpoint, when one is given.
    pub evmi_focus: Option<Vec<f64>>,
    /// Viewpoint entropy with noteworthiness = opacity ([`noteworthiness_entropy`]).
    pub noteworthiness_entropy: Vec<f64>,
}

/// Every measure of the channel: `directions` are the viewpoints'
/// (for colour VoMI), `opacity` the voxels' transfer-function opacity,
/// `focus` an optional importance per voxel. The channel is consumed: its
/// rows are normalised in place ([`ViewpointAnalysis::from_channel`]), so
/// the entries are held once.
///
/// # Errors
/// [`Error::ZeroMass`] when no viewpoint sees anything; core errors.
pub fn volume_measures(
    ch: ViewpointChannel,
    directions: &[DVec3],
    opacity: &[f64],
    focus: Option<&[f64]>,
    weights: ViewpointWeights,
    base: Base,
) -> Result<VolumeMeasures, Error> {
    let noteworthiness_entropy = noteworthiness_entropy(&ch, opacity, base)?;
    let an = ViewpointAnalysis::from_channel(ch, weights)?;
    let views = an.measures(&vec![1.0; an.patches], base)?;
    let h_v = entropy(&an.p_v, base)?;
    let vomi = an.polygonal_information(base)?;
    let sparse = an.channel()?;
    let mut colour_vomi = vec![[0.0; 3]; an.patches];
    let mut part = vec![0.0; an.patches];
    for c in 0..3 {
        let w: Vec<f64> = an.seen.iter().map(|&v| viewpoint_colour(directions[v])[c]).collect();
        sparse.output_specific_information_weighted_into(&an.p_o, &w, base, &mut part)?;
        for (cv, p) in colour_vomi.iter_mut().zip(&part) {
            cv[c] = *p;
        }
    }
    let evmi_opacity = importance_information(&an, opacity, base)?;
    let evmi_vomi = importance_information(&an, &vomi, base)?;
    let evmi_focus = focus.map(|f| importance_information(&an, f, base)).transpose()?;
    Ok(VolumeMeasures {
        analysis: an,
        views,
        h_v,
        vomi,
        colour_vomi,
        evmi_opacity,
        evmi_vomi,
        evmi_focus,
        noteworthiness_entropy,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewpoint::icosphere;
    use crate::volume::TransferFunction;
    use crate::volume::builtin::built_in;

    fn measures(spec: &str, tf: &str, level: u32, size: u32) -> (Vec<DVec3>, VolumeMeasures) {
        let v = built_in(spec).unwrap();
        let tf = TransferFunction::preset(tf).unwrap();
        let c = Caster::new(&v, &tf, 0.5);
        let dirs = icosphere(level);
        let o = VolumeChannelOptions { directions: dirs.clone(), distance: 3.0, size };
        let ch = volume_channel(&c, &o, &mut |_, _| {}).unwrap();
        let m =
            volume_measures(ch, &dirs, &c.voxel_opacity, None, ViewpointWeights::ProjectedArea, Base::Bits).unwrap();
        (dirs, m)
    }

    #[test]
    fn channel_identities() {
        let (dirs, m) = measures("phantom:12", "ramp", 0, 24);
        let an = &m.analysis;
        // I(V;Z) = Σ p(v) VMI(v) = Σ p(z) VoMI(z) (Part V eq. (6) both ways).
        let by_views: f64 = an.seen.iter().zip(&an.p_v).map(|(&v, p)| p * m.views.mutual_information[v]).sum();
        let by_voxels: f64 = m.vomi.iter().zip(&an.p_o).map(|(i, p)| i * p).sum();
        let i = m.views.total_mutual_information;
        assert!(i > 0.0);
        assert!((by_views - i).abs() < 1e-9 * i.max(1.0), "{by_views} {i}");
        assert!((by_voxels - i).abs() < 1e-9 * i.max(1.0), "{by_voxels} {i}");
        // I(V;Z) <= H(V) and <= H(Z); H(Z|V) = H(Z) - I(V;Z).
        assert!(i <= m.h_v + 1e-9 && i <= m.views.object_entropy + 1e-9);
        assert!((m.views.conditional_entropy - (m.views.object_entropy - i)).abs() < 1e-9);
        // Every VMI and VoMI is >= 0.
        assert!(m.vomi.iter().all(|&x| x >= 0.0));
        assert!(m.views.mutual_information.iter().all(|&x| x >= 0.0));
        // Colour VoMI averages to the colour-weighted VMI: for each channel c,
        // Σ_z p(z) CVoMI_c(z) = Σ_v p(v) c(v) VMI(v).
        for c in 0..3 {
            let z: f64 = m.colour_vomi.iter().zip(&an.p_o).map(|(cv, p)| cv[c] * p).sum();
            let v: f64 = an
                .seen
                .iter()
                .zip(&an.p_v)
                .map(|(&v, p)| p * viewpoint_colour(dirs[v])[c] * m.views.mutual_information[v])
                .sum();
            assert!((z - v).abs() < 1e-9 * i.max(1.0), "channel {c}: {z} {v}");
        }
    }

    #[test]
    fn lean_instability_is_the_same_bits() {
        // The volume's instability holds no logarithm per entry; it must not change a bit.
        let (_, m) = measures("hydrogen:2,1,1,10", "ramp", 1, 20);
        let n = m.analysis.viewpoints;
        let neighbours: Vec<Vec<usize>> = (0..n).map(|v| (1..=6).map(|k| (v + k * 7) % n).collect()).collect();
        let a = m.analysis.instability(&neighbours, Base::Bits).unwrap();
        let b = m.analysis.instability_lean(&neighbours, Base::Bits).unwrap();
        assert!(a.iter().any(|x| *x > 0.0));
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn noteworthiness_entropy_limits() {
        let ch = ViewpointChannel {
            positions: vec![DVec3::X; 2],
            starts: vec![0, 3, 4],
            patch: vec![0, 1, 2, 3],
            solid_angle: vec![1.0, 2.0, 1.0, 8.0],
            background: vec![0.0; 2],
            patches: 4,
            rays_per_viewpoint: 1,
        };
        // W ≡ 1: the plain viewpoint entropy, H(1/4, 1/2, 1/4) = 1.5 bits.
        let h = noteworthiness_entropy(&ch, &[1.0; 4], Base::Bits).unwrap();
        assert!((h[0] - 1.5).abs() < 1e-12 && h[1] == 0.0);
        // Seen exactly in proportion to W: uniform, log2 3.
        let h = noteworthiness_entropy(&ch, &[1.0, 2.0, 1.0, 0.0], Base::Bits).unwrap();
        assert!((h[0] - 3f64.log2()).abs() < 1e-12);
        // Nothing noteworthy seen: 0.
        assert_eq!(h[1], 0.0);
        assert!(noteworthiness_entropy(&ch, &[1.0; 3], Base::Bits).is_err());
    }

    #[test]
    fn seeable_voxels_bound_the_rows() {
        let v = built_in("phantom:12").unwrap();
        let tf = TransferFunction::preset("ramp").unwrap();
        let c = Caster::new(&v, &tf, 0.5);
        let o = VolumeChannelOptions { directions: icosphere(1), distance: 3.0, size: 32 };
        let ch = volume_channel(&c, &o, &mut |_, _| {}).unwrap();
        let seeable = seeable_voxels(&c);
        let visible = c.voxel_opacity.iter().filter(|&&a| a > 0.0).count();
        assert!(seeable >= visible && seeable < v.voxels());
        for (k, &d) in o.directions.iter().enumerate() {
            assert!(ch.row(k).0.len() <= seeable);
            // The rows summed over the seeable voxels are the rows summed
            // over every voxel, bit for bit.
            let mut dense = vec![0.0; v.voxels()];
            let bg = c.visibility(&viewpoint_camera(d, o.distance, 1.0), o.size, &mut dense);
            let z: Vec<u32> = (0..v.voxels() as u32).filter(|&z| dense[z as usize] > 0.0).collect();
            let x: Vec<f64> = z.iter().map(|&z| dense[z as usize]).collect();
            assert_eq!((ch.row(k).0, ch.row(k).1, ch.background[k]), (&z[..], &x[..], bg), "view {k}");
        }
    }

    #[test]
    fn in_place_normalisation_is_the_copying_one() {
        let v = built_in("phantom:12").unwrap();
        let c = Caster::new(&v, &TransferFunction::preset("ramp").unwrap(), 0.5);
        let o = VolumeChannelOptions { directions: icosphere(0), distance: 3.0, size: 16 };
        let mut ch = volume_channel(&c, &o, &mut |_, _| {}).unwrap();
        // A viewpoint that sees nothing: its row is dropped, the rows after it move down.
        let empty = ch.starts[3]..ch.starts[4];
        ch.patch.drain(empty.clone());
        ch.solid_angle.drain(empty.clone());
        for s in &mut ch.starts[4..] {
            *s -= empty.len();
        }
        for w in [ViewpointWeights::ProjectedArea, ViewpointWeights::Uniform] {
            let copied = ViewpointAnalysis::new(&ch, w, false).unwrap();
            assert_eq!(copied.rows(), 11);
            assert_eq!(ViewpointAnalysis::from_channel(ch.clone(), w).unwrap(), copied);
        }
    }

    #[test]
    fn radial_density_gives_equal_views() {
        // A spherically symmetric density: every viewpoint sees the same up
        // to the voxel grid's orientation.
        let (_, m) = measures("sphere:16", "ramp", 1, 24);
        let vmi = &m.views.mutual_information;
        let mean = vmi.iter().sum::<f64>() / vmi.len() as f64;
        let spread = vmi.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
        assert!(spread < 0.05 * mean, "spread {spread} mean {mean}");
    }
}
