//! [`VulkanVolumeCaster`]: the volume-casting seam
//! ([`crate::volume::cast::VolumeCaster`]) on a Vulkan device.
//!
//! The kernel (`shaders/volume.wgsl`) runs one invocation per pixel ray and
//! marches it exactly as [`Caster`] does, in f64 and in the same order of
//! operations (grid point, cell test, trilinear value, opacity lookup,
//! transmittance), writing each sample of positive opacity as its grid point
//! and contribution `T·α`. The host computes the rays (camera, box span) with
//! the CPU's code before the dispatch, and afterwards shares every sample's
//! contribution among its eight voxels in ray order with the CPU's code, so
//! each sum sees the same terms in the same order: the rows are the CPU
//! backend's bit for bit wherever the device's f64 `+ − × ÷` round as IEEE
//! says and are not fused (lavapipe: tested). Sums are not done with float
//! atomics on the device, which would make the order, and so the last bits,
//! depend on scheduling.
//!
//! A ray keeps at most `k` samples on the device (`k` up to 256, so a chunk
//! of rays fits one storage buffer); a ray with more stops at its `(k+1)`-th
//! sample and the host marches the rest from there with the CPU's code
//! ([`VulkanVolumeCaster::host_resumed`] counts them). Rays go to the device
//! in chunks, each viewpoint in flight with its own staging buffers
//! (at most one per worker thread), so memory is bounded before the first
//! allocation ([`device_memory`]).

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use super::{Buffer, DeviceInfo, Gpu, Kernel, Use};
use crate::backend::BackendError;
use crate::camera::Camera;
use crate::volume::cast::VolumeCaster;
use crate::volume::raycast::{Caster, EARLY_TERMINATION, pixel_ray};

const SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/volume.spv"));
/// Samples kept per ray on the device, at most.
pub const MAX_SAMPLES: usize = 256;
/// Bytes of samples per chunk of rays: 1024 rays of 256 samples. Small
/// enough that a 256³ volume at 162 viewpoints (a 5.8 GiB channel) stays
/// under the CLI's 6 GiB limit with two streams on lavapipe, whose device
/// memory is the host's; a discrete GPU would want larger chunks.
const SAMPLE_BYTES: usize = 8 << 20;
/// The driver's own memory, counted with the buffers: lavapipe's is about
/// 66 MiB (`itgfx volume cube:8 --viewpoints 12` peaks at 77 MB of RSS on
/// Vulkan, of which 2 MiB are buffers, and at 7.5 MB on the CPU).
const DRIVER_BYTES: u64 = 72 << 20;
/// Rays per chunk, at most.
const MAX_CHUNK: usize = 1 << 16;
/// Where the opacity table starts in the constants buffer.
const TABLE_AT: usize = 16;
/// Bytes of a sample (grid point, contribution) and of a ray's words:
/// direction, first `t`, exit `t` in; transmittance, `t`, count out.
const SAMPLE: usize = 32;
const RAY: usize = 40 + 16 + 4;

/// Samples kept per ray and rays per chunk for `caster`: `k` covers the
/// longest ray through the box (its diagonal, 2 normalised units, over the
/// step) up to [`MAX_SAMPLES`]; the chunk holds `k` samples per ray in
/// [`SAMPLE_BYTES`].
fn layout(caster: &Caster<'_>, k: Option<usize>) -> (usize, usize) {
    let longest = (2.0 / caster.step()).ceil() as usize + 1;
    let k = k.unwrap_or_else(|| longest.min(MAX_SAMPLES)).max(1);
    let chunk = (SAMPLE_BYTES / (SAMPLE * k)).clamp(64, MAX_CHUNK) / 64 * 64;
    (k, chunk)
}

/// The device buffers for the volume: constants (with the opacity table),
/// voxels (f32) and the active-cell bits.
fn volume_bytes(caster: &Caster<'_>) -> [u64; 3] {
    let voxels = caster.volume.voxels() as u64;
    [(TABLE_AT as u64 + caster.opacity_table().0.len() as u64) * 8, voxels * 4, voxels.div_ceil(32) * 4]
}

/// Bytes [`VulkanVolumeCaster::new`] and its casts allocate at most with
/// `streams` viewpoints of `rays` rays in flight (one staging set each): the
/// volume's buffers and per stream the rays, their state and `k` samples per
/// ray for one chunk, plus the host's copy of a chunk's directions, and the
/// driver's own (`DRIVER_BYTES`). On lavapipe the device's memory is the
/// host's.
#[must_use]
pub fn device_memory(caster: &Caster<'_>, streams: usize, rays: u64) -> u64 {
    let (k, chunk) = layout(caster, None);
    let chunk = chunk.min(rays.div_ceil(64) as usize * 64);
    let per_stream = (32 + chunk * (k * SAMPLE + RAY + 32)) as u64;
    DRIVER_BYTES + volume_bytes(caster).iter().sum::<u64>() + streams.max(1) as u64 * per_stream
}

/// One viewpoint's buffers for a chunk of `capacity` rays.
struct Staging {
    capacity: usize,
    rays: Buffer,
    samples: Buffer,
    state: Buffer,
    counts: Buffer,
}

/// The Vulkan volume caster. Fields drop in order: buffers and kernel
/// before the device.
pub struct VulkanVolumeCaster<'a> {
    caster: &'a Caster<'a>,
    staging: Mutex<Vec<Staging>>,
    kernel: Kernel,
    consts: Buffer,
    data: Buffer,
    active: Buffer,
    k: usize,
    chunk: usize,
    resumed: AtomicU64,
    gpu: Gpu,
}

impl<'a> VulkanVolumeCaster<'a> {
    /// Opens the preferred device and uploads the volume, its active cells
    /// and the opacity table.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix when Vulkan is missing;
    /// [`BackendError::TooLarge`] when the voxels exceed one storage buffer
    /// or [`device_memory`] the device's heap.
    pub fn new(caster: &'a Caster<'a>) -> Result<Self, BackendError> {
        Self::with_samples(caster, None)
    }

    /// [`VulkanVolumeCaster::new`] keeping at most `k` samples per ray on the
    /// device (tests use a small `k` to make the host finish rays).
    ///
    /// # Errors
    /// As [`VulkanVolumeCaster::new`].
    pub fn with_samples(caster: &'a Caster<'a>, k: Option<usize>) -> Result<Self, BackendError> {
        let gpu = Gpu::open()?;
        let need = device_memory(caster, rayon::current_num_threads(), MAX_CHUNK as u64);
        if need > gpu.info.heap_bytes {
            return Err(BackendError::TooLarge {
                backend: "vulkan",
                reason: format!(
                    "the volume caster needs {} MiB of device memory, the device has {} MiB; the cpu backend has no such limit",
                    need >> 20,
                    gpu.info.heap_bytes >> 20
                ),
            });
        }
        let [consts_bytes, data_bytes, active_bytes] = volume_bytes(caster);
        if data_bytes > u64::from(gpu.info.max_storage_buffer_range) {
            return Err(BackendError::TooLarge {
                backend: "vulkan",
                reason: format!(
                    "{} voxels take {} MiB as f32, over this device's storage-buffer limit of {} MiB; the cpu backend has no such limit",
                    caster.volume.voxels(),
                    data_bytes >> 20,
                    gpu.info.max_storage_buffer_range >> 20
                ),
            });
        }
        let (k, chunk) = layout(caster, k);
        let kernel = gpu.kernel(SPIRV, c"march", 7, 32)?;
        let v = caster.volume;
        let (table, lo, inv_range, skip_below) = caster.opacity_table();
        let s = v.scale();
        let mut consts = vec![0.0f64; TABLE_AT];
        // As Volume::grid_coords computes them: s · spacing and dims · 0.5.
        for a in 0..3 {
            consts[3 + a] = s * v.spacing[a];
            consts[6 + a] = v.dims[a] as f64 * 0.5;
        }
        consts[9..14].copy_from_slice(&[lo, inv_range, skip_below, caster.step(), EARLY_TERMINATION]);
        consts.extend(table);
        let mut consts_buf = gpu.buffer_for(consts_bytes, Use::Resident)?;
        write_f64s(&mut consts_buf, 0, &consts);
        let mut data = gpu.buffer_for(data_bytes, Use::Resident)?;
        data.write_words(0, v.data.iter().map(|x| x.to_bits()));
        let mut bits = vec![0u32; v.voxels().div_ceil(32)];
        for (c, _) in caster.active_cells().iter().enumerate().filter(|(_, a)| **a) {
            bits[c / 32] |= 1 << (c % 32);
        }
        let mut active = gpu.buffer_for(active_bytes, Use::Resident)?;
        active.write_words(0, bits);
        Ok(Self {
            caster,
            staging: Mutex::new(Vec::new()),
            kernel,
            consts: consts_buf,
            data,
            active,
            k,
            chunk,
            resumed: AtomicU64::new(0),
            gpu,
        })
    }

    /// The device in use.
    #[must_use]
    pub fn device(&self) -> &DeviceInfo {
        &self.gpu.info
    }

    /// Rays the host finished because they had more than `k` samples.
    #[must_use]
    pub fn host_resumed(&self) -> u64 {
        self.resumed.load(Ordering::Relaxed)
    }

    /// Buffers for chunks of up to `rays` rays (at most the layout's chunk):
    /// a free set if one is large enough, else a new one.
    fn take_staging(&self, rays: usize) -> Result<Staging, BackendError> {
        let want = self.chunk.min(rays.div_ceil(64) * 64);
        let free = self.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
        match free {
            Some(s) if s.capacity >= want => Ok(s),
            _ => Ok(Staging {
                capacity: want,
                rays: self.gpu.buffer((32 + want * 40) as u64)?,
                samples: self.gpu.buffer_for((want * self.k * SAMPLE) as u64, Use::Readback)?,
                state: self.gpu.buffer_for((want * 16) as u64, Use::Readback)?,
                counts: self.gpu.buffer_for((want * 4) as u64, Use::Readback)?,
            }),
        }
    }

    /// Casts rays `range` of `view`'s `size²`, adds their
    /// samples to `add` and their transmittance left to `background`, in ray
    /// order (one running sum, as the CPU's).
    fn chunk(
        &self,
        st: &mut Staging,
        view: &Camera,
        size: u32,
        range: std::ops::Range<u32>,
        add: &mut impl FnMut(usize, f64),
        background: &mut f64,
    ) -> Result<(), BackendError> {
        let c = self.caster;
        let n = range.len() as u32;
        let mut rays = Vec::with_capacity(4 + n as usize * 5);
        rays.extend([view.eye.x, view.eye.y, view.eye.z, 0.0]);
        let mut dirs = Vec::with_capacity(n as usize);
        for r in range {
            let d = pixel_ray(view, r % size, r / size, size);
            // A ray that misses the box gets an empty span: no samples, T = 1.
            let (t, t1) = c.clip(view.eye, d).map_or((1.0, 0.0), |(t0, t1)| (c.first_sample(t0), t1));
            rays.extend([d.x, d.y, d.z, t, t1]);
            dirs.push((d, t1));
        }
        write_f64s(&mut st.rays, 0, &rays);
        let push: Vec<u8> = [n, self.k as u32, 0, 0, 0, 0, 0, 0]
            .iter()
            .enumerate()
            .map(|(i, &w)| if (2..5).contains(&i) { c.volume.dims[i - 2] as u32 } else { w })
            .flat_map(u32::to_le_bytes)
            .collect();
        let read = [&self.consts, &self.data, &self.active, &st.rays];
        let write = &mut [&mut st.samples, &mut st.state, &mut st.counts];
        self.gpu.dispatch(&self.kernel, &read, write, &push, n.div_ceil(64))?;
        let (samples, state) = (st.samples.bytes(), st.state.bytes());
        for (j, &(d, t1)) in dirs.iter().enumerate() {
            let word = st.counts.word(j);
            let count = (word & 0x7fff_ffff) as usize;
            for s in 0..count.min(self.k) {
                let at = 4 * (j * self.k + s);
                let g = DVec3::new(f64_at(samples, at), f64_at(samples, at + 1), f64_at(samples, at + 2));
                c.deposit(g, f64_at(samples, at + 3), &mut *add);
            }
            let transmittance = f64_at(state, 2 * j);
            *background += if word & 0x8000_0000 == 0 {
                transmittance
            } else {
                // Out of room on the device: the host marches the rest.
                self.resumed.fetch_add(1, Ordering::Relaxed);
                c.march_from(view.eye, d, f64_at(state, 2 * j + 1), t1, transmittance, |corners, x, _, _| {
                    for &(i, w) in corners {
                        add(i, x * w);
                    }
                })
            };
        }
        Ok(())
    }
}

impl VolumeCaster for VulkanVolumeCaster<'_> {
    fn name(&self) -> &'static str {
        "vulkan"
    }

    fn caster(&self) -> &Caster<'_> {
        self.caster
    }

    fn rays_finished_on_host(&self) -> u64 {
        self.host_resumed()
    }

    fn visibility_row(&self, view: &Camera, size: u32, slot: &[u32], row: &mut [f64]) -> Result<f64, BackendError> {
        let total = size * size;
        let mut st = self.take_staging(total as usize)?;
        let mut add = |z: usize, x: f64| row[slot[z] as usize] += x;
        let mut background = 0.0;
        let mut first = 0;
        let result = loop {
            if first >= total {
                break Ok(background);
            }
            let n = (total - first).min(st.capacity as u32);
            if let Err(e) = self.chunk(&mut st, view, size, first..first + n, &mut add, &mut background) {
                break Err(e);
            }
            first += n;
        };
        self.staging.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(st);
        result
    }
}

/// Writes f64 values from value `offset` on.
fn write_f64s(b: &mut Buffer, offset: usize, values: &[f64]) {
    let dst = &mut b.bytes_mut()[8 * offset..8 * (offset + values.len())];
    for (d, v) in dst.chunks_exact_mut(8).zip(values) {
        d.copy_from_slice(&v.to_le_bytes());
    }
}

/// Value `i` of mapped f64s.
fn f64_at(bytes: &[u8], i: usize) -> f64 {
    let mut w = [0u8; 8];
    w.copy_from_slice(&bytes[8 * i..8 * i + 8]);
    f64::from_le_bytes(w)
}
