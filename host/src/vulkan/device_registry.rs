//! The process-wide registry of instances and devices behind [`crate::Context`]:
//! one `VkDevice` per GPU per process, reference-counted by the contexts using it
//! (the module docs of [`crate::context`] say what is shared and what is not). See
//! [Devices and queues](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#devsandqueues).

use std::ffi::{c_void, CStr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;

use crate::error::DeviceError;
use crate::error::{DeviceReport, Error, Result};
use crate::log::Routes;
use crate::types::context::DeviceLimits;
use crate::vulkan::messenger::debug_callback;

/// Device extensions raykit needs.
const REQUIRED_EXTENSIONS: [&CStr; 4] = [
    ash::khr::ray_tracing_pipeline::NAME,
    ash::khr::acceleration_structure::NAME,
    ash::khr::deferred_host_operations::NAME,
    // Defined device reads through null and stale buffer handles and past a
    // buffer's end (`nullDescriptor`, `robustBufferAccess2`; see `raykit_device::Buffer`).
    ash::ext::robustness2::NAME,
];

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// A process-wide Vulkan instance, with its debug messenger. Never destroyed: it
/// keeps the loader and drivers loaded for the life of the process (NVIDIA's driver
/// does not survive being unloaded and loaded again many times in one process).
pub(crate) struct SharedInstance {
    pub(crate) entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    /// Whether `VK_EXT_debug_utils` is on (debug names and the messenger).
    pub(crate) debug_utils: bool,
    /// Whether `VK_KHR_surface` and the window systems' surface extensions the
    /// loader has are on (windows can present raykit's results).
    pub(crate) surface: bool,
    /// Where the messenger delivers messages: the contexts made on this instance.
    pub(crate) routes: &'static Routes,
    _messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

/// The registry: instances by validation setting, devices with their context counts.
struct Registry {
    /// `[without validation, with validation]`.
    instances: [Option<&'static SharedInstance>; 2],
    devices: Vec<Registered>,
}

struct Registered {
    device: Arc<SharedDevice>,
    contexts: usize,
}

fn registry() -> MutexGuard<'static, Registry> {
    static REGISTRY: Mutex<Registry> = Mutex::new(Registry { instances: [None, None], devices: Vec::new() });
    REGISTRY.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The process's instance with or without the validation layer, made on first use.
pub(crate) fn instance(validation: bool) -> Result<&'static SharedInstance> {
    let mut registry = registry();
    if let Some(instance) = registry.instances[validation as usize] {
        return Ok(instance);
    }
    let instance: &'static SharedInstance = Box::leak(Box::new(create_instance(validation)?));
    registry.instances[validation as usize] = Some(instance);
    Ok(instance)
}

fn create_instance(validation: bool) -> Result<SharedInstance> {
    // SAFETY: loading the system Vulkan loader runs its initialisation code; we
    // trust the installed loader as every Vulkan program does.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Device(DeviceError::LoaderMissing(e.to_string())))?;
    let mut layers: Vec<*const std::ffi::c_char> = Vec::new();
    // The messenger and debug names need VK_EXT_debug_utils: always there with the
    // validation layer; without it, where the loader has it.
    // SAFETY: plain enumeration call.
    let loader_has_debug_utils = unsafe { entry.enumerate_instance_extension_properties(None) }.is_ok_and(|exts| {
        exts.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::ext::debug_utils::NAME))
    });
    if validation {
        // SAFETY: plain enumeration call.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .map_err(Error::vk("vkEnumerateInstanceLayerProperties"))?;
        if !available.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER)) {
            return Err(Error::Device(DeviceError::ValidationLayerMissing));
        }
        layers.push(VALIDATION_LAYER.as_ptr());
    }
    let debug_utils = validation || loader_has_debug_utils;
    let mut extensions: Vec<*const std::ffi::c_char> = Vec::new();
    if debug_utils {
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let surface_extensions = surface_extensions(&entry);
    let surface = !surface_extensions.is_empty();
    extensions.extend(surface_extensions.iter().map(|e| e.as_ptr()));
    let app_info = vk::ApplicationInfo::default()
        .application_name(c"raykit")
        .engine_name(c"raykit")
        .api_version(vk::API_VERSION_1_2);
    // Lives as long as the instance (forever): the messenger's user data.
    let routes: &'static Routes = Box::leak(Box::default());
    let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(routes as *const Routes as *mut c_void);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if debug_utils {
        // Also catches messages of instance creation.
        info = info.push_next(&mut messenger_info);
    }
    // SAFETY: the create info and everything it points to live across the call.
    let instance = unsafe { entry.create_instance(&info, None) }.map_err(|result| match result {
        // The loader found no driver at all: no device to report.
        vk::Result::ERROR_INCOMPATIBLE_DRIVER => Error::Device(DeviceError::NoRayTracingDevice { devices: Vec::new() }),
        other => Error::Device(DeviceError::Vulkan { call: "vkCreateInstance", result: other }),
    })?;
    let messenger = if debug_utils {
        let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
        // SAFETY: the create info is valid; its user data lives forever.
        match unsafe { loader.create_debug_utils_messenger(&messenger_info, None) } {
            Ok(messenger) => Some((loader, messenger)),
            Err(e) => {
                // SAFETY: nothing was made on the instance.
                unsafe { instance.destroy_instance(None) };
                return Err(Error::vk("vkCreateDebugUtilsMessengerEXT")(e));
            }
        }
    } else {
        None
    };
    Ok(SharedInstance { entry, instance, debug_utils, surface, routes, _messenger: messenger })
}

/// The window systems' surface extensions raykit enables where the loader has them.
const PLATFORM_SURFACE_EXTENSIONS: [&CStr; 5] = [
    ash::khr::xlib_surface::NAME,
    ash::khr::xcb_surface::NAME,
    ash::khr::wayland_surface::NAME,
    ash::khr::win32_surface::NAME,
    ash::ext::metal_surface::NAME,
];

/// `VK_KHR_surface` and the platform surface extensions the loader has (none
/// when it lacks `VK_KHR_surface` or every platform one): enabled on every
/// instance, so a window can get a swapchain on raykit's own device (an unused
/// surface extension costs nothing).
fn surface_extensions(entry: &ash::Entry) -> Vec<&'static CStr> {
    // SAFETY: plain enumeration call.
    let Ok(available) = (unsafe { entry.enumerate_instance_extension_properties(None) }) else { return Vec::new() };
    let has = |name: &CStr| available.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name));
    let platform: Vec<&'static CStr> = PLATFORM_SURFACE_EXTENSIONS.into_iter().filter(|e| has(e)).collect();
    if !has(ash::khr::surface::NAME) || platform.is_empty() {
        return Vec::new();
    }
    std::iter::once(ash::khr::surface::NAME).chain(platform).collect()
}

/// A logical device shared by every context made for one physical device.
pub(crate) struct SharedDevice {
    pub(crate) instance: &'static SharedInstance,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) device: ash::Device,
    pub(crate) rt: ash::khr::ray_tracing_pipeline::Device,
    pub(crate) accel: ash::khr::acceleration_structure::Device,
    /// `vkSetDebugUtilsObjectNameEXT`, when VK_EXT_debug_utils is on.
    pub(crate) debug_names: Option<ash::ext::debug_utils::Device>,
    /// Queue 0 of `queue_family`, the one queue raykit submits to; every context
    /// on the device takes this lock to submit.
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    pub(crate) properties: vk::PhysicalDeviceProperties,
    pub(crate) name: String,
    pub(crate) limits: DeviceLimits,
    pub(crate) launch_dimension_limits: [u64; 3],
    pub(crate) non_semantic_info: bool,
    pub(crate) pipeline_library: bool,
    /// Whether `rayTraversalPrimitiveCulling` is enabled: pipelines without
    /// intersection programs are then created with `SKIP_AABBS`.
    pub(crate) primitive_culling: bool,
    /// Whether `VK_KHR_swapchain` is enabled (see [`crate::Context::vulkan_handles`]).
    pub(crate) swapchain: bool,
    pub(crate) lavapipe: bool,
    /// Set once any call on the device returned `VK_ERROR_DEVICE_LOST`.
    lost: AtomicBool,
    /// Set by the fault-injection hook: the next submission reports a lost device.
    inject_loss: AtomicBool,
}

impl SharedDevice {
    /// Whether the device was lost.
    pub(crate) fn is_lost(&self) -> bool {
        self.lost.load(Ordering::Acquire)
    }

    /// Records that the device was lost: every context on it refuses new work from now on.
    pub(crate) fn mark_lost(&self) {
        self.lost.store(true, Ordering::Release);
    }

    /// `Err(DeviceLost)` once the device was lost.
    pub(crate) fn check(&self, during: &'static str) -> Result<()> {
        if self.is_lost() {
            return Err(Error::Device(DeviceError::DeviceLost { during }));
        }
        Ok(())
    }

    /// Makes the next submission on this device fail with `VK_ERROR_DEVICE_LOST`.
    #[cfg(feature = "fault-injection")]
    pub(crate) fn inject_loss(&self) {
        self.inject_loss.store(true, Ordering::Release);
    }

    /// Whether a loss was injected for this submission (and clears the request).
    pub(crate) fn take_injected_loss(&self) -> bool {
        self.inject_loss.swap(false, Ordering::AcqRel)
    }

    /// Maps a failed call's result to raykit's error, marking the device lost on
    /// `VK_ERROR_DEVICE_LOST`.
    pub(crate) fn error(&self, call: &'static str, during: &'static str) -> impl FnOnce(vk::Result) -> Error + '_ {
        move |result| {
            if result == vk::Result::ERROR_DEVICE_LOST {
                self.mark_lost();
                Error::Device(DeviceError::DeviceLost { during })
            } else {
                Error::Device(DeviceError::Vulkan { call, result })
            }
        }
    }
}

/// Which device a context asks the registry for.
#[derive(Copy, Clone, Debug, Default)]
pub(crate) struct DeviceChoice<'a> {
    /// Only devices whose name contains this.
    pub(crate) name_contains: Option<&'a str>,
    /// The `index`-th usable device (after the name filter), in the loader's
    /// order; the first when `None`.
    pub(crate) index: Option<usize>,
}

/// A usable ray-tracing device: its report and where the loader lists it.
pub(crate) struct Usable {
    physical: vk::PhysicalDevice,
    queue_family: u32,
    pub(crate) report: DeviceReport,
}

/// Every physical device's report, and the usable ones matching `name_contains`
/// in the loader's order.
fn survey(instance: &ash::Instance, name_contains: Option<&str>) -> Result<(Vec<DeviceReport>, Vec<Usable>)> {
    // SAFETY: plain enumeration call on a live instance.
    let physical_devices =
        unsafe { instance.enumerate_physical_devices() }.map_err(Error::vk("vkEnumeratePhysicalDevices"))?;
    let mut reports = Vec::new();
    let mut usable = Vec::new();
    for &physical in &physical_devices {
        let (report, family) = inspect_device(instance, physical)?;
        let name_ok = name_contains.is_none_or(|want| report.name.contains(want));
        match family {
            Some(queue_family) if report.missing.is_empty() && name_ok => {
                usable.push(Usable { physical, queue_family, report: report.clone() });
            }
            _ => {}
        }
        reports.push(report);
    }
    Ok((reports, usable))
}

/// The usable ray-tracing devices whose name contains `name_contains`, in the
/// loader's order (the order [`DeviceChoice::index`] counts in); an error listing
/// every device when there is none.
pub(crate) fn usable_devices(instance: &'static SharedInstance, name_contains: Option<&str>) -> Result<Vec<Usable>> {
    let _registry = registry();
    let (reports, usable) = survey(&instance.instance, name_contains)?;
    if usable.is_empty() {
        return Err(no_device(reports, name_contains));
    }
    Ok(usable)
}

/// `NoRayTracingDevice` with every device's report, naming the name filter where
/// a device did not pass it.
fn no_device(mut reports: Vec<DeviceReport>, name_contains: Option<&str>) -> Error {
    if let Some(want) = name_contains {
        for r in &mut reports {
            if !r.name.contains(want) {
                r.missing.push(format!("a name containing {want:?}"));
            }
        }
    }
    Error::Device(DeviceError::NoRayTracingDevice { devices: reports })
}

/// A context's hold on a device: the device it uses, taken from the registry (made
/// if none was there) and handed back by [`release`].
pub(crate) fn acquire(instance: &'static SharedInstance, choice: DeviceChoice<'_>) -> Result<Arc<SharedDevice>> {
    let mut registry = registry();
    let (reports, usable) = survey(&instance.instance, choice.name_contains)?;
    if usable.is_empty() {
        return Err(no_device(reports, choice.name_contains));
    }
    let index = choice.index.unwrap_or(0);
    let Some(chosen) = usable.get(index) else {
        return Err(Error::Device(DeviceError::DeviceIndexOutOfRange {
            index,
            usable: usable.iter().map(|u| u.report.name.clone()).collect(),
        }));
    };
    let (physical, queue_family) = (chosen.physical, chosen.queue_family);
    let existing = registry
        .devices
        .iter_mut()
        .find(|r| std::ptr::eq(r.device.instance, instance) && r.device.physical == physical && !r.device.is_lost());
    if let Some(registered) = existing {
        registered.contexts += 1;
        return Ok(registered.device.clone());
    }
    let device = Arc::new(create_device(instance, physical, queue_family)?);
    registry.devices.push(Registered { device: device.clone(), contexts: 1 });
    Ok(device)
}

/// Hands a context's hold on `device` back; the last one destroys the device.
///
/// # Safety
/// Called once per [`acquire`], after the context destroyed every object it made on
/// the device.
pub(crate) unsafe fn release(device: &Arc<SharedDevice>) {
    let mut registry = registry();
    let Some(index) = registry.devices.iter().position(|r| Arc::ptr_eq(&r.device, device)) else { return };
    let registered = &mut registry.devices[index];
    registered.contexts -= 1;
    if registered.contexts > 0 {
        return;
    }
    let registered = registry.devices.swap_remove(index);
    // SAFETY: no context uses the device any more (per the contract, each destroyed
    // what it made); destroyed under the registry's lock, so no other device is
    // created or destroyed meanwhile. A lost device may be destroyed too.
    unsafe {
        let _ = registered.device.device.device_wait_idle();
        let _exclusive = crate::vulkan::driver_lock::exclusive();
        registered.device.device.destroy_device(None);
    }
}

fn create_device(
    instance: &'static SharedInstance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
) -> Result<SharedDevice> {
    let vk_instance = &instance.instance;
    let mut features = Features::required();
    // Optional: lets pipelines without intersection programs skip AABB geometry
    // in traversal (`SKIP_AABBS`), as OptiX's `usesPrimitiveTypeFlags` does.
    let primitive_culling = Features::query(vk_instance, physical).rt.ray_traversal_primitive_culling == vk::TRUE;
    features.rt = features.rt.ray_traversal_primitive_culling(primitive_culling);
    let priorities = [1.0f32];
    let queue_infos =
        [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
    let mut extension_ptrs: Vec<_> = REQUIRED_EXTENSIONS.iter().map(|e| e.as_ptr()).collect();
    // SAFETY: `physical` came from this instance.
    let device_extensions = unsafe { vk_instance.enumerate_device_extension_properties(physical) }
        .map_err(Error::vk("vkEnumerateDeviceExtensionProperties"))?;
    let has_extension =
        |name: &CStr| device_extensions.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name));
    // Optional: lets modules carry debug info (glslang's -gVS, NonSemantic.Shader.DebugInfo.100).
    let non_semantic_info = has_extension(ash::khr::shader_non_semantic_info::NAME);
    if non_semantic_info {
        extension_ptrs.push(ash::khr::shader_non_semantic_info::NAME.as_ptr());
    }
    // Optional: pipeline libraries (`PipelineLibrary`, `Pipeline::link`).
    let pipeline_library = has_extension(ash::khr::pipeline_library::NAME);
    if pipeline_library {
        extension_ptrs.push(ash::khr::pipeline_library::NAME.as_ptr());
    }
    // Optional: swapchains for windows, where the instance has surfaces.
    let swapchain = instance.surface && has_extension(ash::khr::swapchain::NAME);
    if swapchain {
        extension_ptrs.push(ash::khr::swapchain::NAME.as_ptr());
    }
    let device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queue_infos)
        .enabled_extension_names(&extension_ptrs)
        .enabled_features(&features.base)
        .push_next(&mut features.rt)
        .push_next(&mut features.accel)
        .push_next(&mut features.v12)
        .push_next(&mut features.robustness2);
    let device = {
        let _exclusive = crate::vulkan::driver_lock::exclusive();
        // SAFETY: the physical device supports every extension and feature enabled
        // (checked by `inspect_device`); the create info lives across the call; the
        // registry's lock is held by the caller.
        unsafe { vk_instance.create_device(physical, &device_info, None) }.map_err(Error::vk("vkCreateDevice"))?
    };
    let DeviceProperties { limits, driver_id, launch_dimension_limits } = query_properties(vk_instance, physical);
    // SAFETY: `physical` belongs to the instance.
    let properties = unsafe { vk_instance.get_physical_device_properties(physical) };
    let name = properties.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    // SAFETY: queue family and index 0 were requested at device creation.
    let queue = unsafe { device.get_device_queue(queue_family, 0) };
    Ok(SharedDevice {
        instance,
        physical,
        rt: ash::khr::ray_tracing_pipeline::Device::new(vk_instance, &device),
        accel: ash::khr::acceleration_structure::Device::new(vk_instance, &device),
        debug_names: instance.debug_utils.then(|| ash::ext::debug_utils::Device::new(vk_instance, &device)),
        device,
        queue: Mutex::new(queue),
        queue_family,
        properties,
        name,
        limits,
        launch_dimension_limits,
        non_semantic_info,
        pipeline_library,
        primitive_culling,
        swapchain,
        lavapipe: driver_id == vk::DriverId::MESA_LLVMPIPE,
        lost: AtomicBool::new(false),
        inject_loss: AtomicBool::new(false),
    })
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
    robustness2: vk::PhysicalDeviceRobustness2FeaturesEXT<'static>,
    base: vk::PhysicalDeviceFeatures,
}

impl Features {
    /// Queries what `physical` supports.
    fn query(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Features {
        let mut f = Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default()
            .push_next(&mut f.rt)
            .push_next(&mut f.accel)
            .push_next(&mut f.v12)
            .push_next(&mut f.robustness2);
        // SAFETY: `physical` came from this instance; the chain is well formed.
        unsafe { instance.get_physical_device_features2(physical, &mut features2) };
        f.base = features2.features;
        f.rt.p_next = std::ptr::null_mut();
        f.accel.p_next = std::ptr::null_mut();
        f.v12.p_next = std::ptr::null_mut();
        f.robustness2.p_next = std::ptr::null_mut();
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
                .descriptor_binding_sampled_image_update_after_bind(true)
                .shader_sampled_image_array_non_uniform_indexing(true)
                .descriptor_indexing(true)
                .timeline_semaphore(true),
            robustness2: vk::PhysicalDeviceRobustness2FeaturesEXT::default()
                .robust_buffer_access2(true)
                .null_descriptor(true),
            // Device programs access buffers without bounds checks and rely on
            // robustBufferAccess2 for out-of-range indices (see raykit-device).
            base: vk::PhysicalDeviceFeatures::default().shader_int64(true).robust_buffer_access(true),
        }
    }

    /// Names of required features `self` lacks.
    fn missing(&self) -> Vec<String> {
        let checks: [(&str, vk::Bool32); 15] = [
            ("robustBufferAccess2", self.robustness2.robust_buffer_access2),
            ("nullDescriptor", self.robustness2.null_descriptor),
            ("timelineSemaphore", self.v12.timeline_semaphore),
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
            (
                "descriptorBindingSampledImageUpdateAfterBind",
                self.v12.descriptor_binding_sampled_image_update_after_bind,
            ),
            ("shaderSampledImageArrayNonUniformIndexing", self.v12.shader_sampled_image_array_non_uniform_indexing),
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
