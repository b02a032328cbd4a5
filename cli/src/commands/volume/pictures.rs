//! The pictures of `itgfx volume --out DIR`: best and worst renders, the
//! best-n montage, the viewpoint sphere coloured by the measures, VoMI as
//! slices and as a tint, and colour VoMI with its key.

use std::path::Path;

use glam::DVec3;
use itgfx_backends::volume::channel::viewpoint_colour;
use itgfx_backends::volume::raycast::{Caster, viewpoint_camera};
use itgfx_backends::volume::{Volume, VolumeMeasures};

use crate::CliError;
use crate::export::{montage, percentile_range, sphere_image, sphere_image_coloured, viridis, write_png};

/// The pictures under `--out`, in order (the report, `volume.json`, last).
pub(super) const PICTURES: [&str; 7] =
    ["best.png", "worst.png", "best-n.png", "sphere.png", "vomi.png", "colour-vomi.png", "volume.json"];

/// What the pictures show.
pub(super) struct Shots<'a> {
    /// The ray caster.
    pub caster: &'a Caster<'a>,
    /// Viewpoint directions.
    pub dirs: &'a [DVec3],
    /// Viewpoint distance in bounding-sphere radii.
    pub distance: f64,
    /// Picture side in pixels.
    pub side: u32,
    /// Radius of the sphere the pictures frame ([`Caster::content_radius`]).
    pub radius: f64,
}

impl Shots<'_> {
    /// The volume from viewpoint `k`, framed on what the transfer function
    /// shows, `s × s`, optionally tinted per voxel.
    fn shot(&self, k: usize, tint: Option<&[[f32; 3]]>, s: u32) -> image::RgbImage {
        tinted_view(self.caster, self.dirs[k], self.distance, self.radius, s, tint)
    }

    /// Writes the six pictures of [`PICTURES`] into `dir`.
    ///
    /// # Errors
    /// Encoding and I/O errors, one line.
    pub(super) fn write(&self, dir: &Path, m: &VolumeMeasures, best_n: &[usize]) -> Result<(), CliError> {
        let (v, side, dirs) = (&m.views, self.side, self.dirs);
        let volume = self.caster.volume;
        write_png(&self.shot(v.best, None, side), &dir.join(PICTURES[0]))?;
        write_png(&self.shot(v.worst, None, side), &dir.join(PICTURES[1]))?;
        let half = (side / 2).max(16);
        let imgs: Vec<_> = best_n.iter().map(|&k| self.shot(k, None, half)).collect();
        write_png(&montage(&imgs, 3), &dir.join(PICTURES[2]))?;
        let finite = |x: &[f64]| -> Vec<f64> { x.iter().map(|&x| if x.is_finite() { x } else { f64::NAN }).collect() };
        let (vmi, evmi) = (finite(&v.mutual_information), finite(&m.evmi_opacity));
        write_png(&sphere_image(dirs, &[&vmi, &v.entropy, &evmi], dirs[v.best], side / 2), &dir.join(PICTURES[3]))?;
        // VoMI: the middle y slice, its p(z)-weighted mean along y, and the volume shaded by VoMI from the best view.
        let (vlo, vhi) = percentile_range(&m.vomi);
        let vomi_tint: Vec<[f32; 3]> = m
            .vomi
            .iter()
            .map(|&x| viridis((x - vlo) / (vhi - vlo)).map(|c| (f32::from(c) / 255.0).powf(2.2)))
            .collect();
        let slices = vomi_planes(volume, &m.vomi, &m.analysis.p_o[..volume.voxels()], side, (vlo, vhi));
        let tinted = self.shot(v.best, Some(&vomi_tint), side);
        write_png(&montage(&[slices.0, slices.1, tinted], 3), &dir.join(PICTURES[4]))?;
        // Colour VoMI: each voxel the colour of the viewpoints most informative about it;
        // beside it the key, the viewpoint sphere in the viewpoints' colours.
        let scale = if vhi > 0.0 { vhi } else { 1.0 };
        let colour_tint: Vec<[f32; 3]> =
            m.colour_vomi.iter().map(|c| c.map(|x| (x / scale).clamp(0.0, 1.0) as f32)).collect();
        let key: Vec<[u8; 3]> = dirs.iter().map(|&d| viewpoint_colour(d).map(|c| (c * 255.0).round() as u8)).collect();
        let palette = sphere_image_coloured(dirs, &[key], None, side / 2);
        write_png(&montage(&[self.shot(v.best, Some(&colour_tint), side), palette], 2), &dir.join(PICTURES[5]))
    }
}

/// The montage of the exploration path's views under `--out`.
pub(super) const TOUR: &str = "tour.png";

/// The montage of each object's characteristic view (labelled volumes).
pub(super) const OBJECTS: &str = "objects.png";

/// Writes the volume seen from each of `directions` (tiles of half the
/// picture side, at most 8 a row) to `path`.
///
/// # Errors
/// Encoding and I/O errors, one line.
pub(super) fn montage_of(
    caster: &Caster<'_>,
    directions: &[DVec3],
    distance: f64,
    radius: f64,
    side: u32,
    path: &Path,
) -> Result<(), CliError> {
    let half = (side / 2).max(16);
    let imgs: Vec<_> = directions.iter().map(|&d| view(caster, d, distance, radius, half)).collect();
    write_png(&montage(&imgs, imgs.len().clamp(1, 8)), path)
}

/// The volume seen from `direction` at `distance` radii, framed on the
/// sphere of `radius`, `s × s`.
pub(super) fn view(caster: &Caster<'_>, direction: DVec3, distance: f64, radius: f64, s: u32) -> image::RgbImage {
    tinted_view(caster, direction, distance, radius, s, None)
}

fn tinted_view(
    caster: &Caster<'_>,
    direction: DVec3,
    distance: f64,
    radius: f64,
    s: u32,
    tint: Option<&[[f32; 3]]>,
) -> image::RgbImage {
    let px = caster.render(&viewpoint_camera(direction, distance, radius), s, tint);
    image::RgbImage::from_fn(s, s, |x, y| image::Rgb(px[(y * s + x) as usize]))
}

/// The middle y slice (x across, z up) of a per-voxel field and its mean
/// along y weighted by `weight` (`p(z)`: the field where the channel looks),
/// each `side × side` (nearest voxel), viridis between `range`.
fn vomi_planes(
    v: &Volume,
    field: &[f64],
    weight: &[f64],
    side: u32,
    range: (f64, f64),
) -> (image::RgbImage, image::RgbImage) {
    let [nx, ny, nz] = v.dims;
    let at = |x: u32, y: u32| {
        let i = ((f64::from(x) + 0.5) / f64::from(side) * nx as f64) as usize;
        let k = ((f64::from(y) + 0.5) / f64::from(side) * nz as f64) as usize;
        (i.min(nx - 1), nz - 1 - k.min(nz - 1))
    };
    let colour = |x: f64| image::Rgb(viridis((x - range.0) / (range.1 - range.0)));
    let slice = image::RgbImage::from_fn(side, side, |x, y| {
        let (i, k) = at(x, y);
        colour(field[v.index(i, ny / 2, k)])
    });
    let mip = image::RgbImage::from_fn(side, side, |x, y| {
        let (i, k) = at(x, y);
        let (a, w) =
            (0..ny).map(|j| v.index(i, j, k)).fold((0.0, 0.0), |(a, w), z| (a + weight[z] * field[z], w + weight[z]));
        if w > 0.0 { colour(a / w) } else { image::Rgb(itgfx_backends::preview::BACKGROUND) }
    });
    (slice, mip)
}
