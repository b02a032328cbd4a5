//! The object channel `V → O` of importance-driven focus of attention
//! (Part VI §3.1 after Viola et al. 2006): a labelled volume's objects in
//! place of its voxels, the visibility of an object being the sum of its
//! voxels' visibilities. Built from the voxel channel by summing each row
//! over labels, so its measures are again the viewpoint code's.
//!
//! Membership may be fuzzy (Part VI §3.1: "a voxel may belong to several
//! objects at the same time"): with `p(o|z)` per voxel ([`Membership`]),
//! `vis(o|v) = Σ_z vis(z|v) p(o|z)` ([`object_channel_fuzzy`]); the rest
//! `1 − Σ_o p(o|z)` is the background, left out as label 0 is. Crisp labels
//! are the membership with weights 1, and give the same rows bit for bit.

use crate::viewpoint::ViewpointChannel;

/// Fuzzy object membership `p(o|z)`: per voxel, the objects (labels
/// `1..`) it belongs to with positive weight, in increasing label order,
/// and their weights; each voxel's weights are in `(0, 1]` and sum to at
/// most 1 (the rest is the background).
#[derive(Clone, Debug, PartialEq)]
pub struct Membership {
    /// Row offsets: voxel `z`'s entries are `starts[z]..starts[z + 1]`.
    pub starts: Vec<usize>,
    /// Label (`1..`) of each entry.
    pub objects: Vec<u8>,
    /// `p(o|z)` of each entry.
    pub weights: Vec<f64>,
}

impl Membership {
    /// The crisp membership of `labels`: weight 1 for each voxel's label
    /// (none for label 0).
    #[must_use]
    pub fn crisp(labels: &[u8]) -> Self {
        let mut m = Self { starts: vec![0], objects: Vec::new(), weights: Vec::new() };
        for &l in labels {
            if l > 0 {
                m.objects.push(l);
                m.weights.push(1.0);
            }
            m.starts.push(m.objects.len());
        }
        m
    }

    /// Voxels.
    #[must_use]
    pub fn voxels(&self) -> usize {
        self.starts.len() - 1
    }

    /// Voxel `z`'s labels and weights.
    #[must_use]
    pub fn row(&self, z: usize) -> (&[u8], &[f64]) {
        let (a, b) = (self.starts[z], self.starts[z + 1]);
        (&self.objects[a..b], &self.weights[a..b])
    }

    /// `p(o|z)` of label `o` (`1..`) for every voxel: the importance of a
    /// fuzzy object for `--focus`.
    #[must_use]
    pub fn of(&self, o: u8) -> Vec<f64> {
        (0..self.voxels())
            .map(|z| {
                let (l, w) = self.row(z);
                l.iter().position(|&x| x == o).map_or(0.0, |k| w[k])
            })
            .collect()
    }
}

/// The object channel with fuzzy membership: row `v` holds
/// `vis(o|v) = Σ_z vis(z|v) p(o|z)` for labels `1..=objects` (output
/// `o − 1`), summed in the voxel channel's order.
///
/// # Panics
/// If `m` has fewer voxels than the voxel channel's outputs.
#[must_use]
pub fn object_channel_fuzzy(voxels: &ViewpointChannel, m: &Membership, objects: usize) -> ViewpointChannel {
    assert!(m.voxels() >= voxels.patches, "one membership row per voxel");
    rows_by_object(voxels, objects, |z, acc| {
        let (l, w) = m.row(z);
        for (&l, &w) in l.iter().zip(w) {
            let l = usize::from(l);
            if (1..=objects).contains(&l) {
                acc(l - 1, w);
            }
        }
    })
}

/// The object channel: row `v` holds `vis(o|v) = Σ_{z ∈ o} vis(z|v)` for
/// labels `1..=objects` (output `o − 1`); unlabelled voxels (label 0) are
/// left out.
///
/// # Panics
/// If `labels` is shorter than the voxel channel's outputs.
#[must_use]
pub fn object_channel(voxels: &ViewpointChannel, labels: &[u8], objects: usize) -> ViewpointChannel {
    assert!(labels.len() >= voxels.patches, "one label per voxel");
    rows_by_object(voxels, objects, |z, acc| {
        let l = usize::from(labels[z]);
        if (1..=objects).contains(&l) {
            acc(l - 1, 1.0);
        }
    })
}

/// Sums each row of the voxel channel into `objects` outputs: `spread(z,
/// add)` calls `add(o, w)` to add `w · vis(z|v)` to object `o`.
fn rows_by_object(
    voxels: &ViewpointChannel,
    objects: usize,
    spread: impl Fn(usize, &mut dyn FnMut(usize, f64)),
) -> ViewpointChannel {
    let mut starts = vec![0];
    let (mut patch, mut solid_angle) = (Vec::new(), Vec::new());
    let mut acc = vec![0.0; objects];
    for v in 0..voxels.viewpoints() {
        acc.iter_mut().for_each(|a| *a = 0.0);
        let (z, vis) = voxels.row(v);
        for (&z, &x) in z.iter().zip(vis) {
            // A weight of 1 multiplies exactly: crisp labels give today's sums.
            spread(z as usize, &mut |o, w| acc[o] += x * w);
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
        // Crisp membership: the same rows, bit for bit.
        let crisp = Membership::crisp(&[1, 0, 1, 2]);
        assert_eq!(object_channel_fuzzy(&ch, &crisp, 2), o);
        // Voxel 1 half in object 1, half background; voxel 3 split 1/4, 3/4.
        let fuzzy = Membership {
            starts: vec![0, 1, 2, 3, 5],
            objects: vec![1, 1, 1, 1, 2],
            weights: vec![1.0, 0.5, 1.0, 0.25, 0.75],
        };
        let f = object_channel_fuzzy(&ch, &fuzzy, 2);
        assert_eq!(f.row(0), (&[0u32][..], &[6.0][..]));
        assert_eq!(f.row(1), (&[0u32, 1][..], &[2.0, 6.0][..]));
        assert_eq!(fuzzy.of(2), vec![0.0, 0.0, 0.0, 0.75]);
    }
}
