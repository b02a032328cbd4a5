//! The one fingerprint of shard and counts files: FNV-1a, 64 bits, of
//! what a file's numbers depend on (a scene's triangles, a volume's voxels,
//! a run's settings), and [`MeshFingerprint`], what identifies the scene.

use serde::{Deserialize, Serialize};

use crate::tracer::Prepared;

/// FNV-1a, 64 bits: the fingerprints' hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hashes `bytes` in.
    pub fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The hash.
    #[must_use]
    pub fn value(self) -> u64 {
        self.0
    }

    /// The hash as 16 hexadecimal digits.
    #[must_use]
    pub fn hex(self) -> String {
        format!("{:016x}", self.0)
    }
}

/// What identifies the scene: a shard of another mesh is refused.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFingerprint {
    /// The scene's name.
    pub name: String,
    /// Patches (polygons).
    pub patches: u64,
    /// Triangles traced.
    pub triangles: u64,
    /// FNV-1a (64 bits, 16 hexadecimal digits) of every triangle's vertex
    /// bits (f32, little-endian) and patch id, in order.
    pub hash: String,
}

impl MeshFingerprint {
    /// The fingerprint of a prepared scene named `name`.
    #[must_use]
    pub fn of(name: &str, p: &Prepared) -> Self {
        let mut h = Fnv::default();
        for (t, &patch) in p.triangles.iter().zip(&p.triangle_patch) {
            for v in t {
                for c in v.to_array() {
                    h.eat(&c.to_bits().to_le_bytes());
                }
            }
            h.eat(&patch.to_le_bytes());
        }
        Self { name: name.to_string(), patches: p.patches as u64, triangles: p.triangles.len() as u64, hash: h.hex() }
    }

    /// A volume's fingerprint: `voxels` outputs, no triangles, and `hash`
    /// of everything its rows depend on besides the viewpoints (the voxels,
    /// the transfer function and the sample step: `volume::raycast::Caster::fingerprint`).
    #[must_use]
    pub fn volume(name: &str, voxels: usize, hash: Fnv) -> Self {
        Self { name: name.to_string(), patches: voxels as u64, triangles: 0, hash: hash.hex() }
    }
}
