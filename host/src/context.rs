//! The device context: one Vulkan device with ray-tracing pipelines, like OptiX's
//! `OptixDeviceContext`.
//!
//! [`Context::new`] picks the first physical device that has
//! [`VK_KHR_ray_tracing_pipeline`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_ray_tracing_pipeline.html)
//! and the features raykit needs; when none has, the error lists every device seen
//! and what each lacks. The context owns the logical device, the queue, the memory
//! allocator (gpu-allocator) and the bindless buffer table; every other raykit
//! object keeps it alive through an `Arc`, so no handle outlives its device.

use std::ffi::{c_void, CStr};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;

use crate::buffer_table::BufferTable;
use crate::cache::{CacheKey, DiskCache, PipelineCacheInfo, PipelineCacheLocation};
use crate::error::{DeviceReport, Error, Result};
use crate::log::{LogCallback, LoggedObject, MessageLog, Severity, ValidationMessage};

/// Device extensions raykit needs.
const REQUIRED_EXTENSIONS: [&CStr; 3] = [
    ash::khr::ray_tracing_pipeline::NAME,
    ash::khr::acceleration_structure::NAME,
    ash::khr::deferred_host_operations::NAME,
];

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Enable the Khronos validation layer and collect its messages in
    /// [`Context::messages`]. `None` means: on when the environment variable
    /// `RAYKIT_VALIDATION` is `1`.
    pub validation: Option<bool>,
    /// Use the first ray-tracing device whose name contains this string.
    pub device_name_contains: Option<String>,
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

/// A Vulkan device with ray tracing, and what every raykit object shares.
#[derive(Clone)]
pub struct Context {
    pub(crate) inner: Arc<ContextInner>,
}

pub(crate) struct ContextInner {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Owned by the messenger callback's user data; freed after the messenger.
    log_ptr: *const MessageLog,
    pub(crate) log: MessageLog,
    pub(crate) device: ash::Device,
    pub(crate) rt: ash::khr::ray_tracing_pipeline::Device,
    pub(crate) accel: ash::khr::acceleration_structure::Device,
    queue: Mutex<vk::Queue>,
    queue_family: u32,
    command_pool: Mutex<vk::CommandPool>,
    /// Finished command buffers and their (reset) fences, reused by later
    /// submissions: allocating both for every launch costs more than the launch
    /// on some drivers. Guarded with the pool's lock held too.
    recycled: Mutex<Vec<(vk::CommandBuffer, vk::Fence)>>,
    pub(crate) allocator: ManuallyDrop<Mutex<gpu_allocator::vulkan::Allocator>>,
    pub(crate) buffer_table: ManuallyDrop<BufferTable>,
    pub(crate) limits: DeviceLimits,
    /// Largest launch width, height and depth: `maxComputeWorkGroupCount[i] ×
    /// maxComputeWorkGroupSize[i]`, as `vkCmdTraceRaysKHR` requires.
    pub(crate) launch_dimension_limits: [u64; 3],
    /// Whether `VK_KHR_shader_non_semantic_info` is enabled, which modules with
    /// debug info (`SPV_KHR_non_semantic_info`) need.
    pub(crate) non_semantic_info: bool,
    /// Whether `VK_KHR_pipeline_library` is enabled (see [`crate::PipelineLibrary`]).
    pub(crate) pipeline_library: bool,
    /// Whether the driver is lavapipe (Mesa's CPU driver), whose workarounds
    /// raykit applies (see [`crate::pipeline::library`]).
    pub(crate) lavapipe: bool,
    device_name: String,
    /// The compile cache every pipeline creation goes through.
    pub(crate) pipeline_cache: DiskCache,
    /// `vkSetDebugUtilsObjectNameEXT`, when VK_EXT_debug_utils is on.
    debug_names: Option<ash::ext::debug_utils::Device>,
}

// SAFETY: the raw `log_ptr` points at a `MessageLog` (itself Send + Sync) that lives
// as long as the context; every other field is Send + Sync, and Vulkan objects that
// need external synchronisation (queue, command pool, allocator) sit behind mutexes.
unsafe impl Send for ContextInner {}
// SAFETY: as above.
unsafe impl Sync for ContextInner {}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: `user_data` is the `MessageLog` box installed with the messenger, alive
    // until after the messenger is destroyed; `data` is valid for this call.
    unsafe {
        if user_data.is_null() || data.is_null() {
            return vk::FALSE;
        }
        let log = &*(user_data as *const MessageLog);
        let data = &*data;
        let text = if data.p_message.is_null() {
            String::new()
        } else {
            CStr::from_ptr(data.p_message).to_string_lossy().into_owned()
        };
        let id = if data.p_message_id_name.is_null() {
            String::new()
        } else {
            CStr::from_ptr(data.p_message_id_name).to_string_lossy().into_owned()
        };
        let objects = if data.p_objects.is_null() || data.object_count == 0 {
            Vec::new()
        } else {
            std::slice::from_raw_parts(data.p_objects, data.object_count as usize)
                .iter()
                .map(|o| LoggedObject {
                    object_type: format!("{:?}", o.object_type),
                    handle: o.object_handle,
                    name: (!o.p_object_name.is_null())
                        .then(|| CStr::from_ptr(o.p_object_name).to_string_lossy().into_owned()),
                })
                .collect()
        };
        let severity = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
            Severity::Error
        } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
            Severity::Warning
        } else {
            Severity::Info
        };
        log.push(ValidationMessage { severity, id, text, objects });
    }
    vk::FALSE
}

/// Serialises the creation and destruction of instances and devices across the
/// process: every `vkCreateInstance`, `vkCreateDevice`, `vkDestroyDevice` and
/// `vkDestroyInstance` raykit makes holds this lock.
///
/// NVIDIA's driver (580, H100) sometimes never returns from `vkDestroyDevice`
/// when other threads create or destroy their own instance and device at the
/// same time: in a plain-ash program of 4 threads, each making an instance and a
/// device, submitting 200 empty command buffers and destroying both, 8 of 40
/// runs hung in `vkDestroyDevice`; with these calls under one lock, 0 of 20.
/// This does not make several contexts used at once from several threads safe
/// on that driver: raykit's own 4-thread runs still hang there (in a context's
/// drop, or while one thread links a pipeline and others make contexts). One
/// context shared by all threads works (`Context` is `Clone + Send + Sync`).
fn lifecycle_lock() -> std::sync::MutexGuard<'static, ()> {
    static LIFECYCLE: Mutex<()> = Mutex::new(());
    LIFECYCLE.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Keeps the Vulkan loader and the drivers it loads in memory for the life of
/// the process, through one instance made on the first [`Context::new`] and never
/// destroyed (no layers, no devices: it holds nothing else).
///
/// The loader unloads a driver's library when the last instance using it is
/// destroyed, and loads it again for the next one. NVIDIA's driver (580 on an
/// H100) does not survive that: after about thirty contexts made and destroyed
/// one after the other in one process, `vkCreateInstance` fails with "Unable to
/// find a Vulkan driver". Keeping one instance alive keeps the library loaded.
fn keep_driver_loaded(entry: &ash::Entry) {
    static KEEP_ALIVE: std::sync::OnceLock<Option<(ash::Entry, ash::Instance)>> = std::sync::OnceLock::new();
    KEEP_ALIVE.get_or_init(|| {
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_2);
        let info = vk::InstanceCreateInfo::default().application_info(&app);
        let _lifecycle = lifecycle_lock();
        // SAFETY: a valid create info with no layers or extensions; the instance is
        // intentionally never destroyed (see above).
        unsafe { entry.create_instance(&info, None) }.ok().map(|instance| (entry.clone(), instance))
    });
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

/// The feature structs raykit enables, chained for query or creation.
#[derive(Default)]
struct Features {
    rt: vk::PhysicalDeviceRayTracingPipelineFeaturesKHR<'static>,
    accel: vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'static>,
    v12: vk::PhysicalDeviceVulkan12Features<'static>,
    base: vk::PhysicalDeviceFeatures,
}

impl Features {
    /// Queries what `physical` supports.
    fn query(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Features {
        let mut f = Features::default();
        let mut features2 =
            vk::PhysicalDeviceFeatures2::default().push_next(&mut f.rt).push_next(&mut f.accel).push_next(&mut f.v12);
        // SAFETY: `physical` came from this instance; the chain is well formed.
        unsafe { instance.get_physical_device_features2(physical, &mut features2) };
        f.base = features2.features;
        f.rt.p_next = std::ptr::null_mut();
        f.accel.p_next = std::ptr::null_mut();
        f.v12.p_next = std::ptr::null_mut();
        f
    }

    /// The subset raykit turns on.
    fn required() -> Features {
        Features {
            rt: vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true),
            accel: vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true),
            v12: vk::PhysicalDeviceVulkan12Features::default()
                .buffer_device_address(true)
                .scalar_block_layout(true)
                .vulkan_memory_model(true)
                .runtime_descriptor_array(true)
                .descriptor_binding_partially_bound(true)
                .descriptor_binding_storage_buffer_update_after_bind(true)
                .descriptor_indexing(true),
            // Device programs access buffers without bounds checks and rely on
            // robustBufferAccess for out-of-range indices (see raykit-device).
            base: vk::PhysicalDeviceFeatures::default().shader_int64(true).robust_buffer_access(true),
        }
    }

    /// Names of required features `self` lacks.
    fn missing(&self) -> Vec<String> {
        let checks: [(&str, vk::Bool32); 10] = [
            ("vulkanMemoryModel", self.v12.vulkan_memory_model),
            ("rayTracingPipeline", self.rt.ray_tracing_pipeline),
            ("accelerationStructure", self.accel.acceleration_structure),
            ("bufferDeviceAddress", self.v12.buffer_device_address),
            ("scalarBlockLayout", self.v12.scalar_block_layout),
            ("runtimeDescriptorArray", self.v12.runtime_descriptor_array),
            ("descriptorBindingPartiallyBound", self.v12.descriptor_binding_partially_bound),
            (
                "descriptorBindingStorageBufferUpdateAfterBind",
                self.v12.descriptor_binding_storage_buffer_update_after_bind,
            ),
            ("shaderInt64", self.base.shader_int64),
            ("robustBufferAccess", self.base.robust_buffer_access),
        ];
        checks.iter().filter(|(_, on)| *on == vk::FALSE).map(|(n, _)| format!("feature {n}")).collect()
    }
}

/// Checks one physical device; returns its report (empty `missing` = usable).
fn inspect_device(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Result<(DeviceReport, Option<u32>)> {
    // SAFETY: `physical` came from this instance.
    let props = unsafe { instance.get_physical_device_properties(physical) };
    let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut missing = Vec::new();
    if props.api_version < vk::API_VERSION_1_2 {
        missing.push("Vulkan 1.2".to_owned());
    }
    // SAFETY: as above.
    let extensions = unsafe { instance.enumerate_device_extension_properties(physical) }
        .map_err(Error::vk("vkEnumerateDeviceExtensionProperties"))?;
    for required in REQUIRED_EXTENSIONS {
        let has = extensions.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == required));
        if !has {
            missing.push(format!("extension {}", required.to_string_lossy()));
        }
    }
    if props.api_version >= vk::API_VERSION_1_2 {
        missing.extend(Features::query(instance, physical).missing());
    }
    // SAFETY: as above.
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let queue_family = families.iter().position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE)).map(|i| i as u32);
    if queue_family.is_none() {
        missing.push("a compute queue".to_owned());
    }
    let report = DeviceReport {
        name,
        device_type: format!("{:?}", props.device_type),
        api_version: version_string(props.api_version),
        missing,
    };
    Ok((report, queue_family))
}

impl Context {
    /// Creates a context on the first device with ray-tracing pipelines.
    pub fn new(options: ContextOptions) -> Result<Context> {
        let validation =
            options.validation.unwrap_or_else(|| std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1"));
        // SAFETY: loading the system Vulkan loader runs its initialisation code; we
        // trust the installed loader as every Vulkan program does.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::LoaderMissing(e.to_string()))?;
        keep_driver_loaded(&entry);

        let mut layers: Vec<*const std::ffi::c_char> = Vec::new();
        let mut instance_extensions: Vec<*const std::ffi::c_char> = Vec::new();
        // The messenger (and debug names) need VK_EXT_debug_utils: always there with
        // the validation layer; for a log callback alone, where the loader has it.
        // SAFETY: plain enumeration call.
        let loader_has_debug_utils = unsafe { entry.enumerate_instance_extension_properties(None) }.is_ok_and(|exts| {
            exts.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::ext::debug_utils::NAME))
        });
        let debug = validation || (options.log_callback.is_some() && loader_has_debug_utils);
        if debug && !validation {
            instance_extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        if validation {
            // SAFETY: plain enumeration call.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .map_err(Error::vk("vkEnumerateInstanceLayerProperties"))?;
            if !available.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER)) {
                return Err(Error::ValidationLayerMissing);
            }
            layers.push(VALIDATION_LAYER.as_ptr());
            instance_extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let app_info = vk::ApplicationInfo::default()
            .application_name(c"raykit")
            .engine_name(c"raykit")
            .api_version(vk::API_VERSION_1_2);
        let log = MessageLog::with_callback(options.log_callback.clone());
        let log_ptr = Box::into_raw(Box::new(log.clone())) as *const MessageLog;
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(log_ptr as *mut c_void);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&instance_extensions);
        if debug {
            // Also catches messages of instance creation and destruction.
            instance_info = instance_info.push_next(&mut messenger_info);
        }
        let created = {
            let _lifecycle = lifecycle_lock();
            // SAFETY: the create info and everything it points to live across the call.
            unsafe { entry.create_instance(&instance_info, None) }
        };
        let instance = match created {
            Ok(i) => i,
            Err(e) => {
                // SAFETY: the box was made above and is not shared yet.
                drop(unsafe { Box::from_raw(log_ptr as *mut MessageLog) });
                return Err(Error::vk("vkCreateInstance")(e));
            }
        };
        // From here on, `Partial` destroys what was made if a later step fails.
        let mut partial = Partial { entry, instance, debug: None, log_ptr, armed: true };
        let instance = partial.instance();
        let entry = partial.entry();
        if debug {
            let debug_utils = ash::ext::debug_utils::Instance::new(entry, instance);
            // SAFETY: the create info is valid; the callback's user data outlives the messenger.
            let messenger = unsafe { debug_utils.create_debug_utils_messenger(&messenger_info, None) }
                .map_err(Error::vk("vkCreateDebugUtilsMessengerEXT"))?;
            partial.debug = Some((debug_utils, messenger));
        }
        let instance = partial.instance();

        // SAFETY: plain enumeration call on a live instance.
        let physical_devices =
            unsafe { instance.enumerate_physical_devices() }.map_err(Error::vk("vkEnumeratePhysicalDevices"))?;
        let mut reports = Vec::new();
        let mut chosen = None;
        for &physical in &physical_devices {
            let (report, family) = inspect_device(instance, physical)?;
            let name_ok = options.device_name_contains.as_ref().is_none_or(|want| report.name.contains(want.as_str()));
            if chosen.is_none() && report.missing.is_empty() && name_ok {
                if let Some(family) = family {
                    chosen = Some((physical, family, report.name.clone()));
                }
            }
            reports.push(report);
        }
        let Some((physical_device, queue_family, device_name)) = chosen else {
            if let Some(want) = &options.device_name_contains {
                for r in &mut reports {
                    if !r.name.contains(want.as_str()) {
                        r.missing.push(format!("a name containing {want:?}"));
                    }
                }
            }
            return Err(Error::NoRayTracingDevice { devices: reports });
        };

        let mut features = Features::required();
        let priorities = [1.0f32];
        let queue_infos =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let mut extension_ptrs: Vec<_> = REQUIRED_EXTENSIONS.iter().map(|e| e.as_ptr()).collect();
        // Optional: lets modules carry debug info (glslang's -gVS, NonSemantic.Shader.DebugInfo.100).
        // SAFETY: `physical_device` came from this instance.
        let device_extensions = unsafe { instance.enumerate_device_extension_properties(physical_device) }
            .map_err(Error::vk("vkEnumerateDeviceExtensionProperties"))?;
        let has_extension = |name: &std::ffi::CStr| {
            device_extensions.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
        };
        let non_semantic_info = has_extension(ash::khr::shader_non_semantic_info::NAME);
        if non_semantic_info {
            extension_ptrs.push(ash::khr::shader_non_semantic_info::NAME.as_ptr());
        }
        // Optional: pipeline libraries (`PipelineLibrary`, `Pipeline::link`).
        let pipeline_library = has_extension(ash::khr::pipeline_library::NAME);
        if pipeline_library {
            extension_ptrs.push(ash::khr::pipeline_library::NAME.as_ptr());
        }
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_extension_names(&extension_ptrs)
            .enabled_features(&features.base)
            .push_next(&mut features.rt)
            .push_next(&mut features.accel)
            .push_next(&mut features.v12);
        let device = {
            let _lifecycle = lifecycle_lock();
            // SAFETY: the physical device supports every extension and feature enabled
            // (checked by `inspect_device`); the create info lives across the call.
            unsafe { instance.create_device(physical_device, &device_info, None) }
        }
        .map_err(Error::vk("vkCreateDevice"))?;
        let device_guard = DeviceGuard { device: device.clone(), armed: true };

        let DeviceProperties { limits, driver_id, launch_dimension_limits } =
            query_properties(instance, physical_device);
        let lavapipe = driver_id == vk::DriverId::MESA_LLVMPIPE;
        let debug_names = debug.then(|| ash::ext::debug_utils::Device::new(instance, &device));
        let rt = ash::khr::ray_tracing_pipeline::Device::new(instance, &device);
        let accel = ash::khr::acceleration_structure::Device::new(instance, &device);
        // SAFETY: queue family and index 0 were requested at device creation.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER | vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid device and create info.
        let command_pool =
            unsafe { device.create_command_pool(&pool_info, None) }.map_err(Error::vk("vkCreateCommandPool"))?;
        let pool_guard = PoolGuard(&device, command_pool);
        let allocator = gpu_allocator::vulkan::Allocator::new(&gpu_allocator::vulkan::AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            buffer_device_address: true,
            allocation_sizes: Default::default(),
        })
        .map_err(|source| Error::Allocation { what: "the memory allocator", source })?;
        let buffer_table = BufferTable::new(&device, instance, physical_device)?;
        std::mem::forget(pool_guard);
        // SAFETY: `physical_device` belongs to `instance`.
        let properties = unsafe { instance.get_physical_device_properties(physical_device) };
        let pipeline_cache = DiskCache::open(&device, CacheKey::of(&properties), &options.pipeline_cache);

        let device = device_guard.take();
        let (entry, instance, debug) = partial.take();
        Ok(Context {
            inner: Arc::new(ContextInner {
                _entry: entry,
                instance,
                debug,
                log_ptr,
                log,
                device,
                rt,
                accel,
                queue: Mutex::new(queue),
                queue_family,
                command_pool: Mutex::new(command_pool),
                recycled: Mutex::new(Vec::new()),
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                buffer_table: ManuallyDrop::new(buffer_table),
                limits,
                launch_dimension_limits,
                non_semantic_info,
                pipeline_library,
                lavapipe,
                device_name,
                pipeline_cache,
                debug_names,
            }),
        })
    }

    /// The name of the device in use.
    pub fn device_name(&self) -> &str {
        &self.inner.device_name
    }

    /// Whether this device links pipelines from libraries
    /// (`VK_KHR_pipeline_library`; see [`crate::PipelineLibrary`]).
    pub fn supports_pipeline_libraries(&self) -> bool {
        self.inner.pipeline_library
    }

    /// The device's ray-tracing limits.
    pub fn limits(&self) -> &DeviceLimits {
        &self.inner.limits
    }

    /// Validation messages collected so far (empty when validation is off). The
    /// returned log is shared: it keeps collecting, also while the context is
    /// destroyed, so a test can check for leaks reported at destruction.
    pub fn messages(&self) -> MessageLog {
        self.inner.log.clone()
    }

    /// The queue family used for all work.
    pub fn queue_family(&self) -> u32 {
        self.inner.queue_family
    }

    /// Names `handle` (an object of this context's device) for validation messages
    /// and debugging tools (`vkSetDebugUtilsObjectNameEXT`); does nothing without
    /// VK_EXT_debug_utils. raykit names the objects it makes itself.
    pub fn set_debug_name<H: vk::Handle>(&self, handle: H, name: &str) {
        self.inner.set_name(handle, name);
    }

    /// The compile cache: its file, whether it was loaded (warm), missing (cold)
    /// or refused, and its current size. See [`crate::cache`].
    pub fn pipeline_cache_info(&self) -> PipelineCacheInfo {
        self.inner.pipeline_cache.info(&self.inner.device)
    }

    /// Writes the compile cache to its file now (it is also written when the
    /// context is destroyed); returns the file, or `None` when the cache is off or
    /// empty.
    pub fn save_pipeline_cache(&self) -> Result<Option<std::path::PathBuf>> {
        self.inner.pipeline_cache.save(&self.inner.device)
    }

    /// The largest launch width, height and depth each on its own:
    /// `maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i]`, which
    /// `vkCmdTraceRaysKHR` requires besides the total of
    /// [`DeviceLimits::max_ray_dispatch_invocation_count`].
    pub fn max_launch_dimensions(&self) -> [u64; 3] {
        self.inner.launch_dimension_limits
    }

    /// Device memory raykit holds now, from its allocator (gpu-allocator): what
    /// live buffers and acceleration structures use, and the memory blocks
    /// reserved for them.
    pub fn memory_usage(&self) -> MemoryUsage {
        let report = self.inner.allocator().generate_report();
        MemoryUsage {
            allocations: report.allocations.len(),
            allocated_bytes: report.total_allocated_bytes,
            reserved_bytes: report.total_capacity_bytes,
            blocks: report.blocks.len(),
        }
    }
}

/// The Vulkan objects under a context, for interoperation and for comparisons with
/// hand-written Vulkan. Using them is `unsafe` ash code under the rules
/// [`crate::pipeline::raw`] states.
impl Context {
    /// The `ash` instance.
    pub fn raw_instance(&self) -> &ash::Instance {
        &self.inner.instance
    }
    /// The `ash` device.
    pub fn raw_device(&self) -> &ash::Device {
        &self.inner.device
    }
    /// The `VK_KHR_ray_tracing_pipeline` functions of the device.
    pub fn raw_ray_tracing(&self) -> &ash::khr::ray_tracing_pipeline::Device {
        &self.inner.rt
    }
    /// The bindless buffer table's descriptor set (set 0 of every raykit pipeline layout).
    pub fn raw_buffer_table_set(&self) -> vk::DescriptorSet {
        self.inner.buffer_table.set
    }
    /// The bindless buffer table's descriptor set layout.
    pub fn raw_buffer_table_layout(&self) -> vk::DescriptorSetLayout {
        self.inner.buffer_table.layout
    }
}

impl std::fmt::Debug for Context {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let inner = &self.inner;
        f.debug_struct("Context")
            .field("device", &inner.device_name)
            .field("queue_family", &inner.queue_family)
            .field("validation", &inner.debug.is_some())
            .field("pipeline_libraries", &inner.pipeline_library)
            .field("limits", &inner.limits)
            .finish_non_exhaustive()
    }
}

/// Device memory in use by one [`Context`] ([`Context::memory_usage`]).
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

impl ContextInner {
    /// Gives `handle` a debug name, so validation messages and tools name it. Does
    /// nothing without VK_EXT_debug_utils.
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(debug) = &self.debug_names else { return };
        let Ok(name) = std::ffi::CString::new(name) else { return };
        let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
        // SAFETY: `handle` is a live object of this device (callers name what they
        // just made); naming needs no external synchronisation of the object.
        let _ = unsafe { debug.set_debug_utils_object_name(&info) };
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, gpu_allocator::vulkan::Allocator> {
        // A panic while holding the lock cannot leave the allocator half-updated in a
        // way that matters more than losing the allocation; keep going.
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Work submitted to the queue and not yet waited for: a recorded command buffer
/// and the fence it signals. Dropping it waits for the work first, so buffers
/// the work uses may be freed after it.
pub(crate) struct Submission {
    ctx: Arc<ContextInner>,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    during: &'static str,
    waited: bool,
}

impl ContextInner {
    /// Records commands with `record` and submits them without waiting; the
    /// returned [`Submission`] is waited on (or dropped, which waits).
    pub(crate) fn submit(
        self: &Arc<Self>,
        during: &'static str,
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<Submission> {
        let device = &self.device;
        let pool = self.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        let reused = self.recycled.lock().unwrap_or_else(|p| p.into_inner()).pop();
        let (cmd, mut fence) = match reused {
            Some(pair) => pair,
            None => {
                let alloc_info = vk::CommandBufferAllocateInfo::default()
                    .command_pool(*pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1);
                // SAFETY: the pool is externally synchronised by the mutex held.
                let cmd = unsafe { device.allocate_command_buffers(&alloc_info) }
                    .map_err(Error::vk("vkAllocateCommandBuffers"))?[0];
                (cmd, vk::Fence::null())
            }
        };
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: a fresh or finished (recycled) command buffer of a pool made
            // with RESET_COMMAND_BUFFER, so beginning it resets it; recorded under
            // the pool's lock.
            unsafe { device.begin_command_buffer(cmd, &begin) }.map_err(Error::vk("vkBeginCommandBuffer"))?;
            record(cmd);
            // SAFETY: as above.
            unsafe { device.end_command_buffer(cmd) }.map_err(Error::vk("vkEndCommandBuffer"))?;
            if fence == vk::Fence::null() {
                // SAFETY: valid device.
                fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
                    .map_err(Error::vk("vkCreateFence"))?;
            }
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            let queue = self.queue.lock().unwrap_or_else(|p| p.into_inner());
            // SAFETY: the queue is externally synchronised by its mutex; the command
            // buffer is fully recorded; the fence is unsignalled (new or reset).
            unsafe { device.queue_submit(*queue, &submit, fence) }.map_err(|e| match e {
                vk::Result::ERROR_DEVICE_LOST => Error::DeviceLost { during },
                other => Error::Vulkan { call: "vkQueueSubmit", result: other },
            })
        })();
        if let Err(e) = result {
            // SAFETY: nothing was submitted: the command buffer and fence are idle.
            unsafe {
                if fence != vk::Fence::null() {
                    device.destroy_fence(fence, None);
                }
                device.free_command_buffers(*pool, &[cmd]);
            }
            return Err(e);
        }
        drop(pool);
        Ok(Submission { ctx: self.clone(), cmd, fence, during, waited: false })
    }
}

impl Submission {
    /// Whether the work has finished, without blocking.
    pub(crate) fn is_done(&self) -> Result<bool> {
        if self.waited {
            return Ok(true);
        }
        // SAFETY: the fence belongs to this device and is alive.
        unsafe { self.ctx.device.get_fence_status(self.fence) }.map_err(|e| match e {
            vk::Result::ERROR_DEVICE_LOST => Error::DeviceLost { during: self.during },
            other => Error::Vulkan { call: "vkGetFenceStatus", result: other },
        })
    }

    /// Blocks until the work has finished.
    pub(crate) fn wait(&mut self) -> Result<()> {
        if self.waited {
            return Ok(());
        }
        // SAFETY: the fence belongs to this device and was submitted.
        let waited = unsafe { self.ctx.device.wait_for_fences(&[self.fence], true, u64::MAX) };
        waited.map_err(|e| match e {
            vk::Result::ERROR_DEVICE_LOST => Error::DeviceLost { during: self.during },
            other => Error::Vulkan { call: "vkWaitForFences", result: other },
        })?;
        self.waited = true;
        Ok(())
    }
}

impl Drop for Submission {
    fn drop(&mut self) {
        // A failed wait means a lost device; destroying the objects is still allowed then.
        let waited = self.wait().is_ok();
        let pool = self.ctx.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        let device = &self.ctx.device;
        // Keep a few finished pairs for the next submissions.
        const KEEP: usize = 8;
        let mut recycled = self.ctx.recycled.lock().unwrap_or_else(|p| p.into_inner());
        // SAFETY: the work has finished (waited above), so the fence is signalled
        // and the command buffer idle.
        if waited && recycled.len() < KEEP && unsafe { device.reset_fences(&[self.fence]) }.is_ok() {
            recycled.push((self.cmd, self.fence));
            return;
        }
        // SAFETY: as above; the pool is locked.
        unsafe {
            device.destroy_fence(self.fence, None);
            device.free_command_buffers(*pool, &[self.cmd]);
        }
    }
}

/// What raykit reads of a physical device's properties, in one query.
struct DeviceProperties {
    limits: DeviceLimits,
    driver_id: vk::DriverId,
    launch_dimension_limits: [u64; 3],
}

fn query_properties(instance: &ash::Instance, physical: vk::PhysicalDevice) -> DeviceProperties {
    let mut rt = vk::PhysicalDeviceRayTracingPipelinePropertiesKHR::default();
    let mut accel = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 =
        vk::PhysicalDeviceProperties2::default().push_next(&mut rt).push_next(&mut accel).push_next(&mut driver);
    // SAFETY: the chain is well formed; `physical` belongs to `instance`.
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let limits = props2.properties.limits;
    let device_limits = DeviceLimits {
        shader_group_handle_size: rt.shader_group_handle_size,
        shader_group_handle_alignment: rt.shader_group_handle_alignment,
        shader_group_base_alignment: rt.shader_group_base_alignment,
        max_shader_group_stride: rt.max_shader_group_stride,
        max_ray_recursion_depth: rt.max_ray_recursion_depth,
        max_ray_dispatch_invocation_count: rt.max_ray_dispatch_invocation_count,
        max_ray_hit_attribute_size: rt.max_ray_hit_attribute_size,
        max_push_constants_size: limits.max_push_constants_size,
        max_uniform_buffer_range: limits.max_uniform_buffer_range,
        max_storage_buffer_range: limits.max_storage_buffer_range,
        min_uniform_buffer_offset_alignment: limits.min_uniform_buffer_offset_alignment,
        min_scratch_alignment: accel.min_acceleration_structure_scratch_offset_alignment,
        max_geometry_count: accel.max_geometry_count,
        max_primitive_count: accel.max_primitive_count,
        max_instance_count: accel.max_instance_count,
    };
    // `vkCmdTraceRaysKHR` takes at most `maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i]` per dimension.
    let launch_dimension_limits: [u64; 3] = std::array::from_fn(|i| {
        limits.max_compute_work_group_count[i] as u64 * limits.max_compute_work_group_size[i] as u64
    });
    DeviceProperties { limits: device_limits, driver_id: driver.driver_id, launch_dimension_limits }
}

impl Drop for ContextInner {
    fn drop(&mut self) {
        // SAFETY: every child object holds an `Arc` to this context, so none is
        // alive now; the device is idle after the wait; objects are destroyed in
        // reverse order of creation, the messenger last so it reports leaks.
        unsafe {
            let _ = self.device.device_wait_idle();
            // Errors cannot be returned from drop; `Context::save_pipeline_cache`
            // reports them to whoever wants to know.
            let _ = self.pipeline_cache.save(&self.device);
            self.pipeline_cache.destroy(&self.device);
            ManuallyDrop::take(&mut self.buffer_table).destroy(&self.device);
            ManuallyDrop::drop(&mut self.allocator);
            // Recycled fences; their command buffers go with the pool.
            for (_, fence) in self.recycled.get_mut().unwrap_or_else(|p| p.into_inner()).drain(..) {
                self.device.destroy_fence(fence, None);
            }
            let pool = self.command_pool.get_mut().unwrap_or_else(|p| p.into_inner());
            self.device.destroy_command_pool(*pool, None);
            let lifecycle = lifecycle_lock();
            self.device.destroy_device(None);
            drop(lifecycle);
            if let Some((debug_utils, messenger)) = self.debug.take() {
                debug_utils.destroy_debug_utils_messenger(messenger, None);
            }
            let _lifecycle = lifecycle_lock();
            self.instance.destroy_instance(None);
            drop(Box::from_raw(self.log_ptr as *mut MessageLog));
        }
        self.log.mark_destroyed();
    }
}

/// Destroys the instance (and messenger) if context creation fails part-way.
struct Partial {
    entry: ash::Entry,
    instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    log_ptr: *const MessageLog,
    /// Cleared by `take`, when the context owns all of it.
    armed: bool,
}

impl Partial {
    fn instance(&self) -> &ash::Instance {
        &self.instance
    }
    fn entry(&self) -> &ash::Entry {
        &self.entry
    }
    fn take(
        mut self,
    ) -> (ash::Entry, ash::Instance, Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>) {
        self.armed = false;
        (self.entry.clone(), self.instance.clone(), self.debug.take())
    }
}

impl Drop for Partial {
    fn drop(&mut self) {
        if !self.armed {
            return;
        }
        // SAFETY: only objects created above and not handed to a context remain.
        unsafe {
            if let Some((debug_utils, messenger)) = self.debug.take() {
                debug_utils.destroy_debug_utils_messenger(messenger, None);
            }
            let _lifecycle = lifecycle_lock();
            self.instance.destroy_instance(None);
            drop(Box::from_raw(self.log_ptr as *mut MessageLog));
        }
    }
}

/// Destroys the device if context creation fails after it was made.
struct DeviceGuard {
    device: ash::Device,
    /// Cleared by `take`, when the context owns the device.
    armed: bool,
}
impl DeviceGuard {
    fn take(mut self) -> ash::Device {
        self.armed = false;
        self.device.clone()
    }
}
impl Drop for DeviceGuard {
    fn drop(&mut self) {
        if self.armed {
            let _lifecycle = lifecycle_lock();
            // SAFETY: nothing else uses the device yet.
            unsafe { self.device.destroy_device(None) };
        }
    }
}

/// Destroys the command pool if context creation fails after it was made.
struct PoolGuard<'a>(&'a ash::Device, vk::CommandPool);
impl Drop for PoolGuard<'_> {
    fn drop(&mut self) {
        // SAFETY: the pool has no command buffers yet.
        unsafe { self.0.destroy_command_pool(self.1, None) };
    }
}
