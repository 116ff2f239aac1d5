//! The miss stage (`__miss__`).

use spirv_std::glam::{UVec3, Vec3};

/// What a miss program may use: launch index and size, the ray, device,
/// tracing and callables.
pub struct Miss<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    world_ray_origin: Vec3,
    world_ray_direction: Vec3,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
    /// The trace depth of the ray that missed (see [`Miss::trace_depth`]).
    depth: u32,
    /// The pipeline's `max_trace_depth` (`u32::MAX` when unknown).
    max_trace_depth: u32,
}

impl<'a> Miss<'a> {
    #[doc(hidden)]
    pub fn __new(
        launch_index: UVec3,
        launch_dimensions: UVec3,
        world_ray_origin: Vec3,
        world_ray_direction: Vec3,
        device: super::DeviceAccess<'a>,
        exception_slot: u32,
        exception_call: &'a mut crate::exception::ExceptionDetails,
    ) -> Self {
        Miss {
            launch_index,
            launch_dimensions,
            world_ray_origin,
            world_ray_direction,
            device,
            exception_slot,
            exception_call,
            depth: 1,
            max_trace_depth: u32::MAX,
        }
    }

    super::recursive_trace!();

    super::launch_accessors!();

    /// The ray's origin in world space (`optixGetWorldRayOrigin`).
    #[doc(alias("optixGetWorldRayOrigin", "gl_WorldRayOriginEXT"))]
    pub fn world_ray_origin(&self) -> Vec3 {
        self.world_ray_origin
    }

    /// The ray's direction in world space (`optixGetWorldRayDirection`).
    #[doc(alias("optixGetWorldRayDirection", "gl_WorldRayDirectionEXT"))]
    pub fn world_ray_direction(&self) -> Vec3 {
        self.world_ray_direction
    }
}
