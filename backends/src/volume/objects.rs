//! The object channel `V → O` of importance-driven focus of attention
//! (Part VI §3.1 after Viola et al. 2006): a labelled volume's objects in
//! place of its voxels, the visibility of an object being the sum of its
//! voxels' visibilities. Built from the voxel channel by summing each row
//! over labels, so its measures are again the viewpoint code's.

use crate::viewpoint::ViewpointChannel;

/// The object channel: row `v` holds `vis(o|v) = Σ_{z ∈ o} vis(z|v)` for
/// labels `1..=objects` (output `o − 1`); unlabelled voxels (label 0) are
/// left out.
///
/// # Panics
/// If `labels` is shorter than the voxel channel's outputs.
#[must_use]
pub fn object_channel(voxels: &ViewpointChannel, labels: &[u8], objects: usize) -> ViewpointChannel {
    assert!(labels.len() >= voxels.patches, "one label per voxel");
    let mut starts = vec![0];
    let (mut patch, mut solid_angle) = (Vec::new(), Vec::new());
    let mut acc = vec![0.0; objects];
    for v in 0..voxels.viewpoints() {
        acc.iter_mut().for_each(|a| *a = 0.0);
        let (z, vis) = voxels.row(v);
        for (&z, &x) in z.iter().zip(vis) {
            let l = usize::from(labels[z as usize]);
            if (1..=objects).contains(&l) {
                acc[l - 1] += x;
            }
        }
        for (o, &a) in acc.iter().enumerate() {
            if a > 0.0 {
                patch.push(o as u32);
                solid_angle.push(a);
            }
        }
        starts.push(patch.len());
    }
    ViewpointChannel {
        positions: voxels.positions.clone(),
        starts,
        patch,
        solid_angle,
        background: voxels.background.clone(),
        patches: objects,
        rays_per_viewpoint: voxels.rays_per_viewpoint,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_summed_by_label() {
        let ch = ViewpointChannel {
            positions: vec![glam::DVec3::X; 2],
            starts: vec![0, 3, 4],
            patch: vec![0, 1, 2, 3],
            solid_angle: vec![1.0, 2.0, 4.0, 8.0],
            background: vec![0.0; 2],
            patches: 4,
            rays_per_viewpoint: 1,
        };
        let o = object_channel(&ch, &[1, 0, 1, 2], 2);
        assert_eq!(o.row(0), (&[0u32][..], &[5.0][..]));
        assert_eq!(o.row(1), (&[1u32][..], &[8.0][..]));
    }
}
