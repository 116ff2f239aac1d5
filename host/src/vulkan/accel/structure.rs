//! What every acceleration structure has: its build flags, the memory sizes the
//! driver asks for, and the structure itself with its storage
//! ([`VkAccelerationStructureKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkAccelerationStructureKHR.html)).

use std::sync::Arc;

use ash::vk;

use crate::context::ContextInner;
use crate::memory::RawBuffer;

/// Which way the builder trades build time against trace time (OptiX's
/// `OPTIX_BUILD_FLAG_PREFER_FAST_TRACE` / `_BUILD`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildPreference {
    /// Slower builds, faster traversal (the default, for static geometry).
    #[default]
    FastTrace,
    /// Faster builds, slower traversal (for geometry rebuilt every frame).
    FastBuild,
    /// Let the driver choose.
    Neither,
}

/// Build flags of one acceleration structure.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BuildOptions {
    /// Build-time versus trace-time preference.
    pub preference: BuildPreference,
    /// Allow [`Gas::update`](super::Gas::update) / [`Ias::update`](super::Ias::update) (refit) later.
    pub allow_update: bool,
    /// Allow [`Gas::compact`](super::Gas::compact) later.
    pub allow_compaction: bool,
}

impl BuildOptions {
    /// Prefer fast traversal (the default).
    #[must_use]
    pub fn fast_trace(mut self) -> Self {
        self.preference = BuildPreference::FastTrace;
        self
    }

    /// Prefer fast builds.
    #[must_use]
    pub fn fast_build(mut self) -> Self {
        self.preference = BuildPreference::FastBuild;
        self
    }

    /// Allow later refits (`update`).
    #[must_use]
    pub fn allow_update(mut self, allow: bool) -> Self {
        self.allow_update = allow;
        self
    }

    /// Allow later compaction.
    #[must_use]
    pub fn allow_compaction(mut self, allow: bool) -> Self {
        self.allow_compaction = allow;
        self
    }

    pub(crate) fn vk_flags(self) -> vk::BuildAccelerationStructureFlagsKHR {
        type F = vk::BuildAccelerationStructureFlagsKHR;
        let mut flags = match self.preference {
            BuildPreference::FastTrace => F::PREFER_FAST_TRACE,
            BuildPreference::FastBuild => F::PREFER_FAST_BUILD,
            BuildPreference::Neither => F::empty(),
        };
        if self.allow_update {
            flags |= F::ALLOW_UPDATE;
        }
        if self.allow_compaction {
            flags |= F::ALLOW_COMPACTION;
        }
        flags
    }
}

/// Memory an acceleration structure needs, from the driver's size query
/// (OptiX's `OptixAccelBufferSizes`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct AccelSizes {
    /// Bytes of the structure itself (`accelerationStructureSize`).
    pub structure: u64,
    /// Scratch bytes a build needs (`buildScratchSize`).
    pub build_scratch: u64,
    /// Scratch bytes an update needs (`updateScratchSize`).
    pub update_scratch: u64,
}

/// An acceleration structure with its storage; destroyed on drop.
pub(crate) struct AccelStructure {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) handle: vk::AccelerationStructureKHR,
    pub(crate) address: u64,
    pub(crate) size: u64,
    /// Bumped by every refit, so an IAS built over an older version is refused
    /// at launch (see [`crate::handles`], which holds clones of it: never the
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
