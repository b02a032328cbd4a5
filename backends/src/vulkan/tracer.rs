//! [`VulkanTracer`]: every crossing of each line, on a Vulkan device.
//!
//! The kernel (`shaders/trace.wgsl`) tests each line against every triangle
//! with the watertight test of the CPU backend, taking the per-line shear
//! constants from the host, and returns up to [`MAX_HITS`] raw hits per line
//! (numerator and determinant of `t`, triangle). The host finishes each hit
//! exactly as the CPU backend does (`t = num / det`, the `[tmin, tmax]` test,
//! facing, patch, sorting and merging), so the two backends agree wherever
//! the device's f32 products and sums round as the CPU's do. A line with more
//! than [`MAX_HITS`] crossings is retraced on the host (counted in
//! [`VulkanTracer::host_retraced`]).
//!
//! The kernel is brute force, `O(lines × triangles)`: exact and simple, and
//! fast on a GPU for scenes of up to a few thousand triangles. A BVH kernel is
//! the next step for large meshes.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec3, Vec3A};

use super::{Buffer, Gpu, Kernel};
use crate::lines::Line;
use crate::tracer::{
    BackendError, Crossing, CrossingBuffer, Prepared, Shear, Tracer, finish, sphere_crossings, test_triangle,
};

/// Raw hits kept per line on the device.
pub const MAX_HITS: usize = 16;
/// Lines per dispatch.
const CHUNK: usize = 65_536;
const SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.spv"));

struct Staging {
    lines: Buffer,
    counts: Buffer,
    hits: Buffer,
}

/// The Vulkan tracing backend. Fields drop in order: buffers and kernel
/// before the device.
pub struct VulkanTracer {
    staging: Mutex<Staging>,
    kernel: Kernel,
    triangles: Buffer,
    scene: Prepared,
    retraced: AtomicU64,
    gpu: Gpu,
}

impl VulkanTracer {
    /// Opens the preferred device and uploads the scene.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix when Vulkan is missing.
    pub fn new(scene: &Prepared) -> Result<Self, BackendError> {
        let gpu = Gpu::open()?;
        let kernel = gpu.kernel(SPIRV, c"trace", 4, 16)?;
        let n = scene.triangles.len();
        let mut triangles = gpu.buffer((n * 48) as u64)?;
        let words: Vec<u32> = scene
            .triangles
            .iter()
            .flat_map(|t| t.iter().flat_map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), 0]))
            .collect();
        triangles.write_words(0, &words);
        let staging = Staging {
            lines: gpu.buffer((CHUNK * 48) as u64)?,
            counts: gpu.buffer((CHUNK * 4) as u64)?,
            hits: gpu.buffer((CHUNK * MAX_HITS * 16) as u64)?,
        };
        Ok(Self {
            staging: Mutex::new(staging),
            kernel,
            triangles,
            scene: scene.clone(),
            retraced: AtomicU64::new(0),
            gpu,
        })
    }

    /// The device in use.
    #[must_use]
    pub fn device(&self) -> &super::DeviceInfo {
        &self.gpu.info
    }

    /// Lines retraced on the host because they had more than [`MAX_HITS`] crossings.
    #[must_use]
    pub fn host_retraced(&self) -> u64 {
        self.retraced.load(Ordering::Relaxed)
    }

    fn trace_chunk(&self, st: &mut Staging, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        let mut words = Vec::with_capacity(lines.len() * 12);
        let mut shears = Vec::with_capacity(lines.len());
        for l in lines {
            let org = Vec3A::from(Vec3::from(l.origin));
            let dir = Vec3A::from(Vec3::from(l.direction));
            let sh = Shear::new(org, dir);
            let k = (sh.k[0] | sh.k[1] << 2 | sh.k[2] << 4) as u32;
            words.extend([l.origin[0].to_bits(), l.origin[1].to_bits(), l.origin[2].to_bits(), l.tmin.to_bits()]);
            words.extend([sh.s[0].to_bits(), sh.s[1].to_bits(), sh.s[2].to_bits(), l.tmax.to_bits()]);
            words.extend([k, 0, 0, 0]);
            shears.push((sh, dir));
        }
        st.lines.write_words(0, &words);
        let push: Vec<u8> = [lines.len() as u32, self.scene.triangles.len() as u32, MAX_HITS as u32, 0]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect();
        let groups = lines.len().div_ceil(64) as u32;
        self.gpu.dispatch(&self.kernel, &[&self.triangles, &st.lines, &st.counts, &st.hits], &push, groups)?;
        let mut hits = Vec::with_capacity(MAX_HITS);
        for (i, l) in lines.iter().enumerate() {
            let n = st.counts.word(i) as usize;
            let (sh, dir) = &shears[i];
            if n > MAX_HITS {
                self.retraced.fetch_add(1, Ordering::Relaxed);
                for tri in 0..self.scene.triangles.len() {
                    test_triangle(&self.scene, sh, l, *dir, tri, &mut hits);
                }
            } else {
                for j in 0..n {
                    let base = 4 * (i * MAX_HITS + j);
                    let num = f32::from_bits(st.hits.word(base));
                    let det = f32::from_bits(st.hits.word(base + 1));
                    let tri = st.hits.word(base + 2) as usize;
                    let t = num / det;
                    if t >= l.tmin && t <= l.tmax {
                        let cos = self.scene.normals[tri].dot(*dir);
                        hits.push(Crossing { t, patch: self.scene.triangle_patch[tri], cos, primitive: tri as u32 });
                    }
                }
            }
            finish(&mut hits, out);
        }
        Ok(())
    }
}

impl Tracer for VulkanTracer {
    fn name(&self) -> &'static str {
        "vulkan"
    }

    fn trace_all(&self, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        out.clear();
        if self.scene.triangles.is_empty() {
            // The analytic sphere (or an empty scene): crossings in closed form on the host.
            let mut hits = Vec::new();
            for l in lines {
                if let Some(s) = &self.scene.sphere {
                    sphere_crossings(s, l, &mut hits);
                }
                finish(&mut hits, out);
            }
            return Ok(());
        }
        let mut st = self.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        for chunk in lines.chunks(CHUNK) {
            self.trace_chunk(&mut st, chunk, out)?;
        }
        Ok(())
    }
}
