//! The Vulkan compute backend (ash, loaded at run time): device discovery,
//! one compute queue, host-visible buffers and WGSL kernels compiled to
//! SPIR-V at build time by naga (`build.rs`).
//!
//! `libvulkan.so.1` is opened when a Vulkan path is first used, so the binary
//! starts without it; its absence, a loader without a driver and a driver
//! without a device all become [`BackendError::Unavailable`] with the fix.
//! `ITGFX_VULKAN_LIBRARY` names another loader (tests hide the real one with it).
//!
//! * [`tracer`]: [`tracer::VulkanTracer`], the tracing seam on the GPU.
//! * [`reduce`]: entropy of large weight arrays with f64 accumulation.
//! * [`volume`]: [`volume::VulkanVolumeCaster`], volume ray casting on the GPU.

#[cfg(test)]
mod no_contraction;
pub mod reduce;
pub mod tracer;
pub mod volume;

use std::ffi::CStr;
use std::sync::{Arc, Mutex};

use ash::vk;

use crate::backend::BackendError;

/// What `itgfx devices` prints for one physical device.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    /// `deviceName`.
    pub name: String,
    /// discrete, integrated, virtual, cpu or other.
    pub kind: &'static str,
    /// Vulkan API version, `major.minor.patch`.
    pub api_version: String,
    /// Largest storage buffer binding, bytes.
    pub max_storage_buffer_range: u32,
    /// Invocations per workgroup.
    pub max_workgroup_invocations: u32,
    /// Shared memory per workgroup, bytes.
    pub max_shared_memory: u32,
    /// 64-bit floats in shaders (needed: f64 accumulation and the exact edge test).
    pub float64: bool,
    /// Size of the largest device-local heap, bytes.
    pub heap_bytes: u64,
}

const FIX: &str = "install Mesa's Vulkan drivers (apt-get install mesa-vulkan-drivers libvulkan1) or a GPU driver, or use the cpu backend";

fn unavailable(reason: impl Into<String>) -> BackendError {
    BackendError::Unavailable { backend: "vulkan", reason: reason.into() }
}

fn vk_err(what: &str, e: vk::Result) -> BackendError {
    match e {
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => BackendError::OutOfMemory,
        vk::Result::ERROR_DEVICE_LOST => BackendError::DeviceLost,
        other => unavailable(format!("{what} failed: {other}")),
    }
}

fn load_entry() -> Result<ash::Entry, BackendError> {
    let entry = match std::env::var_os("ITGFX_VULKAN_LIBRARY") {
        // SAFETY: loading a Vulkan loader runs its initialisers; it is the
        // documented way to use ash's `loaded` feature, and the library named
        // by ITGFX_VULKAN_LIBRARY is trusted as the system loader is.
        Some(path) => unsafe { ash::Entry::load_from(path) },
        // SAFETY: as above, for the system's `libvulkan.so.1`.
        None => unsafe { ash::Entry::load() },
    };
    entry.map_err(|e| unavailable(format!("no Vulkan loader ({e}); {FIX}")))
}

fn create_instance(entry: &ash::Entry) -> Result<ash::Instance, BackendError> {
    let app = vk::ApplicationInfo::default()
        .application_name(c"itgfx")
        .engine_name(c"itgfx")
        .api_version(vk::make_api_version(0, 1, 2, 0));
    let info = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: valid create info; the instance is destroyed in `Drop`.
    unsafe { entry.create_instance(&info, None) }.map_err(|e| match e {
        vk::Result::ERROR_INCOMPATIBLE_DRIVER => unavailable(format!("a Vulkan loader but no driver; {FIX}")),
        other => vk_err("vkCreateInstance", other),
    })
}

fn physical_devices(instance: &ash::Instance) -> Result<Vec<vk::PhysicalDevice>, BackendError> {
    // SAFETY: the instance is live.
    match unsafe { instance.enumerate_physical_devices() } {
        Ok(d) if !d.is_empty() => Ok(d),
        // Lavapipe-less driver files give ERROR_INITIALIZATION_FAILED, not an empty list.
        Ok(_) | Err(vk::Result::ERROR_INITIALIZATION_FAILED) => Err(unavailable(format!("no Vulkan device; {FIX}"))),
        Err(e) => Err(vk_err("vkEnumeratePhysicalDevices", e)),
    }
}

fn describe(instance: &ash::Instance, pd: vk::PhysicalDevice) -> DeviceInfo {
    // SAFETY: `pd` comes from this instance.
    let (props, features, mem) = unsafe {
        (
            instance.get_physical_device_properties(pd),
            instance.get_physical_device_features(pd),
            instance.get_physical_device_memory_properties(pd),
        )
    };
    let name = props.device_name_as_c_str().map_or_else(|_| "?".into(), |c| c.to_string_lossy().into_owned());
    let kind = match props.device_type {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual",
        vk::PhysicalDeviceType::CPU => "cpu",
        _ => "other",
    };
    let v = props.api_version;
    let heap_bytes = mem.memory_heaps[..mem.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    DeviceInfo {
        name,
        kind,
        api_version: format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v)),
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        max_workgroup_invocations: props.limits.max_compute_work_group_invocations,
        max_shared_memory: props.limits.max_compute_shared_memory_size,
        float64: features.shader_float64 == vk::TRUE,
        heap_bytes,
    }
}

/// Preference among usable devices: discrete, integrated, virtual, CPU.
fn rank(kind: &str) -> u32 {
    match kind {
        "discrete" => 0,
        "integrated" => 1,
        "virtual" => 2,
        "cpu" => 3,
        _ => 4,
    }
}

/// Every Vulkan device, and the index of the one `Gpu::open` would use
/// (the most capable kind with 64-bit float support and a compute queue).
///
/// # Errors
/// [`BackendError::Unavailable`] with the fix when there is no loader,
/// driver or device.
pub fn devices() -> Result<(Vec<DeviceInfo>, Option<usize>), BackendError> {
    let entry = load_entry()?;
    let instance = create_instance(&entry)?;
    let result = physical_devices(&instance).map(|pds| {
        let infos: Vec<DeviceInfo> = pds.iter().map(|&pd| describe(&instance, pd)).collect();
        let chosen = choose(&instance, &pds, &infos).map(|(i, _)| i);
        (infos, chosen)
    });
    // SAFETY: nothing created from the instance outlives this call.
    unsafe { instance.destroy_instance(None) };
    result
}

fn choose(instance: &ash::Instance, pds: &[vk::PhysicalDevice], infos: &[DeviceInfo]) -> Option<(usize, u32)> {
    (0..pds.len())
        .filter(|&i| infos[i].float64)
        .filter_map(|i| compute_queue(instance, pds[i]).map(|q| (i, q)))
        .min_by_key(|&(i, _)| (rank(infos[i].kind), i))
}

fn compute_queue(instance: &ash::Instance, pd: vk::PhysicalDevice) -> Option<u32> {
    // SAFETY: `pd` comes from this instance.
    let fams = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    fams.iter().position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE)).map(|i| i as u32)
}

/// The loader, instance and logical device. Every [`Gpu`], [`Buffer`] and
/// [`Kernel`] holds it by `Arc`, so the device outlives whatever was made
/// from it, whatever order safe code drops them in.
struct Device {
    _entry: ash::Entry,
    instance: ash::Instance,
    device: ash::Device,
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: this is the last handle: every buffer, kernel and command
        // pool made from the device held this `Arc` and has been dropped.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            self.instance.destroy_instance(None);
        }
    }
}

/// An open device with one compute queue; every submission is serialised.
pub(crate) struct Gpu {
    shared: Arc<Device>,
    queue: Mutex<vk::Queue>,
    pool: Mutex<vk::CommandPool>,
    memory: vk::PhysicalDeviceMemoryProperties,
    /// The device in use.
    pub info: DeviceInfo,
}

impl Gpu {
    /// Opens the preferred device.
    ///
    /// # Errors
    /// [`BackendError::Unavailable`] with the fix; device errors.
    pub fn open() -> Result<Self, BackendError> {
        let entry = load_entry()?;
        let instance = create_instance(&entry)?;
        match Self::open_on(entry, &instance) {
            Ok(g) => Ok(g),
            Err(Failed::BeforeDevice(e)) => {
                // SAFETY: nothing was created from the instance.
                unsafe { instance.destroy_instance(None) };
                Err(e)
            }
            Err(Failed::AfterDevice(e)) => Err(e),
        }
    }

    fn open_on(entry: ash::Entry, instance: &ash::Instance) -> Result<Self, Failed> {
        let pds = physical_devices(instance).map_err(Failed::BeforeDevice)?;
        let infos: Vec<DeviceInfo> = pds.iter().map(|&pd| describe(instance, pd)).collect();
        let (i, family) = choose(instance, &pds, &infos).ok_or_else(|| {
            Failed::BeforeDevice(unavailable(format!("no Vulkan device with 64-bit float shaders and compute; {FIX}")))
        })?;
        let pd = pds[i];
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default().queue_family_index(family).queue_priorities(&priorities)];
        let features = vk::PhysicalDeviceFeatures::default().shader_float64(true);
        let info = vk::DeviceCreateInfo::default().queue_create_infos(&queues).enabled_features(&features);
        // SAFETY: valid create info for a device of this instance.
        let device = unsafe { instance.create_device(pd, &info, None) }
            .map_err(|e| Failed::BeforeDevice(vk_err("vkCreateDevice", e)))?;
        // SAFETY: the family and index exist (created above).
        let queue = unsafe { device.get_device_queue(family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // From here on the device is destroyed with its last handle; the
        // caller destroys the instance only when this function fails before.
        let shared = Arc::new(Device { _entry: entry, instance: instance.clone(), device });
        // SAFETY: the device is live.
        let pool = unsafe { shared.device.create_command_pool(&pool_info, None) }
            .map_err(|e| vk_err("vkCreateCommandPool", e));
        let pool = match pool {
            Ok(p) => p,
            Err(e) => {
                // Dropping `shared` destroys the device and the instance.
                drop(shared);
                return Err(Failed::AfterDevice(e));
            }
        };
        // SAFETY: `pd` comes from this instance.
        let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
        Ok(Self { shared, queue: Mutex::new(queue), pool: Mutex::new(pool), memory, info: infos[i].clone() })
    }

    /// A host-visible, coherent storage buffer of `bytes`, mapped, for data
    /// the host writes before each dispatch ([`Use::Stream`]).
    ///
    /// # Errors
    /// Allocation failures.
    pub fn buffer(&self, bytes: u64) -> Result<Buffer, BackendError> {
        self.buffer_for(bytes, Use::Stream)
    }

    /// A mapped storage buffer of `bytes` in the memory that suits `usage`:
    /// each preference of [`Use::memory_preferences`] in turn, the next one
    /// where a device has no such memory type or its heap is full.
    ///
    /// # Errors
    /// Allocation failures.
    pub fn buffer_for(&self, bytes: u64, usage: Use) -> Result<Buffer, BackendError> {
        let bytes = bytes.max(16);
        if bytes > u64::from(self.info.max_storage_buffer_range) {
            return Err(BackendError::TooLarge {
                backend: "vulkan",
                reason: format!(
                    "a {bytes}-byte buffer exceeds this device's storage-buffer limit of {} bytes (at 48 bytes a triangle, about 2.8 million triangles on lavapipe); the cpu backend has no such limit",
                    self.info.max_storage_buffer_range
                ),
            });
        }
        let d = &self.shared.device;
        let info = vk::BufferCreateInfo::default()
            .size(bytes)
            .usage(vk::BufferUsageFlags::STORAGE_BUFFER)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info; freed in `Buffer::drop` (or below on failure).
        unsafe {
            let buffer = d.create_buffer(&info, None).map_err(|e| vk_err("vkCreateBuffer", e))?;
            let req = d.get_buffer_memory_requirements(buffer);
            let types = usage.memory_preferences().iter().filter_map(|&want| {
                (0..self.memory.memory_type_count).find(|&t| {
                    req.memory_type_bits & (1 << t) != 0
                        && self.memory.memory_types[t as usize].property_flags.contains(want)
                })
            });
            let mut memory = Err(unavailable("no host-visible coherent memory type"));
            for ty in types {
                let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(ty);
                memory = d.allocate_memory(&alloc, None).map_err(|e| vk_err("vkAllocateMemory", e));
                if memory.is_ok() {
                    break;
                }
            }
            let memory = match memory {
                Ok(m) => m,
                Err(e) => {
                    d.destroy_buffer(buffer, None);
                    return Err(e);
                }
            };
            let mapped = d
                .bind_buffer_memory(buffer, memory, 0)
                .and_then(|()| d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()));
            match mapped {
                Ok(ptr) => {
                    Ok(Buffer { shared: self.shared.clone(), buffer, memory, ptr: ptr.cast(), bytes: bytes as usize })
                }
                Err(e) => {
                    d.destroy_buffer(buffer, None);
                    d.free_memory(memory, None);
                    Err(vk_err("vkMapMemory", e))
                }
            }
        }
    }

    /// A compute kernel from SPIR-V with `bindings` storage buffers and
    /// `push` bytes of push constants.
    ///
    /// # Errors
    /// Pipeline creation failures.
    pub fn kernel(&self, spirv: &[u8], entry: &CStr, bindings: u32, push: u32) -> Result<Kernel, BackendError> {
        let d = &self.shared.device;
        let words: Vec<u32> = spirv.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        let binding: Vec<vk::DescriptorSetLayoutBinding> = (0..bindings)
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        // Filled in step by step: on an early return, dropping `k` destroys
        // what was made so far (destroying a null handle is a no-op).
        let mut k = Kernel {
            shared: self.shared.clone(),
            module: vk::ShaderModule::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            bindings,
        };
        // SAFETY: every create info is valid and refers to live objects made
        // just before it; each object is owned by `k`, whose drop destroys it.
        unsafe {
            k.module = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
                .map_err(|e| vk_err("vkCreateShaderModule", e))?;
            k.set_layout = d
                .create_descriptor_set_layout(&vk::DescriptorSetLayoutCreateInfo::default().bindings(&binding), None)
                .map_err(|e| vk_err("vkCreateDescriptorSetLayout", e))?;
            let ranges = [vk::PushConstantRange::default().stage_flags(vk::ShaderStageFlags::COMPUTE).size(push)];
            let layouts = [k.set_layout];
            k.layout = d
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts).push_constant_ranges(&ranges),
                    None,
                )
                .map_err(|e| vk_err("vkCreatePipelineLayout", e))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(k.module)
                .name(entry);
            let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(k.layout)];
            k.pipeline = d
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
                .map_err(|(_, e)| vk_err("vkCreateComputePipelines", e))?[0];
            let sizes =
                [vk::DescriptorPoolSize::default().ty(vk::DescriptorType::STORAGE_BUFFER).descriptor_count(bindings)];
            k.pool = d
                .create_descriptor_pool(&vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes), None)
                .map_err(|e| vk_err("vkCreateDescriptorPool", e))?;
            k.set = d
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default().descriptor_pool(k.pool).set_layouts(&layouts),
                )
                .map_err(|e| vk_err("vkAllocateDescriptorSets", e))?[0];
        }
        Ok(k)
    }

    /// Records and runs one dispatch of `groups` workgroups and waits for it.
    ///
    /// The kernel's bindings are `read` then `write`, in order: the kernels
    /// declare the `read` ones `var<storage, read>`, so the device writes
    /// only the buffers borrowed `&mut` here, and no `&[u8]` from
    /// [`Buffer::bytes`] can be alive while it does.
    ///
    /// # Errors
    /// Submission failures.
    pub(crate) fn dispatch(
        &self,
        k: &Kernel,
        read: &[&Buffer],
        write: &mut [&mut Buffer],
        push: &[u8],
        groups: u32,
    ) -> Result<(), BackendError> {
        let buffers: Vec<&Buffer> = read.iter().copied().chain(write.iter().map(|b| &**b)).collect();
        assert_eq!(buffers.len() as u32, k.bindings, "one buffer per binding");
        assert!(
            Arc::ptr_eq(&k.shared, &self.shared) && buffers.iter().all(|b| Arc::ptr_eq(&b.shared, &self.shared)),
            "kernel and buffers belong to this device"
        );
        let d = &self.shared.device;
        let pool = self.pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let queue = self.queue.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        // SAFETY: the pool and queue are held exclusively; every handle is live;
        // the fence wait ends the command buffer's use before it is freed.
        unsafe {
            let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
                .iter()
                .map(|b| [vk::DescriptorBufferInfo::default().buffer(b.buffer).offset(0).range(vk::WHOLE_SIZE)])
                .collect();
            let writes: Vec<vk::WriteDescriptorSet> = infos
                .iter()
                .enumerate()
                .map(|(i, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(k.set)
                        .dst_binding(i as u32)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(info)
                })
                .collect();
            d.update_descriptor_sets(&writes, &[]);
            let cb = d
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(*pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .map_err(|e| vk_err("vkAllocateCommandBuffers", e))?[0];
            let fence = d.create_fence(&vk::FenceCreateInfo::default(), None).map_err(|e| vk_err("vkCreateFence", e));
            let run = fence.and_then(|fence| {
                let r = (|| {
                    d.begin_command_buffer(
                        cb,
                        &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                    )
                    .map_err(|e| vk_err("vkBeginCommandBuffer", e))?;
                    d.cmd_bind_pipeline(cb, vk::PipelineBindPoint::COMPUTE, k.pipeline);
                    d.cmd_bind_descriptor_sets(cb, vk::PipelineBindPoint::COMPUTE, k.layout, 0, &[k.set], &[]);
                    if !push.is_empty() {
                        d.cmd_push_constants(cb, k.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
                    }
                    d.cmd_dispatch(cb, groups.max(1), 1, 1);
                    // Make shader writes visible to the host.
                    let barrier = vk::MemoryBarrier::default()
                        .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                        .dst_access_mask(vk::AccessFlags::HOST_READ);
                    d.cmd_pipeline_barrier(
                        cb,
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::PipelineStageFlags::HOST,
                        vk::DependencyFlags::empty(),
                        &[barrier],
                        &[],
                        &[],
                    );
                    d.end_command_buffer(cb).map_err(|e| vk_err("vkEndCommandBuffer", e))?;
                    let cbs = [cb];
                    let submit = [vk::SubmitInfo::default().command_buffers(&cbs)];
                    d.queue_submit(*queue, &submit, fence).map_err(|e| vk_err("vkQueueSubmit", e))?;
                    d.wait_for_fences(&[fence], true, u64::MAX).map_err(|e| vk_err("vkWaitForFences", e))
                })();
                d.destroy_fence(fence, None);
                r
            });
            d.free_command_buffers(*pool, &[cb]);
            run
        }
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        let pool = *self.pool.get_mut().unwrap_or_else(std::sync::PoisonError::into_inner);
        // SAFETY: every dispatch waited for its fence, so the pool's command
        // buffers are idle; the device lives on in `shared` until its last
        // buffer and kernel are dropped too.
        unsafe {
            let _ = self.shared.device.device_wait_idle();
            self.shared.device.destroy_command_pool(pool, None);
        }
    }
}

/// Why opening failed, and whether the instance is already destroyed.
enum Failed {
    /// Nothing made from the instance yet: the caller destroys it.
    BeforeDevice(BackendError),
    /// The device (and with it the instance) was destroyed already.
    AfterDevice(BackendError),
}

/// A mapped host-visible storage buffer; it keeps its device alive.
pub(crate) struct Buffer {
    shared: Arc<Device>,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    ptr: *mut u8,
    bytes: usize,
}

// SAFETY: the mapping is plain memory owned by this value (the raw pointer
// is what makes the type !Send by default); moving it to another thread
// moves that ownership.
unsafe impl Send for Buffer {}
// SAFETY: through `&Buffer` the host only reads the mapping, and the device
// only writes a buffer that `Gpu::dispatch` borrows `&mut` (it waits for the
// dispatch to finish before returning), so no write overlaps a shared borrow.
unsafe impl Sync for Buffer {}

/// What a buffer holds, which decides the memory it lives in. On lavapipe
/// every choice is the same host memory; on a discrete GPU the kernels read
/// [`Use::Resident`] data from the card's own memory (through a resizable
/// BAR) instead of across the bus, and the host reads [`Use::Readback`]
/// results through its caches instead of from write-combined memory. On an
/// H200 this measured neutral (the host's per-dispatch cost dominates:
/// docs/VULKAN.md, *On a real GPU*), and is kept as the placement a
/// discrete GPU wants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Use {
    /// Written by the host before each dispatch, read once by the device.
    Stream,
    /// Written once by the host, read by the device in every dispatch (a
    /// scene's nodes and triangles, a volume's voxels).
    Resident,
    /// Written by the device, read by the host.
    Readback,
}

impl Use {
    /// Memory property flags to try, best first; every entry is mappable.
    #[must_use]
    pub fn memory_preferences(self) -> &'static [vk::MemoryPropertyFlags] {
        const MAPPED: vk::MemoryPropertyFlags = vk::MemoryPropertyFlags::from_raw(
            vk::MemoryPropertyFlags::HOST_VISIBLE.as_raw() | vk::MemoryPropertyFlags::HOST_COHERENT.as_raw(),
        );
        const RESIDENT: vk::MemoryPropertyFlags =
            vk::MemoryPropertyFlags::from_raw(MAPPED.as_raw() | vk::MemoryPropertyFlags::DEVICE_LOCAL.as_raw());
        const CACHED: vk::MemoryPropertyFlags =
            vk::MemoryPropertyFlags::from_raw(MAPPED.as_raw() | vk::MemoryPropertyFlags::HOST_CACHED.as_raw());
        match self {
            Self::Stream => &[MAPPED],
            Self::Resident => &[RESIDENT, MAPPED],
            Self::Readback => &[CACHED, MAPPED],
        }
    }
}

impl Buffer {
    /// The mapped bytes.
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        // SAFETY: `ptr` maps `bytes` bytes for the buffer's lifetime.
        unsafe { std::slice::from_raw_parts(self.ptr, self.bytes) }
    }

    /// The mapped bytes, writable.
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        // SAFETY: as `bytes`, with exclusive access through `&mut self`.
        unsafe { std::slice::from_raw_parts_mut(self.ptr, self.bytes) }
    }

    /// Copies 32-bit words in from word `offset` on (f32 values as
    /// `x.to_bits()`), without an intermediate copy.
    ///
    /// # Panics
    /// If they do not fit.
    pub fn write_words(&mut self, offset: usize, words: impl IntoIterator<Item = u32>) {
        let mut dst = self.bytes_mut()[4 * offset..].chunks_exact_mut(4);
        for w in words {
            dst.next().expect("words fit the buffer").copy_from_slice(&w.to_le_bytes());
        }
    }

    /// Word `i`.
    #[must_use]
    pub fn word(&self, i: usize) -> u32 {
        let b = &self.bytes()[4 * i..4 * i + 4];
        u32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        let d = &self.shared.device;
        // SAFETY: dispatches wait for completion, so the GPU no longer uses
        // it, and the device is alive (held by `shared`).
        unsafe {
            d.unmap_memory(self.memory);
            d.destroy_buffer(self.buffer, None);
            d.free_memory(self.memory, None);
        }
    }
}

/// A compute pipeline with its descriptor set; it keeps its device alive.
pub(crate) struct Kernel {
    shared: Arc<Device>,
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    bindings: u32,
}

impl Drop for Kernel {
    fn drop(&mut self) {
        let d = &self.shared.device;
        // SAFETY: no dispatch is in flight (each waits for its fence), the
        // device is alive (held by `shared`), and null handles of a kernel
        // whose creation stopped early are ignored by vkDestroy*.
        unsafe {
            d.destroy_descriptor_pool(self.pool, None);
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_shader_module(self.module, None);
        }
    }
}
