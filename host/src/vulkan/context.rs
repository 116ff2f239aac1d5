//! A Vulkan context's operations: debug names, submissions on the context's
//! timeline (recorded command buffers, recycled once their epoch has finished),
//! and its destruction, which hands the shared device back to the registry (see
//! [`crate::context`] for what contexts of one GPU share).

use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;

use crate::error::DeviceError;
use crate::error::{Error, Result};
use crate::log::MessageLog;
use crate::types::context::{ContextOptions, DeviceLimits, MemoryUsage};
use crate::validate::handles::{LiveTraversables, TraversableState};
use crate::validate::hit_reach::HitReach;
use crate::validate::launch::Liveness;
use crate::vulkan::buffer_table::BufferTable;
use crate::vulkan::cache::{CacheKey, DiskCache};
use crate::vulkan::device_registry::{SharedDevice, SharedInstance};
use crate::vulkan::timeline::Timeline;

/// A Vulkan context: its share of the GPU's device and its own objects (see
/// [`crate::context`]).
pub(crate) struct ContextInner {
    /// This context's id, which its objects' debug names carry (see [`crate::log`]).
    pub(crate) id: u64,
    /// The device, shared with every other context on the same GPU.
    pub(crate) shared: Arc<SharedDevice>,
    pub(crate) log: MessageLog,
    // Copies of the shared device's function tables and properties, read often.
    pub(crate) instance: ash::Instance,
    pub(crate) device: ash::Device,
    pub(crate) rt: ash::khr::ray_tracing_pipeline::Device,
    pub(crate) accel: ash::khr::acceleration_structure::Device,
    /// This context's command pool: a pool is externally synchronised, so each
    /// context has its own.
    pub(crate) command_pool: Mutex<vk::CommandPool>,
    /// Finished command buffers, reused by later submissions: allocating one for
    /// every launch costs more than the launch on some drivers. Guarded with the
    /// pool's lock held too.
    pub(crate) recycled: Mutex<Vec<vk::CommandBuffer>>,
    pub(crate) allocator: ManuallyDrop<Mutex<gpu_allocator::vulkan::Allocator>>,
    pub(crate) buffer_table: ManuallyDrop<BufferTable>,
    /// Epochs of submissions and the objects waiting for them (see [`crate::timeline`]).
    pub(crate) timeline: Timeline,
    /// The live IASes, which launches check `Traversable`s against (see [`crate::validate::handles`]).
    pub(crate) traversables: LiveTraversables,
    pub(crate) limits: DeviceLimits,
    /// Largest launch width, height and depth: `maxComputeWorkGroupCount[i] ×
    /// maxComputeWorkGroupSize[i]`, as `vkCmdTraceRaysKHR` requires.
    pub(crate) launch_dimension_limits: [u64; 3],
    /// Whether `VK_KHR_shader_non_semantic_info` is enabled, which modules with
    /// debug info (`SPV_KHR_non_semantic_info`) need.
    pub(crate) non_semantic_info: bool,
    /// Whether `VK_KHR_pipeline_library` is enabled (see [`crate::PipelineLibrary`]).
    pub(crate) pipeline_library: bool,
    /// Whether pipelines may be created with `SKIP_AABBS` (`rayTraversalPrimitiveCulling`).
    pub(crate) primitive_culling: bool,
    /// Whether the driver is lavapipe (Mesa's CPU driver), whose workarounds
    /// raykit applies (see [`PipelineLibrary`](crate::PipelineLibrary)).
    pub(crate) lavapipe: bool,
    /// The compile cache every pipeline creation of this context goes through.
    pub(crate) pipeline_cache: DiskCache,
    /// The test hook that holds submissions on the device (see [`crate::gate`]).
    #[cfg(feature = "fault-injection")]
    pub(crate) gate: crate::vulkan::gate::Gate,
    /// Test hook: buffers the host could map are copied through staging buffers
    /// as on a discrete GPU (see `crate::gate`).
    #[cfg(feature = "fault-injection")]
    pub(crate) force_staging: std::sync::atomic::AtomicBool,
}

/// Whether `options` (or `RAYKIT_VALIDATION=1`) ask for the validation layer.
fn validation(options: &ContextOptions) -> bool {
    options.validation.unwrap_or_else(|| std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1"))
}

/// The `device_index` of every usable device that `options.device_name_contains`
/// lets through, in the loader's order; devices of type CPU are left out when a
/// GPU is there too (see [`crate::Context::all`]).
pub(crate) fn device_indices(options: &ContextOptions) -> Result<Vec<usize>> {
    let validation = validation(options);
    let instance = crate::vulkan::device_registry::instance(validation)?;
    let usable = crate::vulkan::device_registry::usable_devices(instance, options.device_name_contains.as_deref())?;
    let is_cpu = |u: &crate::vulkan::device_registry::Usable| {
        u.report.device_type == format!("{:?}", vk::PhysicalDeviceType::CPU)
    };
    let any_gpu = usable.iter().any(|u| !is_cpu(u));
    Ok(usable.iter().enumerate().filter(|(_, u)| !(any_gpu && is_cpu(u))).map(|(index, _)| index).collect())
}

/// Creates a Vulkan context as `options` say: on the first device with
/// ray-tracing pipelines (or the one they choose), shared with the other
/// contexts on that GPU.
pub(crate) fn create(options: &ContextOptions) -> Result<Arc<ContextInner>> {
    let validation = validation(options);
    let instance = crate::vulkan::device_registry::instance(validation)?;
    let id = crate::types::context::next_context_id();
    let log = MessageLog::with_callback(options.log_callback.clone());
    // Routed before the device is made, so messages of its creation reach the log.
    instance.routes.add(id, log.clone());
    let mut route = RouteGuard { instance, id, armed: true };
    let choice = crate::vulkan::device_registry::DeviceChoice {
        name_contains: options.device_name_contains.as_deref(),
        index: options.device_index,
    };
    let shared = crate::vulkan::device_registry::acquire(instance, choice)?;
    let mut hold = DeviceHold { shared: shared.clone(), armed: true };
    let device = &shared.device;
    let physical = shared.physical;
    let pool_info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(shared.queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER | vk::CommandPoolCreateFlags::TRANSIENT);
    // SAFETY: valid device and create info.
    let command_pool =
        unsafe { device.create_command_pool(&pool_info, None) }.map_err(Error::vk("vkCreateCommandPool"))?;
    let pool_guard = PoolGuard(device, command_pool);
    let allocator = gpu_allocator::vulkan::Allocator::new(&gpu_allocator::vulkan::AllocatorCreateDesc {
        instance: instance.instance.clone(),
        device: device.clone(),
        physical_device: physical,
        debug_settings: Default::default(),
        buffer_device_address: true,
        allocation_sizes: Default::default(),
    })
    .map_err(|source| Error::Device(DeviceError::Allocation { what: "the memory allocator", source }))?;
    let buffer_table = BufferTable::new(device)?;
    let timeline = Timeline::new(device)?;
    std::mem::forget(pool_guard);
    let pipeline_cache = DiskCache::open(device, CacheKey::of(&shared.properties), &options.pipeline_cache);
    let inner = ContextInner {
        id,
        log,
        instance: instance.instance.clone(),
        device: device.clone(),
        rt: shared.rt.clone(),
        accel: shared.accel.clone(),
        command_pool: Mutex::new(command_pool),
        recycled: Mutex::new(Vec::new()),
        allocator: ManuallyDrop::new(Mutex::new(allocator)),
        buffer_table: ManuallyDrop::new(buffer_table),
        timeline,
        traversables: LiveTraversables::default(),
        limits: shared.limits,
        launch_dimension_limits: shared.launch_dimension_limits,
        non_semantic_info: shared.non_semantic_info,
        pipeline_library: shared.pipeline_library,
        primitive_culling: shared.primitive_culling,
        lavapipe: shared.lavapipe,
        pipeline_cache,
        shared,
        #[cfg(feature = "fault-injection")]
        gate: Default::default(),
        #[cfg(feature = "fault-injection")]
        force_staging: Default::default(),
    };
    inner.set_name(command_pool, "command pool");
    inner.set_name(inner.buffer_table.set, "buffer table");
    inner.set_name(inner.buffer_table.layout, "buffer table layout");
    // The context now owns the route and the hold.
    route.armed = false;
    hold.armed = false;
    Ok(Arc::new(inner))
}

impl ContextInner {
    /// Gives `handle` a debug name, so validation messages and tools name it; the
    /// name carries the context's id, which routes messages about the object to this
    /// context (see [`crate::log`]). Does nothing without VK_EXT_debug_utils.
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(debug) = &self.shared.debug_names else { return };
        let Ok(name) = std::ffi::CString::new(crate::log::tagged_name(self.id, name)) else { return };
        let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
        // SAFETY: `handle` is a live object of this device (callers name what they
        // just made); naming needs no external synchronisation of the object.
        let _ = unsafe { debug.set_debug_utils_object_name(&info) };
    }

    /// `Err(DeviceLost)` once the device was lost: every context on it refuses new work.
    pub(crate) fn check_device(&self, during: &'static str) -> Result<()> {
        self.shared.check(during)
    }

    /// The semaphore and value a submission made now waits for: the submission
    /// gate's when it is closed (test builds, see [`crate::gate`]), else none.
    #[cfg(feature = "fault-injection")]
    fn gate_wait(&self) -> Option<(vk::Semaphore, u64)> {
        self.gate.wait()
    }

    /// As above: without the test hook, never.
    #[cfg(not(feature = "fault-injection"))]
    #[inline(always)]
    fn gate_wait(&self) -> Option<(vk::Semaphore, u64)> {
        None
    }

    /// Opens a closed submission gate (test builds, see [`crate::gate`]) before a
    /// host wait, which could otherwise wait for held work forever.
    #[cfg(feature = "fault-injection")]
    pub(crate) fn open_gate_before_waiting(&self) {
        // Fails only on a lost device, which the wait then reports.
        let _ = self.open_gate();
    }

    /// As above: without the test hook, nothing to open.
    #[cfg(not(feature = "fault-injection"))]
    #[inline(always)]
    pub(crate) fn open_gate_before_waiting(&self) {}

    /// Device memory this context's allocator holds now.
    pub(crate) fn memory_usage(&self) -> MemoryUsage {
        let report = self.allocator().generate_report();
        MemoryUsage {
            allocations: report.allocations.len(),
            allocated_bytes: report.total_allocated_bytes,
            reserved_bytes: report.total_capacity_bytes,
            blocks: report.blocks.len(),
        }
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, gpu_allocator::vulkan::Allocator> {
        // A panic while holding the lock cannot leave the allocator half-updated in a
        // way that matters more than losing the allocation; keep going.
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Work submitted to the queue and not yet waited for: a recorded command buffer
/// and the epoch it signals on the context's timeline semaphore (no fence: the
/// semaphore is what is waited on). Dropping it waits for the work first, so
/// buffers the work uses may be freed after it.
pub(crate) struct Submission {
    ctx: Arc<ContextInner>,
    cmd: vk::CommandBuffer,
    during: &'static str,
    waited: bool,
    /// The submission's epoch on the context's timeline.
    pub(crate) epoch: u64,
}

impl ContextInner {
    /// Records commands with `record` and submits them without waiting; the
    /// returned [`Submission`] is waited on (or dropped, which waits).
    pub(crate) fn submit(
        self: &Arc<Self>,
        during: &'static str,
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<Submission> {
        self.submit_checked(during, || Ok(()), record)
    }

    /// [`ContextInner::submit`], running `check` first under the timeline's lock:
    /// what `check` finds alive stays alive until the work has finished, as a
    /// drop after it waits for this submission's epoch (see [`crate::timeline`]).
    pub(crate) fn submit_checked(
        self: &Arc<Self>,
        during: &'static str,
        check: impl FnOnce() -> Result<()>,
        record: impl FnOnce(vk::CommandBuffer),
    ) -> Result<Submission> {
        let mut timeline = self.timeline.lock();
        check()?;
        self.check_device(during)?;
        let device = &self.device;
        let pool = self.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        let reused = self.recycled.lock().unwrap_or_else(|p| p.into_inner()).pop();
        let cmd = match reused {
            Some(cmd) => cmd,
            None => {
                let alloc_info = vk::CommandBufferAllocateInfo::default()
                    .command_pool(*pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1);
                // SAFETY: the pool is externally synchronised by the mutex held.
                let cmd = unsafe { device.allocate_command_buffers(&alloc_info) }
                    .map_err(Error::vk("vkAllocateCommandBuffers"))?[0];
                self.set_name(cmd, "command buffer");
                cmd
            }
        };
        let epoch = timeline.last_submitted + 1;
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: a fresh or finished (recycled) command buffer of a pool made
            // with RESET_COMMAND_BUFFER, so beginning it resets it; recorded under
            // the pool's lock.
            unsafe { device.begin_command_buffer(cmd, &begin) }.map_err(Error::vk("vkBeginCommandBuffer"))?;
            record(cmd);
            // SAFETY: as above.
            unsafe { device.end_command_buffer(cmd) }.map_err(Error::vk("vkEndCommandBuffer"))?;
            let cmds = [cmd];
            let signal = [self.timeline.semaphore];
            let values = [epoch];
            // Test builds only: a closed submission gate holds the work on the device.
            let gate = self.gate_wait();
            let (wait, wait_values) = match &gate {
                Some((semaphore, value)) => (std::slice::from_ref(semaphore), std::slice::from_ref(value)),
                None => (&[][..], &[][..]),
            };
            let wait_stages = [vk::PipelineStageFlags::ALL_COMMANDS];
            let mut timeline_info = vk::TimelineSemaphoreSubmitInfo::default()
                .signal_semaphore_values(&values)
                .wait_semaphore_values(wait_values);
            let submit = [vk::SubmitInfo::default()
                .command_buffers(&cmds)
                .wait_semaphores(wait)
                .wait_dst_stage_mask(&wait_stages[..wait.len()])
                .signal_semaphores(&signal)
                .push_next(&mut timeline_info)];
            // One queue for every context on the device, behind one lock.
            let queue = self.shared.queue.lock().unwrap_or_else(|p| p.into_inner());
            // Checked again under the queue's lock: no submission follows a loss.
            self.check_device(during)?;
            let submitted = if self.shared.take_injected_loss() {
                Err(vk::Result::ERROR_DEVICE_LOST)
            } else {
                // SAFETY: the queue is externally synchronised by its mutex; the command
                // buffer is fully recorded; the
                // epoch is above every value signalled before (under the timeline lock).
                unsafe { device.queue_submit(*queue, &submit, vk::Fence::null()) }
            };
            submitted.map_err(self.shared.error("vkQueueSubmit", during))
        })();
        if let Err(e) = result {
            // SAFETY: nothing was submitted: the command buffer is idle.
            unsafe { device.free_command_buffers(*pool, &[cmd]) };
            return Err(e);
        }
        drop(pool);
        timeline.last_submitted = epoch;
        // Retire on every submission what finished meanwhile.
        self.collect_locked(&mut timeline);
        drop(timeline);
        Ok(Submission { ctx: self.clone(), cmd, during, waited: false, epoch })
    }
}

impl Submission {
    /// Whether the work has finished, without blocking.
    pub(crate) fn is_done(&self) -> Result<bool> {
        if self.waited {
            return Ok(true);
        }
        self.ctx.check_device(self.during)?;
        // SAFETY: the semaphore is a live timeline semaphore of this device.
        let reached = unsafe { self.ctx.device.get_semaphore_counter_value(self.ctx.timeline.semaphore) }
            .map_err(self.ctx.shared.error("vkGetSemaphoreCounterValue", self.during))?;
        Ok(reached >= self.epoch)
    }

    /// Blocks until the work has finished.
    pub(crate) fn wait(&mut self) -> Result<()> {
        if self.waited {
            return Ok(());
        }
        // Once the device is lost, the work's results are lost with it.
        self.ctx.check_device(self.during)?;
        self.wait_epoch()?;
        self.waited = true;
        Ok(())
    }

    /// Waits for the submission's epoch. A lost device reports
    /// `VK_ERROR_DEVICE_LOST` in finite time.
    fn wait_epoch(&self) -> Result<()> {
        self.ctx.open_gate_before_waiting();
        let semaphores = [self.ctx.timeline.semaphore];
        let values = [self.epoch];
        let info = vk::SemaphoreWaitInfo::default().semaphores(&semaphores).values(&values);
        // SAFETY: a live timeline semaphore of this device; the epoch was submitted,
        // so the wait ends.
        let waited = unsafe { self.ctx.device.wait_semaphores(&info, u64::MAX) };
        waited.map_err(self.ctx.shared.error("vkWaitSemaphores", self.during))
    }
}

impl Drop for Submission {
    fn drop(&mut self) {
        // Waits for the epoch even when the device was marked lost: another context's
        // call may have seen the loss while this work still runs (or the loss was
        // injected). A failed wait means a lost device; destroying the objects is
        // still allowed then.
        let waited = self.waited || self.wait_epoch().is_ok();
        let pool = self.ctx.command_pool.lock().unwrap_or_else(|p| p.into_inner());
        let device = &self.ctx.device;
        // Keep a few finished command buffers for the next submissions.
        const KEEP: usize = 8;
        let mut recycled = self.ctx.recycled.lock().unwrap_or_else(|p| p.into_inner());
        if waited && !self.ctx.shared.is_lost() && recycled.len() < KEEP {
            recycled.push(self.cmd);
            return;
        }
        // SAFETY: the work has finished (waited above), so the command buffer is
        // idle; the pool is locked.
        unsafe { device.free_command_buffers(*pool, &[self.cmd]) };
    }
}
impl Drop for ContextInner {
    fn drop(&mut self) {
        // SAFETY: every child object and every submission holds an `Arc` to this
        // context, so none is alive now and none of its work is pending (a
        // submission waits for its work when dropped). Only this context's objects
        // are destroyed here; the device goes with the last context on it.
        unsafe {
            // This context's work: the queue is shared with other contexts, so wait on
            // this context's timeline rather than for the whole device. A lost device
            // ends the wait with an error; the objects may be destroyed then.
            let _ = self.wait_for_pending_work();
            #[cfg(feature = "fault-injection")]
            self.gate.destroy(&self.device);
            self.destroy_all_retired();
            self.timeline.destroy(&self.device);
            // Errors cannot be returned from drop; `Context::save_pipeline_cache`
            // reports them to whoever wants to know.
            let _ = self.pipeline_cache.save(&self.device);
            self.pipeline_cache.destroy(&self.device);
            ManuallyDrop::take(&mut self.buffer_table).destroy(&self.device);
            ManuallyDrop::drop(&mut self.allocator);
            // Recycled command buffers go with the pool.
            let pool = self.command_pool.get_mut().unwrap_or_else(|p| p.into_inner());
            self.device.destroy_command_pool(*pool, None);
            // The log stays routed until the device (if this was its last context)
            // is destroyed, so it hears about objects left alive on it.
            crate::vulkan::device_registry::release(&self.shared);
        }
        self.shared.instance.routes.remove(self.id);
        self.log.mark_destroyed();
    }
}

/// Stops routing messages to a context whose creation failed.
pub(crate) struct RouteGuard {
    pub(crate) instance: &'static SharedInstance,
    pub(crate) id: u64,
    pub(crate) armed: bool,
}

impl Drop for RouteGuard {
    fn drop(&mut self) {
        if self.armed {
            self.instance.routes.remove(self.id);
        }
    }
}

/// Hands the device back if context creation fails after it was acquired.
pub(crate) struct DeviceHold {
    pub(crate) shared: Arc<SharedDevice>,
    pub(crate) armed: bool,
}

impl Drop for DeviceHold {
    fn drop(&mut self) {
        if self.armed {
            // SAFETY: the failed creation destroyed what it made (its guards drop
            // before this one) and made nothing else on the device.
            unsafe { crate::vulkan::device_registry::release(&self.shared) };
        }
    }
}

/// Destroys the command pool if context creation fails after it was made.
pub(crate) struct PoolGuard<'a>(pub(crate) &'a ash::Device, pub(crate) vk::CommandPool);
impl Drop for PoolGuard<'_> {
    fn drop(&mut self) {
        // SAFETY: the pool has no command buffers yet.
        unsafe { self.0.destroy_command_pool(self.1, None) };
    }
}

impl Liveness for ContextInner {
    fn buffer(&self, handle: u32) -> bool {
        self.buffer_table.is_live(handle)
    }

    fn texture(&self, handle: u32) -> bool {
        self.buffer_table.textures.is_live(handle)
    }

    fn traversable(&self, address: u64) -> TraversableState {
        self.traversables.state(address)
    }

    fn hit_reach(&self, address: u64) -> Option<Arc<HitReach>> {
        self.traversables.hit_reach(address)
    }
}
