//! Acceleration structures: OptiX's GAS (geometry) and IAS (instances) on
//! [`VK_KHR_acceleration_structure`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_acceleration_structure.html).
//!
//! Building follows OptiX's steps (`optixAccelComputeMemoryUsage`, then
//! `optixAccelBuild` with temp and output buffers, then optional compaction):
//!
//! 1. every input is validated before the GPU sees it (`validate::accel`): indices in
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
//! build (Vulkan has no per-primitive SBT index buffer); curves and moving
//! instances have no Vulkan equivalent (moving spheres are
//! [`Gas::moving_spheres`], motion blur in software). An [`Ias`] keeps the [`Gas`]es it instances alive,
//! so an instance can never point at a destroyed GAS.

pub(crate) mod gas;
mod ias;
mod pending;
mod primitive_data;

pub use crate::types::accel::{
    Aabb, Aabbs, AccelSizes, BuildInput, BuildOptions, BuildPreference, GeometryFlags, Indices, InstanceFlags,
    Triangles,
};
pub use crate::types::mesh::Mesh;
pub use gas::{Compaction, Gas, GasBuilder};
pub use ias::{Ias, IasBuilder, Instance};
pub use pending::PendingBuild;
