//! An acceleration structure on Vulkan: the structure itself with its storage
//! ([`VkAccelerationStructureKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkAccelerationStructureKHR.html)),
//! (the flags and index formats it is built with are mapped in `vulkan::conv`).

use std::sync::Arc;

use ash::vk;

use crate::vulkan::context::ContextInner;
use crate::vulkan::memory::RawBuffer;

/// An acceleration structure with its storage; destroyed on drop.
pub(crate) struct AccelStructure {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) handle: vk::AccelerationStructureKHR,
    pub(crate) address: u64,
    pub(crate) size: u64,
    /// Bumped by every refit, so an IAS built over an older version is refused
    /// at launch (see [`crate::validate::handles`], which holds clones of it: never the
    /// structure, whose drop must not happen under a launch's checks).
    pub(crate) version: Arc<std::sync::atomic::AtomicU64>,
    _storage: RawBuffer,
}

impl AccelStructure {
    /// Allocates storage of `size` bytes and creates a structure of type `ty` in it.
    pub(crate) fn new(ctx: &Arc<ContextInner>, ty: vk::AccelerationStructureTypeKHR, size: u64) -> crate::Result<Self> {
        let storage = RawBuffer::new(
            ctx,
            "acceleration structure",
            size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
            gpu_allocator::MemoryLocation::GpuOnly,
            256,
        )?;
        let create = vk::AccelerationStructureCreateInfoKHR::default().buffer(storage.buffer).size(size).ty(ty);
        // SAFETY: the storage buffer is `size` bytes, 256-aligned, with the storage usage.
        let handle = unsafe { ctx.accel.create_acceleration_structure(&create, None) }
            .map_err(crate::Error::vk("vkCreateAccelerationStructureKHR"))?;
        let address_info = vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(handle);
        // SAFETY: `handle` is a live acceleration structure of this device.
        let address = unsafe { ctx.accel.get_acceleration_structure_device_address(&address_info) };
        Ok(AccelStructure { ctx: ctx.clone(), handle, address, size, version: Default::default(), _storage: storage })
    }
}

impl Drop for AccelStructure {
    fn drop(&mut self) {
        // Pending launches and builds may still use it: the timeline destroys it
        // once the last submitted epoch has finished (its storage buffer, dropped
        // after this, waits for the same epoch). Instances that reference it hold
        // an `Arc` to it.
        self.ctx.retire(crate::vulkan::timeline::Retired::Accel(self.handle));
    }
}
