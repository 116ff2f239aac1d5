//! Acceleration structures: OptiX's GAS (geometry) and IAS (instances) on
//! [`VK_KHR_acceleration_structure`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_acceleration_structure.html).
//!
//! Building follows OptiX's steps (`optixAccelComputeMemoryUsage`, then
//! `optixAccelBuild` with temp and output buffers, then optional compaction):
//!
//! 1. every input is validated before the GPU sees it ([`input`]): indices in
//!    range, counts within the device's limits, strides aligned, vertices and
//!    boxes finite — each problem a typed [`Error`](crate::Error);
//! 2. the memory sizes are queried
//!    ([`vkGetAccelerationStructureBuildSizesKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkGetAccelerationStructureBuildSizesKHR.html));
//!    [`GasBuilder::sizes`] exposes the query;
//! 3. the structure and one scratch buffer (shared by every build of a batch) are
//!    allocated through gpu-allocator, the builds are recorded into one command
//!    buffer ([`vkCmdBuildAccelerationStructuresKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdBuildAccelerationStructuresKHR.html))
//!    and submitted; [`PendingBuild`] is the handle to wait on, and the scratch and
//!    input buffers are released when it is waited on;
//! 4. optionally the structure is compacted ([`Gas::compact`]) or refitted
//!    ([`Gas::update`], [`Ias::update`]) when its build allowed it and its topology
//!    is unchanged.
//!
//! ```no_run
//! use raykit::accel::BuildOptions;
//! use raykit::glam::{Affine3A, Vec3};
//! use raykit::{Context, ContextOptions, Gas, Ias, Instance, Triangles};
//!
//! # fn main() -> raykit::Result<()> {
//! let ctx = Context::new(ContextOptions::default())?;
//! let vertices = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE];
//! let indices: [u16; 6] = [0, 1, 2, 1, 3, 2];
//! let input = Triangles::new(&vertices).indices_u16(&indices);
//! let options = BuildOptions::default().allow_update(true).allow_compaction(true);
//! // Ask for the memory first if you like, as optixAccelComputeMemoryUsage does.
//! let sizes = Gas::builder().triangles(input).options(options).sizes(&ctx)?;
//! // Build without blocking, do other work, then wait.
//! let pending = Gas::builder().triangles(input).options(options).submit(&ctx)?;
//! let mut gas = pending.wait()?;
//! assert_eq!(gas.size(), sizes.structure);
//! // Refit after moving vertices (same topology).
//! let moved = vertices.map(|v| v * 2.0);
//! gas.update(&[Triangles::new(&moved).indices_u16(&indices).into()])?;
//! // Instance it twice, the second with its own hit records.
//! let scene = Ias::new(&ctx, &[
//!     Instance::new(&gas),
//!     Instance::new(&gas).transform(Affine3A::from_translation(Vec3::Z)).sbt_offset(1).mask(0x02),
//! ])?;
//! let _handle = scene.handle(); // goes into the launch params
//! # Ok(())
//! # }
//! ```
//!
//! Vulkan differences from OptiX, documented where they show: a GAS holds either
//! triangles or AABBs, not both; a geometry's SBT index is its position in the
//! build (Vulkan has no per-primitive SBT index buffer); motion blur and curves
//! have no Vulkan equivalent. An [`Ias`] keeps the [`Gas`]es it instances alive,
//! so an instance can never point at a destroyed GAS.

mod build;
mod gas;
mod ias;
pub mod input;

use std::sync::Arc;

use ash::vk;

use crate::context::ContextInner;
use crate::memory::RawBuffer;

pub use build::PendingBuild;
pub use gas::{Compaction, Gas, GasBuilder};
pub use ias::{Ias, IasBuilder, Instance, InstanceFlags};
pub use input::{Aabb, Aabbs, BuildInput, GeometryFlags, Indices, Triangles};

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
    /// Allow [`Gas::update`] / [`Ias::update`] (refit) later.
    pub allow_update: bool,
    /// Allow [`Gas::compact`] later.
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
        Ok(AccelStructure { ctx: ctx.clone(), handle, address, size, _storage: storage })
    }
}

impl Drop for AccelStructure {
    fn drop(&mut self) {
        // SAFETY: every submission that uses the structure is waited on before its
        // owner can be dropped (launches block; a `PendingBuild` waits in its own
        // drop, before the structures it holds); instances that reference it hold
        // an `Arc` to it.
        unsafe { self.ctx.accel.destroy_acceleration_structure(self.handle, None) };
    }
}
