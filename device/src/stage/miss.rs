//! The miss stage (`__miss__`).

use spirv_std::glam::{UVec3, Vec3};

use crate::{BufferTable, Ray, RayType, Traversable};

/// What a miss program may use: launch index and size, the ray, buffers,
/// tracing and callables.
pub struct Miss<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    world_ray_origin: Vec3,
    world_ray_direction: Vec3,
    buffers: &'a mut BufferTable,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
}

impl<'a> Miss<'a> {
    #[doc(hidden)]
    pub fn __new(
        launch_index: UVec3,
        launch_dimensions: UVec3,
        world_ray_origin: Vec3,
        world_ray_direction: Vec3,
        buffers: &'a mut BufferTable,
        exception_slot: u32,
        exception_call: &'a mut crate::exception::ExceptionDetails,
    ) -> Self {
        Miss {
            launch_index,
            launch_dimensions,
            world_ray_origin,
            world_ray_direction,
            buffers,
            exception_slot,
            exception_call,
        }
    }

    super::launch_accessors!();

    /// The ray's origin in world space (`optixGetWorldRayOrigin`).
    pub fn world_ray_origin(&self) -> Vec3 {
        self.world_ray_origin
    }

    /// The ray's direction in world space (`optixGetWorldRayDirection`).
    pub fn world_ray_direction(&self) -> Vec3 {
        self.world_ray_direction
    }

    /// Traces `ray` of ray type `R` into `scene` (`optixTrace`); `payload` is a
    /// `#[trace_payload]` parameter of this program.
    pub fn trace<R: RayType>(&mut self, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
        super::trace::<R>(scene, ray, payload)
    }
}
