//! The GPU timeline: every submission of a context (launch, acceleration-structure
//! build, refit, compaction, copy) signals the next value, its *epoch*, of one
//! [timeline semaphore](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#synchronization-semaphores),
//! and objects the device may still use are destroyed only once the work that
//! could use them has finished (deferred retirement, as wgpu-core's
//! `LifetimeTracker` does).
//!
//! Dropping a [`crate::DeviceBuffer`], a [`crate::Gas`], an [`crate::Ias`], an SBT,
//! a pipeline or anything else that owns device memory or a Vulkan object never
//! waits and never frees what pending work uses: the drop queues the raw objects
//! with the epoch of the last submission, and they are destroyed (their memory
//! returned to the allocator, their bindless slot freed for reuse) once the
//! semaphore has reached that epoch. Finished work is collected on every
//! submission and on [`crate::Context::poll`]; what is left is destroyed with the
//! context, after the device is idle.
//!
//! Submissions are recorded and submitted under the timeline's lock, and a drop
//! takes the same lock to read the last epoch: a drop either happens before a
//! submission is recorded (the submission's handle check then refuses the dropped
//! object) or after it is submitted (the object waits for its epoch).

use std::collections::VecDeque;
use std::sync::{Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::Allocation;

use crate::error::DeviceError;
use crate::error::{Error, Result};
use crate::vulkan::context::ContextInner;

/// A Vulkan object (or a bindless slot) whose owner was dropped, waiting for the
/// epoch after which no pending work can use it.
pub(crate) enum Retired {
    /// A buffer and its memory.
    Buffer(vk::Buffer, Option<Allocation>),
    /// A slot of the bindless buffer table.
    Slot(u32),
    /// An acceleration structure (its storage is a separate `Buffer`).
    Accel(vk::AccelerationStructureKHR),
    /// A pipeline or pipeline library.
    Pipeline(vk::Pipeline),
    /// A pipeline layout.
    PipelineLayout(vk::PipelineLayout),
    /// A descriptor set layout.
    DescriptorSetLayout(vk::DescriptorSetLayout),
    /// A descriptor pool (with its sets).
    DescriptorPool(vk::DescriptorPool),
    /// A query pool.
    QueryPool(vk::QueryPool),
    /// A texture's image, view, sampler and memory.
    Image(vk::Image, vk::ImageView, vk::Sampler, Option<Allocation>),
    /// A slot of the bindless texture table.
    TextureSlot(u32),
}

/// The timeline's mutable state, behind its lock.
pub(crate) struct TimelineState {
    /// The epoch of the last submission (0: none yet).
    pub(crate) last_submitted: u64,
    /// Retired objects with the epoch they wait for, in nondecreasing epoch order.
    pending: VecDeque<(u64, Retired)>,
}

/// One timeline semaphore and the objects waiting on it.
pub(crate) struct Timeline {
    pub(crate) semaphore: vk::Semaphore,
    state: Mutex<TimelineState>,
}

impl Timeline {
    /// A timeline at epoch 0.
    pub(crate) fn new(device: &ash::Device) -> Result<Timeline> {
        let mut kind = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE);
        let info = vk::SemaphoreCreateInfo::default().push_next(&mut kind);
        // SAFETY: valid create info; the timelineSemaphore feature is enabled.
        let semaphore = unsafe { device.create_semaphore(&info, None) }.map_err(Error::vk("vkCreateSemaphore"))?;
        Ok(Timeline { semaphore, state: Mutex::new(TimelineState { last_submitted: 0, pending: VecDeque::new() }) })
    }

    /// Locks the state: submissions hold it from their checks until they are submitted.
    pub(crate) fn lock(&self) -> MutexGuard<'_, TimelineState> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Destroys the semaphore.
    ///
    /// # Safety
    /// The device must be idle, with every retired object destroyed.
    pub(crate) unsafe fn destroy(&self, device: &ash::Device) {
        // SAFETY: per the contract above.
        unsafe { device.destroy_semaphore(self.semaphore, None) };
    }
}

impl ContextInner {
    /// The highest epoch the device has finished.
    pub(crate) fn completed_epoch(&self) -> Result<u64> {
        // SAFETY: the semaphore is a live timeline semaphore of this device.
        unsafe { self.device.get_semaphore_counter_value(self.timeline.semaphore) }.map_err(|e| match e {
            vk::Result::ERROR_DEVICE_LOST => {
                Error::Device(DeviceError::DeviceLost { during: "reading the GPU timeline" })
            }
            other => Error::Device(DeviceError::Vulkan { call: "vkGetSemaphoreCounterValue", result: other }),
        })
    }

    /// The epoch of the last submission.
    pub(crate) fn last_submitted_epoch(&self) -> u64 {
        self.timeline.lock().last_submitted
    }

    /// Blocks until the device has finished epoch `epoch`.
    pub(crate) fn wait_for_epoch(&self, epoch: u64) -> Result<()> {
        if epoch == 0 {
            return Ok(());
        }
        self.open_gate_before_waiting();
        let semaphores = [self.timeline.semaphore];
        let values = [epoch];
        let info = vk::SemaphoreWaitInfo::default().semaphores(&semaphores).values(&values);
        // SAFETY: the semaphore is a live timeline semaphore of this device, and
        // `epoch` was submitted, so the wait ends.
        unsafe { self.device.wait_semaphores(&info, u64::MAX) }.map_err(|e| match e {
            vk::Result::ERROR_DEVICE_LOST => {
                Error::Device(DeviceError::DeviceLost { during: "waiting for the GPU timeline" })
            }
            other => Error::Device(DeviceError::Vulkan { call: "vkWaitSemaphores", result: other }),
        })
    }

    /// Blocks until everything submitted so far has finished.
    pub(crate) fn wait_for_pending_work(&self) -> Result<()> {
        self.wait_for_epoch(self.last_submitted_epoch())
    }

    /// Queues `object` until the last submitted epoch has finished, or destroys it
    /// at once when the device has finished everything.
    pub(crate) fn retire(&self, object: Retired) {
        let mut state = self.timeline.lock();
        let epoch = state.last_submitted;
        // A failed read (a lost device) keeps the object until the context goes.
        let completed = self.completed_epoch().unwrap_or(0);
        if epoch <= completed && state.pending.is_empty() {
            drop(state);
            // SAFETY: every submission that may use the object (all of them, up to
            // `epoch`) has finished, and its owner is gone.
            unsafe { self.destroy_retired(object) };
            return;
        }
        state.pending.push_back((epoch, object));
        self.collect_locked(&mut state);
    }

    /// Destroys the retired objects whose epoch has finished.
    pub(crate) fn collect(&self) -> Result<()> {
        let completed = self.completed_epoch()?;
        let mut state = self.timeline.lock();
        self.collect_up_to(&mut state, completed);
        Ok(())
    }

    /// [`ContextInner::collect`] with the lock held.
    pub(crate) fn collect_locked(&self, state: &mut TimelineState) {
        // Nothing waits: skip the semaphore read (launches stay cheap).
        if state.pending.is_empty() {
            return;
        }
        if let Ok(completed) = self.completed_epoch() {
            self.collect_up_to(state, completed);
        }
    }

    fn collect_up_to(&self, state: &mut TimelineState, completed: u64) {
        while state.pending.front().is_some_and(|(epoch, _)| *epoch <= completed) {
            if let Some((_, object)) = state.pending.pop_front() {
                // SAFETY: the work of every epoch up to `completed` has finished.
                unsafe { self.destroy_retired(object) };
            }
        }
    }

    /// Number of retired objects still waiting for their epoch.
    pub(crate) fn pending_retirements(&self) -> usize {
        self.timeline.lock().pending.len()
    }

    /// Destroys every retired object.
    ///
    /// # Safety
    /// The device must be idle.
    pub(crate) unsafe fn destroy_all_retired(&self) {
        let pending = std::mem::take(&mut self.timeline.lock().pending);
        for (_, object) in pending {
            // SAFETY: per the contract above.
            unsafe { self.destroy_retired(object) };
        }
    }

    /// # Safety
    /// No pending or future work may use `object`.
    unsafe fn destroy_retired(&self, object: Retired) {
        let device = &self.device;
        // SAFETY: per the contract above; each object was made by this device.
        unsafe {
            match object {
                Retired::Buffer(buffer, allocation) => {
                    device.destroy_buffer(buffer, None);
                    if let Some(allocation) = allocation {
                        let _ = self.allocator().free(allocation);
                    }
                }
                Retired::Slot(slot) => self.buffer_table.remove(device, slot),
                Retired::Accel(accel) => self.accel.destroy_acceleration_structure(accel, None),
                Retired::Pipeline(pipeline) => {
                    let _exclusive = crate::vulkan::driver_lock::exclusive();
                    device.destroy_pipeline(pipeline, None);
                }
                Retired::PipelineLayout(layout) => device.destroy_pipeline_layout(layout, None),
                Retired::DescriptorSetLayout(layout) => device.destroy_descriptor_set_layout(layout, None),
                Retired::DescriptorPool(pool) => device.destroy_descriptor_pool(pool, None),
                Retired::QueryPool(pool) => device.destroy_query_pool(pool, None),
                Retired::Image(image, view, sampler, allocation) => {
                    device.destroy_sampler(sampler, None);
                    device.destroy_image_view(view, None);
                    device.destroy_image(image, None);
                    if let Some(allocation) = allocation {
                        let _ = self.allocator().free(allocation);
                    }
                }
                Retired::TextureSlot(slot) => self.buffer_table.textures.remove(device, self.buffer_table.set, slot),
            }
        }
    }
}
