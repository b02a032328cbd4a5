//! [`VulkanTracer`]: the tracing seam on a Vulkan device.
//!
//! The kernel (`shaders/trace.wgsl`) walks a BVH2 that obvhs builds on the
//! host over the same padded triangle boxes as the CPU backend's BVH (a
//! loosened slab test, so it can only add candidates), and tests each
//! candidate with the CPU backend's watertight test, taking the per-line
//! shear constants from the host. It returns up to [`MAX_HITS`] raw hits per
//! line (numerator and determinant of `t`, triangle). The host finishes each
//! hit exactly as the CPU backend does (`t = num / det`, the `[tmin, tmax]`
//! test, facing, patch, sorting and merging). Every float operation of the
//! kernel is marked `NoContraction` (`build.rs`), so the device rounds each
//! product and sum as the CPU does, and the device's choice of the closest
//! hit divides with the CPU's correctly rounded f32 division (`div_rn`):
//! the two backends agree bit for bit on lavapipe and on an NVIDIA H200
//! (docs/VULKAN.md, *On a real GPU*). A line
//! with more than [`MAX_HITS`] crossings, or whose traversal overflows the
//! kernel's 64-entry stack, is retraced by the CPU backend (counted in
//! [`VulkanTracer::host_retraced`]).
//!
//! Closest-hit queries run the same kernel in its mode 1: the device keeps
//! the crossing with the smallest `t` (ties to the smaller triangle, the
//! host's order) and shrinks the interval it searches; the host recomputes
//! that triangle's hit with the CPU's arithmetic (`t`, barycentrics,
//! normal). Occlusion is a closest-hit query: exact, and the device's early
//! exit would save little on a GPU where a warp waits for its slowest line.
//! Design notes: `docs/VULKAN.md`.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec3, Vec3A};

use super::{Buffer, Gpu, Kernel, Use};
use crate::lines::Line;
use crate::tracer::watertight::{Shear, finish, sphere_crossings, sphere_hit, triangle_hit};
use crate::tracer::{BackendError, CpuTracer, Crossing, CrossingBuffer, Hit, Prepared, Tracer, bvh_input};

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
    nodes: Buffer,
    triangles: Buffer,
    prims: Buffer,
    scene: Prepared,
    /// Built on first need (a line with too many crossings).
    fallback: std::sync::OnceLock<CpuTracer>,
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
        let kernel = gpu.kernel(SPIRV, c"trace", 6, 16)?;
        let (mut node_words, mut tri_words, mut prim_words) = (Vec::new(), Vec::new(), Vec::new());
        if !scene.triangles.is_empty() {
            let (aabbs, params) = bvh_input(scene);
            let bvh = obvhs::bvh2::builder::build_bvh2(&aabbs, params, &mut std::time::Duration::default());
            for n in &bvh.nodes {
                let (lo, hi) = (n.aabb.min, n.aabb.max);
                node_words.extend([lo.x.to_bits(), lo.y.to_bits(), lo.z.to_bits(), n.prim_count]);
                node_words.extend([hi.x.to_bits(), hi.y.to_bits(), hi.z.to_bits(), n.first_index]);
            }
            for &p in &bvh.primitive_indices {
                for v in &scene.triangles[p as usize] {
                    tri_words.extend([v.x.to_bits(), v.y.to_bits(), v.z.to_bits(), 0]);
                }
                prim_words.push(p);
            }
        }
        let upload = |words: &[u32]| -> Result<Buffer, BackendError> {
            let mut b = gpu.buffer_for(4 * words.len() as u64, Use::Resident)?;
            b.write_words(0, words.iter().copied());
            Ok(b)
        };
        let (nodes, triangles, prims) = (upload(&node_words)?, upload(&tri_words)?, upload(&prim_words)?);
        let staging = Staging {
            lines: gpu.buffer((CHUNK * 48) as u64)?,
            counts: gpu.buffer_for((CHUNK * 4) as u64, Use::Readback)?,
            hits: gpu.buffer_for((CHUNK * MAX_HITS * 16) as u64, Use::Readback)?,
        };
        Ok(Self {
            staging: Mutex::new(staging),
            kernel,
            nodes,
            triangles,
            prims,
            scene: scene.clone(),
            fallback: std::sync::OnceLock::new(),
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

    /// Uploads a chunk of lines and runs the kernel in `mode` (0: every
    /// crossing, 1: the closest); returns each line's direction.
    fn dispatch(&self, st: &mut Staging, lines: &[Line], mode: u32) -> Result<Vec<Vec3A>, BackendError> {
        let mut words = Vec::with_capacity(lines.len() * 12);
        let mut dirs = Vec::with_capacity(lines.len());
        for l in lines {
            let org = Vec3A::from(Vec3::from(l.origin));
            let dir = Vec3A::from(Vec3::from(l.direction));
            let sh = Shear::new(org, dir);
            let k = (sh.k[0] | sh.k[1] << 2 | sh.k[2] << 4) as u32;
            words.extend([l.origin[0].to_bits(), l.origin[1].to_bits(), l.origin[2].to_bits(), l.tmin.to_bits()]);
            words.extend([sh.s[0].to_bits(), sh.s[1].to_bits(), sh.s[2].to_bits(), l.tmax.to_bits()]);
            // 1/d for the slab test; a zero component gets a large finite
            // stand-in so that 0 · ∞ never makes a NaN.
            let inv = |d: f32| if d == 0.0 { 1e30 } else { 1.0 / d };
            words.extend([k, inv(dir.x).to_bits(), inv(dir.y).to_bits(), inv(dir.z).to_bits()]);
            dirs.push(dir);
        }
        st.lines.write_words(0, words);
        let push: Vec<u8> =
            [lines.len() as u32, MAX_HITS as u32, mode, 0].iter().flat_map(|w| w.to_le_bytes()).collect();
        let groups = lines.len().div_ceil(64) as u32;
        let read = [&self.nodes, &self.triangles, &self.prims, &st.lines];
        self.gpu.dispatch(&self.kernel, &read, &mut [&mut st.counts, &mut st.hits], &push, groups)?;
        Ok(dirs)
    }

    /// The CPU backend, built on first need.
    fn fallback(&self) -> &CpuTracer {
        self.retraced.fetch_add(1, Ordering::Relaxed);
        self.fallback.get_or_init(|| CpuTracer::new(&self.scene))
    }

    fn trace_chunk(&self, st: &mut Staging, lines: &[Line], out: &mut CrossingBuffer) -> Result<(), BackendError> {
        let dirs = self.dispatch(st, lines, 0)?;
        let mut hits = Vec::with_capacity(MAX_HITS);
        for (i, l) in lines.iter().enumerate() {
            let n = st.counts.word(i) as usize;
            let dir = &dirs[i];
            if n > MAX_HITS {
                // Too many crossings for the device's slots, or a stack overflow.
                let mut one = CrossingBuffer::default();
                self.fallback().trace_all(std::slice::from_ref(l), &mut one)?;
                hits.extend_from_slice(one.line(0));
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

    fn closest_chunk(&self, st: &mut Staging, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        self.dispatch(st, lines, 1)?;
        for (i, l) in lines.iter().enumerate() {
            let hit = match st.counts.word(i) {
                0 => None,
                1 => {
                    let tri = st.hits.word(4 * i * MAX_HITS + 2);
                    match triangle_hit(&self.scene, l, tri) {
                        Some(h) => Some(h),
                        // The device's division rounded differently: ask the host.
                        None => self.fallback().closest(l),
                    }
                }
                // The traversal stack overflowed.
                _ => self.fallback().closest(l),
            };
            out.push(hit);
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

    fn closest_hit(&self, lines: &[Line], out: &mut Vec<Option<Hit>>) -> Result<(), BackendError> {
        out.clear();
        if self.scene.triangles.is_empty() {
            out.extend(lines.iter().map(|l| self.scene.sphere.as_ref().and_then(|s| sphere_hit(s, l))));
            return Ok(());
        }
        let mut st = self.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        for chunk in lines.chunks(CHUNK) {
            self.closest_chunk(&mut st, chunk, out)?;
        }
        Ok(())
    }

    fn occluded(&self, lines: &[Line], out: &mut Vec<bool>) -> Result<(), BackendError> {
        let mut hits = Vec::with_capacity(lines.len());
        self.closest_hit(lines, &mut hits)?;
        out.clear();
        out.extend(hits.iter().map(Option::is_some));
        Ok(())
    }
}
