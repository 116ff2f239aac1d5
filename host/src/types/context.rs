//! What a context is made with and reports: its backend and options, the device's
//! limits and the memory in use.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::cache::PipelineCacheLocation;
use crate::log::LogCallback;

/// Device memory in use by one [`Context`](crate::Context) ([`Context::memory_usage`](crate::Context::memory_usage)).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct MemoryUsage {
    /// Live allocations.
    pub allocations: usize,
    /// Bytes they use.
    pub allocated_bytes: u64,
    /// Memory blocks reserved from the driver.
    pub blocks: usize,
    /// Bytes of those blocks.
    pub reserved_bytes: u64,
}
/// Hands out context ids.
pub(crate) fn next_context_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Where a [`Context`](crate::Context) runs device programs.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// A Vulkan device with ray-tracing pipelines: a GPU, or Mesa's lavapipe.
    #[default]
    Vulkan,
    /// The host's CPUs: the device crates' programs, compiled for the host and
    /// linked into the program, called as Rust functions (see [`crate::cpu`]).
    /// Needs no Vulkan driver.
    Cpu,
}

impl Backend {
    /// The backend `RAYKIT_BACKEND` names (`vulkan` or `cpu`), if it is set.
    pub fn from_env() -> Option<Backend> {
        match std::env::var("RAYKIT_BACKEND").ok()?.to_ascii_lowercase().as_str() {
            "cpu" => Some(Backend::Cpu),
            "vulkan" => Some(Backend::Vulkan),
            _ => None,
        }
    }
}

/// How to create a [`Context`](crate::Context).
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// The backend. `None` means: what the environment variable `RAYKIT_BACKEND`
    /// says (`cpu` or `vulkan`), else Vulkan.
    pub backend: Option<Backend>,
    /// Threads of the CPU backend's pool; `None` means `RAYKIT_CPU_THREADS`, else
    /// one per logical CPU. Results do not depend on it.
    pub cpu_threads: Option<usize>,
    /// Whether the CPU backend traces camera rays in packets: sixteen invocations
    /// run side by side, and their traces from the point each invocation first
    /// traced from, into scenes whose triangles run no program while a ray
    /// traverses, walk the tree together (several times faster for coherent
    /// rays). `None` means on, unless the environment variable
    /// `RAYKIT_CPU_PACKETS` is `0`. Results do not depend on it, except which of
    /// two hits at exactly the same distance is the closest.
    pub cpu_packets: Option<bool>,
    /// Enable the Khronos validation layer and collect its messages in
    /// [`Context::messages`](crate::Context::messages). `None` means: on when the environment variable
    /// `RAYKIT_VALIDATION` is `1`. The layer is a property of the Vulkan instance:
    /// contexts with validation and contexts without it use two devices on one GPU,
    /// which NVIDIA's driver may not tolerate when both work at once; keep one
    /// setting per process there.
    pub validation: Option<bool>,
    /// Use the first ray-tracing device whose name contains this string.
    /// Contexts made for the same GPU (with the same validation setting) share its
    /// `VkDevice`.
    pub device_name_contains: Option<String>,
    /// Use the `n`-th usable ray-tracing device (counted from 0 among those
    /// `device_name_contains` lets through, in the Vulkan loader's order) instead
    /// of the first; [`DeviceError::DeviceIndexOutOfRange`](crate::DeviceError::DeviceIndexOutOfRange) lists them when there are
    /// fewer. [`Context::all`](crate::Context::all) makes one context per device this way.
    pub device_index: Option<usize>,
    /// Where the on-disk compile cache lives, or [`PipelineCacheLocation::Off`]
    /// (see [`crate::cache`]). On by default.
    pub pipeline_cache: PipelineCacheLocation,
    /// Called with every warning and error the debug messenger reports (OptiX's
    /// log callback; see [`crate::log`]). Turns `VK_EXT_debug_utils` on even
    /// without validation, where the loader has it.
    pub log_callback: Option<LogCallback>,
}

/// Ray-tracing limits and SBT layout constants of the device.
#[derive(Copy, Clone, Debug)]
pub struct DeviceLimits {
    /// `shaderGroupHandleSize`.
    pub shader_group_handle_size: u32,
    /// `shaderGroupHandleAlignment`.
    pub shader_group_handle_alignment: u32,
    /// `shaderGroupBaseAlignment`.
    pub shader_group_base_alignment: u32,
    /// `maxShaderGroupStride`.
    pub max_shader_group_stride: u32,
    /// `maxRayRecursionDepth`.
    pub max_ray_recursion_depth: u32,
    /// `maxRayDispatchInvocationCount`.
    pub max_ray_dispatch_invocation_count: u32,
    /// `maxRayHitAttributeSize`.
    pub max_ray_hit_attribute_size: u32,
    /// `maxPushConstantsSize`.
    pub max_push_constants_size: u32,
    /// `maxUniformBufferRange`.
    pub max_uniform_buffer_range: u32,
    /// `maxStorageBufferRange`: the most bytes one buffer in the buffer table may have.
    pub max_storage_buffer_range: u32,
    /// `minUniformBufferOffsetAlignment`.
    pub min_uniform_buffer_offset_alignment: u64,
    /// `minAccelerationStructureScratchOffsetAlignment`.
    pub min_scratch_alignment: u32,
    /// `maxGeometryCount` of acceleration structures.
    pub max_geometry_count: u64,
    /// `maxPrimitiveCount` of acceleration structures.
    pub max_primitive_count: u64,
    /// `maxInstanceCount` of acceleration structures.
    pub max_instance_count: u64,
}
