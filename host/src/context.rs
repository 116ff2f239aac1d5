//! The device context, like OptiX's `OptixDeviceContext`: what every raykit object
//! is made on.
//!
//! [`Context::new`] picks the first physical device that has
//! [`VK_KHR_ray_tracing_pipeline`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_ray_tracing_pipeline.html)
//! and the features raykit needs; when none has, the error lists every device seen
//! and what each lacks. Every other raykit object keeps its context alive through an
//! `Arc`, so no handle outlives its context or device.
//!
//! # One device per GPU
//!
//! As OptiX runs several device contexts on one CUDA context, every context made
//! for one GPU shares one `VkDevice` and its queue: any number of contexts may be
//! used on any number of threads. A process-wide registry holds one `VkInstance` per
//! validation setting (made on first use, kept for the life of the process) and, per
//! GPU, one device with a count of its contexts: the first context creates it, the
//! last one dropped destroys it. Instances and devices are created and destroyed
//! under the registry's lock, one call at a time, and a GPU never has two live
//! devices with one validation setting (NVIDIA's driver does not tolerate concurrent
//! work on several `VkDevice`s of one process).
//!
//! Shared by the contexts of a device: the `VkDevice`, its one queue (behind one
//! mutex that every context takes to submit, as `vkQueueSubmit` requires), its
//! limits, and whether it was lost. Each context's own: its options (validation log,
//! log callback, compile cache), its command pool and recycled command buffers
//! (a pool is externally synchronised: one per context keeps threads of
//! different contexts from waiting on each other), its memory allocator
//! (gpu-allocator, so [`Context::memory_usage`] counts what this context holds), and
//! its bindless buffer table (descriptor set layout, pool and set: a context's
//! pipelines reach only its own buffers). Validation messages reach the context
//! whose objects they name (see [`crate::log`]).
//!
//! # Lost device
//!
//! When a call reports `VK_ERROR_DEVICE_LOST`
//! ([lost device](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#devsandqueues-lost-device)),
//! the device is marked lost: that call and every later launch, build, buffer,
//! module or pipeline creation on every context of the device returns
//! [`DeviceError::DeviceLost`], and the objects still drop cleanly. The next
//! [`Context::new`] gets a new device, Vulkan's way back from a lost device.

use std::sync::Arc;

use ash::vk;

use crate::backend::{refused_on_cpu, CpuRefusal};
use crate::cache::PipelineCacheInfo;
use crate::error::{DeviceError, Error, Result};
use crate::log::MessageLog;
use crate::types::context::next_context_id;
pub use crate::types::context::{Backend, ContextOptions, DeviceLimits, MemoryUsage};
use crate::vulkan::context::ContextInner;

/// A device with ray tracing, and what every raykit object shares: a Vulkan
/// device, or the CPU backend (see [`Backend`]).
#[derive(Clone)]
#[doc(alias("OptixDeviceContext"))]
pub struct Context {
    repr: ContextRepr,
}

/// What a [`Context`] is underneath.
#[derive(Clone)]
pub(crate) enum ContextRepr {
    Vulkan(Arc<ContextInner>),
    Cpu(Arc<crate::cpu::CpuContext>),
}

impl Context {
    /// Creates a context on the backend `options` choose. On Vulkan, the first
    /// device with ray-tracing pipelines; when another context already uses that
    /// GPU, the new one shares its `VkDevice`.
    #[doc(alias("optixDeviceContextCreate", "optixInit", "vkCreateDevice"))]
    pub fn new(options: ContextOptions) -> Result<Context> {
        match options.backend.or_else(Backend::from_env).unwrap_or_default() {
            Backend::Vulkan => Self::new_vulkan(options),
            Backend::Cpu => {
                let cpu = crate::cpu::CpuContext::new(next_context_id(), &options)?;
                // The CPU backend is one device, index 0 (what `Context::all` gives).
                if let Some(index) = options.device_index.filter(|&index| index > 0) {
                    return Err(Error::Device(DeviceError::DeviceIndexOutOfRange { index, usable: vec![cpu.name()] }));
                }
                Ok(Context { repr: ContextRepr::Cpu(Arc::new(cpu)) })
            }
        }
    }

    /// One context per ray-tracing device, for splitting work across them
    /// ([`crate::DeviceGroup`]): on Vulkan, every usable device that
    /// `options.device_name_contains` lets through, in the loader's order, each
    /// made as [`Context::new`] makes one with [`ContextOptions::device_index`] set.
    /// Devices of type CPU (Mesa's lavapipe) are left out when a GPU is there too:
    /// beside GPUs they slow a split launch down more than they help; make a
    /// context for one by name and put it in a group explicitly to use it anyway.
    /// On the CPU backend, one context (the backend uses every core already).
    ///
    /// `options.device_index` is ignored. Fails as [`Context::new`] does when
    /// there is no usable device, or with the first device that fails.
    ///
    /// ```no_run
    /// use raykit::{Context, ContextOptions};
    /// let contexts = Context::all(ContextOptions::default())?;
    /// for ctx in &contexts {
    ///     println!("{}", ctx.device_name());
    /// }
    /// # Ok::<(), raykit::Error>(())
    /// ```
    pub fn all(options: ContextOptions) -> Result<Vec<Context>> {
        if options.backend.or_else(Backend::from_env).unwrap_or_default() == Backend::Cpu {
            return Ok(vec![Context::new(options)?]);
        }
        crate::vulkan::context::device_indices(&options)?
            .into_iter()
            .map(|index| Context::new(ContextOptions { device_index: Some(index), ..options.clone() }))
            .collect()
    }

    /// A context of an existing Vulkan context's inner state.
    pub(crate) fn from_vulkan(inner: Arc<ContextInner>) -> Context {
        Context { repr: ContextRepr::Vulkan(inner) }
    }

    /// A context of an existing CPU context.
    pub(crate) fn from_cpu(cpu: Arc<crate::cpu::CpuContext>) -> Context {
        Context { repr: ContextRepr::Cpu(cpu) }
    }

    /// Which backend the context is, with its half: what each public operation
    /// matches once.
    pub(crate) fn repr(&self) -> &ContextRepr {
        &self.repr
    }

    /// The Vulkan context, when this is one.
    pub(crate) fn as_vulkan(&self) -> Option<&Arc<ContextInner>> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => Some(inner),
            ContextRepr::Cpu(_) => None,
        }
    }

    /// The most each launch dimension may be: `maxComputeWorkGroupCount[i] ×
    /// maxComputeWorkGroupSize[i]` on Vulkan (VUID-vkCmdTraceRaysKHR-width-03638 …).
    pub(crate) fn launch_dimension_limits(&self) -> [u64; 3] {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.launch_dimension_limits,
            ContextRepr::Cpu(_) => crate::cpu::LAUNCH_DIMENSION_LIMITS,
        }
    }

    /// Whether `other` is this context (a clone of it).
    pub(crate) fn is_same(&self, other: &Context) -> bool {
        match (&self.repr, &other.repr) {
            (ContextRepr::Vulkan(a), ContextRepr::Vulkan(b)) => Arc::ptr_eq(a, b),
            (ContextRepr::Cpu(a), ContextRepr::Cpu(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }

    /// The backend this context runs programs on.
    pub fn backend(&self) -> Backend {
        match &self.repr {
            ContextRepr::Vulkan(_) => Backend::Vulkan,
            ContextRepr::Cpu(_) => Backend::Cpu,
        }
    }

    /// Rays the CPU backend has traced in packets on this context so far (see
    /// [`ContextOptions::cpu_packets`]); `0` on Vulkan.
    pub fn packet_rays(&self) -> u64 {
        match &self.repr {
            ContextRepr::Vulkan(_) => 0,
            ContextRepr::Cpu(cpu) => cpu.packet_rays.load(std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// Rays the CPU backend found outside the scene's bounds before a packet
    /// took them (they missed without a walk) on this context so far: with
    /// [`Context::packet_rays`], the rays that could go in packets; `0` on
    /// Vulkan.
    pub fn rays_outside_scene(&self) -> u64 {
        match &self.repr {
            ContextRepr::Vulkan(_) => 0,
            ContextRepr::Cpu(cpu) => cpu.outside_rays.load(std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// A Vulkan context on the first device with ray-tracing pipelines.
    fn new_vulkan(options: ContextOptions) -> Result<Context> {
        Ok(Context::from_vulkan(crate::vulkan::context::create(&options)?))
    }

    /// The name of the device in use.
    pub fn device_name(&self) -> std::borrow::Cow<'_, str> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => std::borrow::Cow::Borrowed(&inner.shared.name),
            ContextRepr::Cpu(cpu) => std::borrow::Cow::Owned(cpu.name()),
        }
    }

    /// Whether this device links pipelines from libraries (on Vulkan,
    /// `VK_KHR_pipeline_library`; the CPU backend always does; see
    /// [`crate::PipelineLibrary`]).
    pub fn supports_pipeline_libraries(&self) -> bool {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.pipeline_library,
            ContextRepr::Cpu(_) => true,
        }
    }

    /// The device's ray-tracing limits.
    pub fn limits(&self) -> &DeviceLimits {
        match &self.repr {
            ContextRepr::Vulkan(inner) => &inner.limits,
            ContextRepr::Cpu(_) => &crate::cpu::LIMITS,
        }
    }

    /// Whether this context and `other` share one `VkDevice` (contexts made for one
    /// GPU do).
    pub fn shares_device_with(&self, other: &Context) -> bool {
        match (&self.repr, &other.repr) {
            (ContextRepr::Vulkan(a), ContextRepr::Vulkan(b)) => Arc::ptr_eq(&a.shared, &b.shared),
            _ => false,
        }
    }

    /// Whether the device was lost (`VK_ERROR_DEVICE_LOST`): then every context on it
    /// refuses new work with [`DeviceError::DeviceLost`]; drop them, and make a new context.
    pub fn is_device_lost(&self) -> bool {
        matches!(&self.repr, ContextRepr::Vulkan(inner) if inner.shared.is_lost())
    }

    /// Test hook: the next submission on this context's device (by any context on
    /// it) fails as if the device was lost, without reaching the driver.
    #[cfg(feature = "fault-injection")]
    #[doc(hidden)]
    pub fn inject_device_loss_at_next_submit(&self) {
        if let ContextRepr::Vulkan(inner) = &self.repr {
            inner.shared.inject_loss();
        }
    }

    /// Validation messages collected so far (empty when validation is off): those
    /// naming this context's objects, and those naming no context's. The
    /// returned log is shared: it keeps collecting, also while the context is
    /// destroyed, so a test can check for leaks reported at destruction.
    pub fn messages(&self) -> MessageLog {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.log.clone(),
            ContextRepr::Cpu(cpu) => cpu.log.clone(),
        }
    }

    /// The queue family used for all work (`None` on the CPU backend).
    pub fn queue_family(&self) -> Option<u32> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => Some(inner.shared.queue_family),
            ContextRepr::Cpu(_) => None,
        }
    }

    /// Names `handle` (an object of this context's device) for validation messages
    /// and debugging tools (`vkSetDebugUtilsObjectNameEXT`); does nothing without
    /// VK_EXT_debug_utils. raykit names the objects it makes itself.
    pub fn set_debug_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let ContextRepr::Vulkan(inner) = &self.repr {
            inner.set_name(handle, name);
        }
    }

    /// The compile cache: its file, whether it was loaded (warm), missing (cold)
    /// or refused, and its current size. See [`crate::cache`].
    /// On the CPU backend, which compiles nothing at run time, the cache is off.
    pub fn pipeline_cache_info(&self) -> PipelineCacheInfo {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.pipeline_cache.info(&inner.device),
            ContextRepr::Cpu(_) => PipelineCacheInfo::off(),
        }
    }

    /// Writes the compile cache to its file now (it is also written when the
    /// context is destroyed); returns the file, or `None` when the cache is off or
    /// empty.
    pub fn save_pipeline_cache(&self) -> Result<Option<std::path::PathBuf>> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.pipeline_cache.save(&inner.device),
            ContextRepr::Cpu(_) => Ok(None),
        }
    }

    /// The largest launch width, height and depth each on its own:
    /// `maxComputeWorkGroupCount[i] × maxComputeWorkGroupSize[i]`, which
    /// `vkCmdTraceRaysKHR` requires besides the total of
    /// [`DeviceLimits::max_ray_dispatch_invocation_count`].
    pub fn max_launch_dimensions(&self) -> [u64; 3] {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.launch_dimension_limits,
            ContextRepr::Cpu(_) => crate::cpu::LAUNCH_DIMENSION_LIMITS,
        }
    }

    /// Device memory raykit holds now, from its allocator (gpu-allocator): what
    /// live buffers and acceleration structures use, and the memory blocks
    /// reserved for them.
    ///
    /// Objects dropped while the device may still use them count until their work
    /// has finished and they are collected (see [`Context::poll`]).
    ///
    /// On the CPU backend: the live buffers and textures and their bytes.
    pub fn memory_usage(&self) -> MemoryUsage {
        let inner = match &self.repr {
            ContextRepr::Vulkan(inner) => inner,
            ContextRepr::Cpu(cpu) => {
                let (buffers, buffer_bytes) = cpu.buffers.usage();
                let (textures, texture_bytes) = cpu.textures.usage();
                let (allocations, bytes) = (buffers + textures, buffer_bytes + texture_bytes);
                return MemoryUsage { allocations, allocated_bytes: bytes, reserved_bytes: bytes, blocks: allocations };
            }
        };
        inner.memory_usage()
    }
}

impl Context {
    /// Destroys the objects dropped while work that may use them was pending, once
    /// that work has finished (see [`crate::timeline`]); every submission does it
    /// too. Does not block.
    pub fn poll(&self) -> Result<()> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.collect(),
            ContextRepr::Cpu(_) => Ok(()),
        }
    }

    /// Blocks until the device has finished everything submitted so far, then
    /// destroys every object dropped meanwhile.
    pub fn wait_idle(&self) -> Result<()> {
        match &self.repr {
            ContextRepr::Vulkan(inner) => {
                inner.wait_for_pending_work()?;
                inner.collect()
            }
            ContextRepr::Cpu(cpu) => {
                cpu.wait_idle();
                Ok(())
            }
        }
    }

    /// The epoch of the last submission on this context's GPU timeline, and the
    /// highest epoch the device has finished.
    pub fn timeline_epochs(&self) -> Result<(u64, u64)> {
        let inner = match &self.repr {
            ContextRepr::Vulkan(inner) => inner,
            ContextRepr::Cpu(_) => return Err(refused_on_cpu(CpuRefusal::VulkanOnly("the GPU timeline"))),
        };
        Ok((inner.last_submitted_epoch(), inner.completed_epoch()?))
    }

    /// Number of dropped objects still waiting for their work to finish.
    pub fn pending_retirements(&self) -> usize {
        match &self.repr {
            ContextRepr::Vulkan(inner) => inner.pending_retirements(),
            ContextRepr::Cpu(_) => 0,
        }
    }
}

/// The Vulkan objects under a context, for interoperation and for comparisons with
/// hand-written Vulkan. Using them is `unsafe` ash code under the rules
/// [`crate::pipeline::raw`] states. `None` on the CPU backend.
impl Context {
    /// The `ash` instance.
    pub fn raw_instance(&self) -> Option<&ash::Instance> {
        self.as_vulkan().map(|inner| &inner.instance)
    }
    /// The `ash` device.
    pub fn raw_device(&self) -> Option<&ash::Device> {
        self.as_vulkan().map(|inner| &inner.device)
    }
    /// The `VK_KHR_ray_tracing_pipeline` functions of the device.
    pub fn raw_ray_tracing(&self) -> Option<&ash::khr::ray_tracing_pipeline::Device> {
        self.as_vulkan().map(|inner| &inner.rt)
    }
    /// The bindless buffer table's descriptor set (set 0 of every raykit pipeline layout).
    pub fn raw_buffer_table_set(&self) -> Option<vk::DescriptorSet> {
        self.as_vulkan().map(|inner| inner.buffer_table.set)
    }
    /// The bindless buffer table's descriptor set layout.
    pub fn raw_buffer_table_layout(&self) -> Option<vk::DescriptorSetLayout> {
        self.as_vulkan().map(|inner| inner.buffer_table.layout)
    }
    /// The Vulkan loader's entry points the instance was made with.
    pub fn raw_entry(&self) -> Option<&ash::Entry> {
        self.as_vulkan().map(|inner| &inner.shared.instance.entry)
    }
    /// The physical device.
    pub fn raw_physical_device(&self) -> Option<vk::PhysicalDevice> {
        self.as_vulkan().map(|inner| inner.shared.physical)
    }
    /// Runs `f` with the device's one queue (queue 0 of [`Context::queue_family`])
    /// while holding the lock every raykit submission takes, so `f` may submit to it
    /// or present on it (`vkQueueSubmit` and `vkQueuePresentKHR` need the queue
    /// externally synchronised). `None` on the CPU backend.
    ///
    /// Work submitted this way is outside raykit's timeline: wait for it before
    /// dropping raykit objects it uses.
    pub fn with_raw_queue<R>(&self, f: impl FnOnce(vk::Queue) -> R) -> Option<R> {
        let inner = self.as_vulkan()?;
        let queue = inner.shared.queue.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        Some(f(*queue))
    }
    /// Whether windows can present from this device: the instance has
    /// `VK_KHR_surface` and a window system's surface extension (raykit enables
    /// those the loader has: Xlib, XCB, Wayland, Win32, Metal), and the device has
    /// `VK_KHR_swapchain` (enabled where it exists). `false` on the CPU backend.
    pub fn supports_presentation(&self) -> bool {
        self.as_vulkan().is_some_and(|inner| inner.shared.swapchain)
    }
}

impl std::fmt::Debug for Context {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let inner = match &self.repr {
            ContextRepr::Vulkan(inner) => inner,
            ContextRepr::Cpu(cpu) => return f.debug_tuple("Context").field(cpu).finish(),
        };
        f.debug_struct("Context")
            .field("id", &inner.id)
            .field("device", &inner.shared.name)
            .field("queue_family", &inner.shared.queue_family)
            .field("device_lost", &inner.shared.is_lost())
            .field("pipeline_libraries", &inner.pipeline_library)
            .field("limits", &inner.limits)
            .finish_non_exhaustive()
    }
}
