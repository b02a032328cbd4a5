//! Keys that match mesh vertices by exact position, for welding a triangle
//! soup into shared vertices and finding shared edges.
//!
//! Coordinates are compared as numbers, not as bit patterns: `-0.0` and
//! `0.0` are one coordinate. The Utah teapot's OBJ writes both on its
//! symmetry planes; keyed by their bits, its seams became zero-width slits of
//! boundary edges (in simplification and in the viewpoint channel's contours
//! and saliency alike). `x + 0.0` turns `-0.0` into `0.0` and leaves every
//! other value, NaN aside, as it is.

use glam::{DVec3, Vec3A};

/// The key of an f64 position.
#[must_use]
pub fn vertex_key(p: DVec3) -> [u64; 3] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
}

/// The key of an f32 position.
#[must_use]
pub fn vertex_key32(p: Vec3A) -> [u32; 3] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
}

#[cfg(test)]
mod tests {
    use super::{vertex_key, vertex_key32};
    use glam::{DVec3, Vec3A};

    #[test]
    fn minus_zero_is_zero_and_nothing_else_merges() {
        assert_eq!(vertex_key(DVec3::new(-0.0, 1.0, -0.0)), vertex_key(DVec3::new(0.0, 1.0, 0.0)));
        assert_eq!(vertex_key32(Vec3A::new(-0.0, 1.0, 0.0)), vertex_key32(Vec3A::new(0.0, 1.0, -0.0)));
        assert_ne!(vertex_key(DVec3::new(1e-300, 0.0, 0.0)), vertex_key(DVec3::ZERO));
        assert_ne!(vertex_key32(Vec3A::new(-1.0, 0.0, 0.0)), vertex_key32(Vec3A::new(1.0, 0.0, 0.0)));
    }
}
