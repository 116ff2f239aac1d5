//! The hand-written baselines: code written directly against ash, the way a
//! careful Vulkan programmer would without raykit.
//!
//! [`AshDevice`] is its own instance and device on raykit's GPU (matched by
//! `deviceUUID`; with `RAYKIT_VALIDATION=1`, with the Khronos validation layer,
//! whose messages it collects). On it, the `accel` suite's GAS build: a
//! persistent, persistently mapped host-visible input buffer and a persistent
//! scratch buffer, both grown on demand (so no allocation per build); structure
//! storage from `vkAllocateMemory`, reused after a structure is destroyed (as an
//! allocator reuses freed memory); one submission with the compacted-size query;
//! fence wait. The primary-ray suites' independent baseline also runs on it
//! (see [`crate::ash_independent`]).
//!
//! [`AshTracer`] is the hand-written launch of raykit's own compiled primary-ray
//! `VkPipeline`, SBT regions and TLAS that the `primary` and `optix` suites time
//! beside raykit's launch (what raykit's launch path costs), on raykit's device
//! with its own descriptor set (raykit's buffer-table layout, one slot written)
//! whose output buffer is device-local, as the fastest Vulkan program keeps it;
//! the picture is copied out to a host-visible buffer after the launch, outside
//! the timed part. GPU timestamps bracket `vkCmdTraceRaysKHR`, as raykit's
//! `launch_timed` does.

use std::cell::RefCell;
use std::ffi::CStr;
use std::sync::Mutex;

use anyhow::{bail, Context as _};
use ash::vk;

use crate::ash_launcher::{Output, Submitter};

/// A Vulkan device of its own (its own instance too) on raykit's GPU, set up for
/// acceleration-structure builds and ray-tracing pipelines.
pub struct AshDevice {
    _entry: ash::Entry,
    instance: ash::Instance,
    pub(crate) device: ash::Device,
    pub(crate) accel: ash::khr::acceleration_structure::Device,
    pub(crate) rt: ash::khr::ray_tracing_pipeline::Device,
    /// The ray-tracing pipeline properties (SBT handle size and alignments).
    pub(crate) rt_props: RtProperties,
    pub(crate) queue: vk::Queue,
    pub(crate) pool: vk::CommandPool,
    memory_props: vk::PhysicalDeviceMemoryProperties,
    scratch_alignment: u64,
    pub(crate) timestamp_period_ns: f64,
    /// Valid bits of the queue's timestamps (0: none).
    pub(crate) timestamp_valid_bits: u32,
    timestamps: bool,
    arena: RefCell<Arena>,
    /// The validation layer's messenger, when `RAYKIT_VALIDATION=1`.
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Messages the validation layer reported (the messenger's user data).
    messages: Box<Mutex<Vec<String>>>,
}

/// Buffers kept from build to build.
#[derive(Default)]
struct Arena {
    /// Host-visible input buffer, its capacity and mapping.
    input: Option<(Buffer, u64, *mut u8)>,
    /// Scratch buffer and its capacity.
    scratch: Option<(Buffer, u64)>,
    /// Storage of destroyed structures, with their sizes, for reuse (as an
    /// allocator would reuse freed memory).
    free_storage: Vec<(Buffer, u64)>,
}

/// A buffer with its own memory (null handles: none).
#[derive(Default)]
pub(crate) struct Buffer {
    pub buffer: vk::Buffer,
    pub memory: vk::DeviceMemory,
    pub address: u64,
}

/// One built GAS.
pub struct AshGas {
    accel: vk::AccelerationStructureKHR,
    storage: (Buffer, u64),
    /// Bytes of the structure.
    pub size: u64,
    /// Compacted size queried after the build.
    pub compacted_size: u64,
    /// GPU time of the build command alone, when the queue has timestamps.
    pub gpu_ns: Option<f64>,
}

/// The SBT-related limits of `VkPhysicalDeviceRayTracingPipelinePropertiesKHR`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RtProperties {
    pub handle_size: u32,
    pub handle_alignment: u32,
    pub base_alignment: u32,
}

/// The Khronos validation layer.
const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Whether the validation layer is on: `RAYKIT_VALIDATION=1`, as for raykit's contexts.
pub fn validation_requested() -> bool {
    std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1")
}

/// Collects the validation layer's warnings and errors into the `Mutex<Vec<String>>`
/// its user data points to.
unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if user_data.is_null() || data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: `user_data` is the device's boxed message list, which outlives the
    // messenger; `data` and its strings are valid for this call.
    let (messages, data) = unsafe { (&*(user_data as *const Mutex<Vec<String>>), &*data) };
    let text = if data.p_message.is_null() {
        String::new()
    } else {
        // SAFETY: as above: a NUL-terminated string.
        unsafe { CStr::from_ptr(data.p_message) }.to_string_lossy().into_owned()
    };
    if let Ok(mut list) = messages.lock() {
        list.push(format!("{severity:?}: {text}"));
    }
    vk::FALSE
}

/// The `deviceUUID` of `physical`.
fn device_uuid(instance: &ash::Instance, physical: vk::PhysicalDevice) -> [u8; vk::UUID_SIZE] {
    let mut id = vk::PhysicalDeviceIDProperties::default();
    let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut id);
    // SAFETY: `physical` belongs to `instance`; the chain is valid.
    unsafe { instance.get_physical_device_properties2(physical, &mut props) };
    id.device_uuid
}

impl AshDevice {
    /// Creates a device on raykit's GPU (the physical device of `ctx`, matched by
    /// its `deviceUUID`), with the validation layer when `RAYKIT_VALIDATION=1`.
    pub fn new(ctx: &raykit::Context) -> anyhow::Result<AshDevice> {
        let theirs = ctx.raw_instance().context("the ash baseline needs a Vulkan context")?;
        let their_physical = ctx.raw_physical_device().context("the ash baseline needs a Vulkan context")?;
        let uuid = device_uuid(theirs, their_physical);
        let validation = validation_requested();
        // SAFETY: loading the system Vulkan loader.
        let entry = unsafe { ash::Entry::load() }.context("loading libvulkan")?;
        let mut layers = Vec::new();
        let mut instance_extensions = Vec::new();
        if validation {
            // SAFETY: plain enumeration call.
            let available = unsafe { entry.enumerate_instance_layer_properties() }?;
            if !available.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER)) {
                bail!("RAYKIT_VALIDATION=1 but VK_LAYER_KHRONOS_validation is not installed");
            }
            layers.push(VALIDATION_LAYER.as_ptr());
            instance_extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let messages: Box<Mutex<Vec<String>>> = Box::default();
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(on_message))
            .user_data(&*messages as *const Mutex<Vec<String>> as *mut std::ffi::c_void);
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&instance_extensions);
        if validation {
            info = info.push_next(&mut messenger_info);
        }
        // SAFETY: valid create info; the messenger's user data outlives the instance.
        let instance = unsafe { entry.create_instance(&info, None) }?;
        let messenger = if validation {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: valid create info; the user data outlives the messenger.
            match unsafe { loader.create_debug_utils_messenger(&messenger_info, None) } {
                Ok(m) => Some((loader, m)),
                Err(e) => {
                    // SAFETY: nothing else was made on the instance.
                    unsafe { instance.destroy_instance(None) };
                    return Err(e).context("vkCreateDebugUtilsMessengerEXT");
                }
            }
        } else {
            None
        };
        // From here on, dropping `partial` destroys the messenger and the instance.
        let partial = PartialInstance { instance: &instance, messenger: messenger.as_ref() };
        // SAFETY: live instance.
        let physicals = unsafe { instance.enumerate_physical_devices() }?;
        let Some(physical) = physicals.into_iter().find(|&p| device_uuid(&instance, p) == uuid) else {
            bail!("raykit's GPU ({}) is not among this instance's devices", ctx.device_name());
        };
        // SAFETY: `physical` belongs to `instance`.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .context("no compute queue")?;
        let timestamp_valid_bits = families[family].timestamp_valid_bits;
        let timestamps = timestamp_valid_bits > 0 && props.limits.timestamp_period > 0.0;
        let mut accel_props = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        let mut rt_props = vk::PhysicalDeviceRayTracingPipelinePropertiesKHR::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut accel_props).push_next(&mut rt_props);
        // SAFETY: as above.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let scratch_alignment = accel_props.min_acceleration_structure_scratch_offset_alignment.max(1) as u64;
        let rt_props = RtProperties {
            handle_size: rt_props.shader_group_handle_size,
            handle_alignment: rt_props.shader_group_handle_alignment.max(1),
            base_alignment: rt_props.shader_group_base_alignment.max(1),
        };

        let extensions: [&CStr; 3] = [
            ash::khr::acceleration_structure::NAME,
            ash::khr::ray_tracing_pipeline::NAME,
            ash::khr::deferred_host_operations::NAME,
        ];
        let extension_ptrs: Vec<_> = extensions.iter().map(|e| e.as_ptr()).collect();
        let mut accel_features =
            vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
        let mut rt_features = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true);
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default().buffer_device_address(true);
        let priorities = [1.0f32];
        let queues =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(family as u32).queue_priorities(&priorities)];
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_extension_names(&extension_ptrs)
            .push_next(&mut accel_features)
            .push_next(&mut rt_features)
            .push_next(&mut v12);
        // SAFETY: the extensions and features are those raykit also requires of this device.
        let device = unsafe { instance.create_device(physical, &info, None) }?;
        std::mem::forget(partial);
        let accel = ash::khr::acceleration_structure::Device::new(&instance, &device);
        let rt = ash::khr::ray_tracing_pipeline::Device::new(&instance, &device);
        // SAFETY: the queue was requested above.
        let queue = unsafe { device.get_device_queue(family as u32, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family as u32)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info.
        let pool = match unsafe { device.create_command_pool(&pool_info, None) } {
            Ok(pool) => pool,
            Err(e) => {
                // SAFETY: nothing else was made on the device.
                unsafe { device.destroy_device(None) };
                drop(PartialInstance { instance: &instance, messenger: messenger.as_ref() });
                return Err(e).context("vkCreateCommandPool");
            }
        };
        // SAFETY: as above.
        let memory_props = unsafe { instance.get_physical_device_memory_properties(physical) };
        Ok(AshDevice {
            _entry: entry,
            instance,
            device,
            accel,
            rt,
            rt_props,
            queue,
            pool,
            memory_props,
            scratch_alignment,
            timestamp_period_ns: props.limits.timestamp_period as f64,
            timestamp_valid_bits,
            timestamps,
            arena: RefCell::new(Arena::default()),
            messenger,
            messages,
        })
    }

    /// The validation layer's messages so far (none without `RAYKIT_VALIDATION=1`).
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    fn memory_type(&self, bits: u32, wanted: vk::MemoryPropertyFlags) -> anyhow::Result<u32> {
        let types = &self.memory_props.memory_types[..self.memory_props.memory_type_count as usize];
        let find = |flags: vk::MemoryPropertyFlags| {
            types.iter().enumerate().position(|(i, t)| bits & (1 << i) != 0 && t.property_flags.contains(flags))
        };
        find(wanted)
            .or_else(|| {
                if wanted.contains(vk::MemoryPropertyFlags::HOST_VISIBLE) {
                    None
                } else {
                    find(vk::MemoryPropertyFlags::empty())
                }
            })
            .map(|i| i as u32)
            .context("no suitable memory type")
    }

    pub(crate) fn buffer(&self, size: u64, usage: vk::BufferUsageFlags, host: bool) -> anyhow::Result<Buffer> {
        let info = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS);
        // SAFETY: valid create info.
        let buffer = unsafe { self.device.create_buffer(&info, None) }?;
        // SAFETY: live buffer.
        let req = unsafe { self.device.get_buffer_memory_requirements(buffer) };
        let props = if host {
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT
        } else {
            vk::MemoryPropertyFlags::DEVICE_LOCAL
        };
        let mut flags = vk::MemoryAllocateFlagsInfo::default().flags(vk::MemoryAllocateFlags::DEVICE_ADDRESS);
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(self.memory_type(req.memory_type_bits, props)?)
            .push_next(&mut flags);
        // SAFETY: valid allocate info.
        let memory = unsafe { self.device.allocate_memory(&alloc, None) }?;
        // SAFETY: fresh buffer and memory of the required size and type.
        unsafe { self.device.bind_buffer_memory(buffer, memory, 0) }?;
        // SAFETY: the buffer has the device-address usage and is bound.
        let address =
            unsafe { self.device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer)) };
        Ok(Buffer { buffer, memory, address })
    }

    /// Copies `parts` into the persistent input buffer (grown when too small), each
    /// at a 16-byte-aligned offset; returns their device addresses.
    pub(crate) fn upload(&self, parts: &[&[u8]]) -> anyhow::Result<Vec<u64>> {
        let mut offsets = Vec::new();
        let mut len = 0u64;
        for p in parts {
            offsets.push(len);
            len = (len + p.len() as u64).div_ceil(16) * 16;
        }
        let mut arena = self.arena.borrow_mut();
        if arena.input.as_ref().is_none_or(|(_, cap, _)| *cap < len) {
            if let Some((old, _, _)) = arena.input.take() {
                self.free(old);
            }
            let b = self.buffer(len, vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR, true)?;
            // SAFETY: host-visible memory, mapped once for the buffer's lifetime.
            let ptr =
                unsafe { self.device.map_memory(b.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }? as *mut u8;
            arena.input = Some((b, len, ptr));
        }
        let Some((b, _, ptr)) = &arena.input else { bail!("no input buffer") };
        for (p, &at) in parts.iter().zip(&offsets) {
            // SAFETY: the mapping covers `len` bytes; no submission is using the buffer.
            unsafe { std::ptr::copy_nonoverlapping(p.as_ptr(), ptr.add(at as usize), p.len()) };
        }
        Ok(offsets.iter().map(|o| b.address + o).collect())
    }

    /// A storage buffer of at least `size` bytes: a freed one when one fits.
    fn storage(&self, size: u64) -> anyhow::Result<(Buffer, u64)> {
        let mut arena = self.arena.borrow_mut();
        if let Some(i) = arena.free_storage.iter().position(|(_, cap)| *cap >= size && *cap <= size * 2) {
            return Ok(arena.free_storage.swap_remove(i));
        }
        Ok((self.buffer(size, vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR, false)?, size))
    }

    /// The persistent scratch buffer's aligned address, grown to `size` when smaller.
    pub(crate) fn scratch(&self, size: u64) -> anyhow::Result<u64> {
        let mut arena = self.arena.borrow_mut();
        let size = size + self.scratch_alignment;
        if arena.scratch.as_ref().is_none_or(|(_, cap)| *cap < size) {
            if let Some((old, _)) = arena.scratch.take() {
                self.free(old);
            }
            arena.scratch = Some((self.buffer(size, vk::BufferUsageFlags::STORAGE_BUFFER, false)?, size));
        }
        let Some((b, _)) = &arena.scratch else { bail!("no scratch buffer") };
        Ok(b.address.div_ceil(self.scratch_alignment) * self.scratch_alignment)
    }

    pub(crate) fn free(&self, b: Buffer) {
        // SAFETY: the work using the buffer has finished.
        unsafe {
            self.device.destroy_buffer(b.buffer, None);
            self.device.free_memory(b.memory, None);
        }
    }

    /// Records `record` into a one-time command buffer, submits it and waits.
    pub(crate) fn submit_and_wait(&self, record: impl FnOnce(vk::CommandBuffer)) -> anyhow::Result<()> {
        let info = vk::CommandBufferAllocateInfo::default().command_pool(self.pool).command_buffer_count(1);
        // SAFETY: single-threaded use of the pool.
        let cmd = unsafe { self.device.allocate_command_buffers(&info) }?[0];
        // SAFETY: fresh command buffer; the fence is waited before everything is freed.
        unsafe {
            self.device.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;
            record(cmd);
            self.device.end_command_buffer(cmd)?;
            let fence = self.device.create_fence(&vk::FenceCreateInfo::default(), None)?;
            let cmds = [cmd];
            self.device.queue_submit(self.queue, &[vk::SubmitInfo::default().command_buffers(&cmds)], fence)?;
            self.device.wait_for_fences(&[fence], true, u64::MAX)?;
            self.device.destroy_fence(fence, None);
            self.device.free_command_buffers(self.pool, &cmds);
        }
        Ok(())
    }

    /// Builds a GAS over `vertices` (f32×3) and `indices` (u32) with fast trace
    /// and compaction allowed, querying the compacted size in the same submission;
    /// with `timed`, GPU timestamps bracket the build command (they cost time
    /// themselves, so timed builds are kept out of the wall-clock comparison).
    ///
    /// With `reuse_storage`, the structure's memory comes from a destroyed
    /// structure's when one fits; otherwise from a fresh `vkAllocateMemory`.
    pub fn build_gas(
        &self,
        vertices: &[[f32; 3]],
        indices: &[u32],
        timed: bool,
        reuse_storage: bool,
    ) -> anyhow::Result<AshGas> {
        let addresses = self.upload(&[as_bytes(vertices), as_bytes(indices)])?;
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR { device_address: addresses[0] })
            .vertex_stride(12)
            .max_vertex(vertices.len() as u32 - 1)
            .index_type(vk::IndexType::UINT32)
            .index_data(vk::DeviceOrHostAddressConstKHR { device_address: addresses[1] });
        let geometry = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })];
        let flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE
            | vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION;
        let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
            .flags(flags)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geometry);
        let count = (indices.len() / 3) as u32;
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: valid build info and one count per geometry.
        unsafe {
            self.accel.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[count],
                &mut sizes,
            )
        };
        let storage = if reuse_storage {
            self.storage(sizes.acceleration_structure_size)?
        } else {
            let size = sizes.acceleration_structure_size;
            (self.buffer(size, vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR, false)?, size)
        };
        let create = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage.0.buffer)
            .size(sizes.acceleration_structure_size)
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL);
        // SAFETY: the storage buffer is large enough.
        let accel = unsafe { self.accel.create_acceleration_structure(&create, None) }?;
        let scratch_address = self.scratch(sizes.build_scratch_size)?;
        info = info
            .dst_acceleration_structure(accel)
            .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch_address });
        let range = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];

        let pool_info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR)
            .query_count(1);
        // SAFETY: valid create info.
        let query = unsafe { self.device.create_query_pool(&pool_info, None) }?;
        let time_pool = if timed && self.timestamps {
            // SAFETY: valid create info.
            Some(unsafe {
                self.device.create_query_pool(
                    &vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2),
                    None,
                )
            }?)
        } else {
            None
        };
        self.submit_and_wait(|cmd| {
            // SAFETY: everything referenced lives until the wait ends.
            unsafe {
                self.device.cmd_reset_query_pool(cmd, query, 0, 1);
                if let Some(t) = time_pool {
                    self.device.cmd_reset_query_pool(cmd, t, 0, 2);
                    self.device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, t, 0);
                }
                self.accel.cmd_build_acceleration_structures(cmd, &[info], &[&range]);
                if let Some(t) = time_pool {
                    self.device.cmd_write_timestamp(
                        cmd,
                        vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                        t,
                        1,
                    );
                }
                let barrier = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR)
                    .dst_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR);
                self.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                );
                self.accel.cmd_write_acceleration_structures_properties(
                    cmd,
                    &[accel],
                    vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                    query,
                    0,
                );
            }
        })?;
        let mut compacted = [0u64; 1];
        // SAFETY: the query was written by the finished submission.
        unsafe {
            self.device.get_query_pool_results(
                query,
                0,
                &mut compacted,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }?;
        let gpu_ns = match time_pool {
            Some(t) => {
                let mut stamps = [0u64; 2];
                // SAFETY: as above.
                unsafe {
                    self.device.get_query_pool_results(
                        t,
                        0,
                        &mut stamps,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }?;
                // SAFETY: no longer used.
                unsafe { self.device.destroy_query_pool(t, None) };
                Some(stamps[1].saturating_sub(stamps[0]) as f64 * self.timestamp_period_ns)
            }
            None => None,
        };
        // SAFETY: no longer used.
        unsafe { self.device.destroy_query_pool(query, None) };
        Ok(AshGas { accel, storage, size: sizes.acceleration_structure_size, compacted_size: compacted[0], gpu_ns })
    }

    /// Compacts `gas` into a new structure of its compacted size; returns that size.
    pub fn compact(&self, gas: &AshGas) -> anyhow::Result<u64> {
        let storage = self.storage(gas.compacted_size)?;
        let create = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage.0.buffer)
            .size(gas.compacted_size)
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL);
        // SAFETY: the storage buffer is large enough.
        let accel = unsafe { self.accel.create_acceleration_structure(&create, None) }?;
        let copy = vk::CopyAccelerationStructureInfoKHR::default()
            .src(gas.accel)
            .dst(accel)
            .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
        // SAFETY: both structures live until the wait ends.
        self.submit_and_wait(|cmd| unsafe { self.accel.cmd_copy_acceleration_structure(cmd, &copy) })?;
        // SAFETY: the copy has finished.
        unsafe { self.accel.destroy_acceleration_structure(accel, None) };
        self.free(storage.0);
        Ok(gas.compacted_size)
    }

    /// Destroys a GAS.
    pub fn destroy(&self, gas: AshGas) {
        // SAFETY: nothing uses it any more.
        unsafe { self.accel.destroy_acceleration_structure(gas.accel, None) };
        let mut arena = self.arena.borrow_mut();
        if arena.free_storage.len() < 4 {
            arena.free_storage.push(gas.storage);
        } else {
            self.free(gas.storage.0);
        }
    }

    /// Whether GPU timestamps of the build are available.
    pub fn has_timestamps(&self) -> bool {
        self.timestamps
    }
}

impl Drop for AshDevice {
    fn drop(&mut self) {
        let arena = std::mem::take(self.arena.get_mut());
        // SAFETY: all work has finished; objects are destroyed child first.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Some((b, _, _)) = arena.input {
                self.free(b);
            }
            if let Some((b, _)) = arena.scratch {
                self.free(b);
            }
            for (b, _) in arena.free_storage {
                self.free(b);
            }
            self.device.destroy_command_pool(self.pool, None);
            let before = self.messages().len();
            self.device.destroy_device(None);
            // What the validation layer says at destruction (objects left alive)
            // comes after the suites' checks: it is printed.
            for m in self.messages().iter().skip(before) {
                eprintln!("ash baseline: validation at device destruction: {m}");
            }
            if let Some((loader, messenger)) = &self.messenger {
                loader.destroy_debug_utils_messenger(*messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// An instance (and its messenger) that the device's constructor destroys
/// when it returns early.
struct PartialInstance<'a> {
    instance: &'a ash::Instance,
    messenger: Option<&'a (ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

impl Drop for PartialInstance<'_> {
    fn drop(&mut self) {
        // SAFETY: no device of the instance is left; the messenger goes first.
        unsafe {
            if let Some((loader, messenger)) = self.messenger {
                loader.destroy_debug_utils_messenger(*messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

pub(crate) fn as_bytes<T: Copy>(data: &[T]) -> &[u8] {
    // SAFETY: `T` is plain data here (f32 arrays, u32) without padding.
    unsafe { std::slice::from_raw_parts(data.as_ptr() as *const u8, std::mem::size_of_val(data)) }
}

/// Memory properties, timestamp bits and timestamp period (ns) of raykit's physical
/// device.
fn raykit_physical(ctx: &raykit::Context) -> anyhow::Result<(vk::PhysicalDeviceMemoryProperties, u32, f64)> {
    let instance = ctx.raw_instance().context("the ash tracer needs a Vulkan context")?;
    let physical = ctx.raw_physical_device().context("the ash tracer needs a Vulkan context")?;
    let family = ctx.queue_family().context("the ash tracer needs a Vulkan context")? as usize;
    // SAFETY: `physical` came from this live instance.
    let props = unsafe { instance.get_physical_device_properties(physical) };
    // SAFETY: as above.
    let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
    // SAFETY: as above.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let bits = families.get(family).map_or(0, |f| f.timestamp_valid_bits);
    Ok((memory, bits, props.limits.timestamp_period as f64))
}

/// Slots of raykit's buffer table (binding 0) and texture table (binding 1).
const TABLE_SLOTS: u32 = raykit_abi::BUFFER_TABLE_SLOTS;
const TEXTURE_SLOTS: u32 = raykit_abi::TEXTURE_TABLE_SLOTS;
/// The slot of the tracer's output buffer in its own descriptor set.
const OUTPUT_SLOT: u32 = 1;

/// A hand-written launcher of raykit's compiled primary-ray pipeline with a
/// device-local output buffer (see the module docs).
pub struct AshTracer<'c> {
    device: &'c ash::Device,
    rt: &'c ash::khr::ray_tracing_pipeline::Device,
    pool: vk::CommandPool,
    submitter: Submitter<'c>,
    descriptor_pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    /// The programs' output, device-local, and its mapped copy.
    output: Output,
}

impl<'c> AshTracer<'c> {
    /// A tracer writing `words` 32-bit words of output on raykit's device.
    pub fn new(ctx: &'c raykit::Context, words: usize) -> anyhow::Result<AshTracer<'c>> {
        let device = ctx.raw_device().context("the ash tracer needs a Vulkan context")?;
        let rt = ctx.raw_ray_tracing().context("the ash tracer needs a Vulkan context")?;
        let family = ctx.queue_family().context("the ash tracer needs a Vulkan context")?;
        let layout = ctx.raw_buffer_table_layout().context("the ash tracer needs a Vulkan context")?;
        let (memory, valid_bits, period_ns) = raykit_physical(ctx)?;
        let bytes = (words as u64 * 4).max(4);
        let buffer =
            |size: u64, usage: vk::BufferUsageFlags, flags: vk::MemoryPropertyFlags| -> anyhow::Result<Buffer> {
                let info = vk::BufferCreateInfo::default().size(size).usage(usage);
                // SAFETY: valid create info.
                let buffer = unsafe { device.create_buffer(&info, None) }?;
                // SAFETY: live buffer.
                let req = unsafe { device.get_buffer_memory_requirements(buffer) };
                let types = &memory.memory_types[..memory.memory_type_count as usize];
                let index = types
                    .iter()
                    .enumerate()
                    .position(|(i, t)| req.memory_type_bits & (1 << i) != 0 && t.property_flags.contains(flags))
                    .with_context(|| format!("no {flags:?} memory for the ash tracer"))?;
                let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(index as u32);
                // SAFETY: valid allocate info; bound right away to the fresh buffer.
                let memory = unsafe { device.allocate_memory(&alloc, None) }?;
                // SAFETY: as above.
                unsafe { device.bind_buffer_memory(buffer, memory, 0) }?;
                Ok(Buffer { buffer, memory, address: 0 })
            };
        let output = buffer(
            bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let readback = buffer(
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
        )?;
        let mut output = Output::new(output, readback, bytes);
        output.map(device)?;

        // A set of raykit's buffer-table layout, with the output in one slot.
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: TABLE_SLOTS },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, descriptor_count: TEXTURE_SLOTS },
        ];
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .flags(vk::DescriptorPoolCreateFlags::UPDATE_AFTER_BIND)
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let descriptor_pool = unsafe { device.create_descriptor_pool(&pool_info, None) }?;
        let layouts = [layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(descriptor_pool).set_layouts(&layouts);
        // SAFETY: the pool has room for this one set of that layout.
        let set = unsafe { device.allocate_descriptor_sets(&alloc) }?[0];
        let infos = [vk::DescriptorBufferInfo::default().buffer(output.device.buffer).offset(0).range(vk::WHOLE_SIZE)];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(set)
            .dst_binding(raykit_abi::BUFFER_TABLE_BINDING)
            .dst_array_element(OUTPUT_SLOT)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&infos);
        // SAFETY: the set and the buffer are live; no launch uses the set yet.
        unsafe { device.update_descriptor_sets(&[write], &[]) };

        // SAFETY: queue 0 of raykit's family exists; the bench is single-threaded,
        // so raykit never submits to it at the same time.
        let queue = unsafe { device.get_device_queue(family, 0) };
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info.
        let pool = unsafe { device.create_command_pool(&info, None) }?;
        let submitter = Submitter::new(device, queue, pool, valid_bits, period_ns)?;
        Ok(AshTracer { device, rt, pool, submitter, descriptor_pool, set, output })
    }

    /// `params` (push constants) with their first word, the output buffer's
    /// handle, pointing at the tracer's own output slot.
    pub fn params_with_output(params: &[u8]) -> Vec<u8> {
        let mut bytes = params.to_vec();
        if let Some(first) = bytes.get_mut(0..4) {
            first.copy_from_slice(&OUTPUT_SLOT.to_ne_bytes());
        }
        bytes
    }

    /// One launch of `pipeline` (raykit's `VkPipeline`, `layout` its layout) with
    /// raykit's SBT `regions`, `params` as push constants (see
    /// [`AshTracer::params_with_output`]); returns the seconds of the trace (GPU
    /// timestamps, else the wall time of the submission).
    pub fn launch(
        &self,
        pipeline: vk::Pipeline,
        layout: vk::PipelineLayout,
        regions: &[vk::StridedDeviceAddressRegionKHR; 4],
        params: &[u8],
        dims: [u32; 3],
    ) -> anyhow::Result<f64> {
        let d = self.device;
        let [raygen, miss, hit, callable] = regions;
        self.submitter.timed(
            |cmd| {
                // SAFETY: the pipeline and layout belong to live raykit objects; the set is the tracer's.
                unsafe {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, pipeline);
                    d.cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        layout,
                        0,
                        &[self.set],
                        &[],
                    );
                    d.cmd_push_constants(cmd, layout, crate::launch::rt_stages(), 0, params);
                }
            },
            // SAFETY: raykit's SBT regions, of its live pipeline bound above.
            |cmd| unsafe { self.rt.cmd_trace_rays(cmd, raygen, miss, hit, callable, dims[0], dims[1], dims[2]) },
        )
    }

    /// The output buffer's words, copied out of device-local memory.
    pub fn picture(&self) -> anyhow::Result<Vec<u32>> {
        self.submitter.picture(&self.output)
    }
}

impl Drop for AshTracer<'_> {
    fn drop(&mut self) {
        self.submitter.destroy();
        self.output.unmap(self.device);
        // SAFETY: nothing is in flight (every submission was waited for); children first.
        unsafe {
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_descriptor_pool(self.descriptor_pool, None);
            for b in [&self.output.device, &self.output.readback] {
                self.device.destroy_buffer(b.buffer, None);
                self.device.free_memory(b.memory, None);
            }
        }
    }
}
