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
            depth: 1,
            max_trace_depth: u32::MAX,
        }
    }

    #[doc(hidden)]
    pub fn __with_trace_depth(mut self, depth: u32, max_trace_depth: u32) -> Self {
        self.depth = depth;
        self.max_trace_depth = max_trace_depth;
        self
    }

    /// The trace depth of the ray that missed: 1 for a ray raygen traced, one
    /// more per level of recursion. Known when the program's ray type has
    /// [`RayType::CHECK_DEPTH`]; 1 otherwise.
    pub fn trace_depth(&self) -> u32 {
        self.depth
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
    /// `#[trace_payload]` parameter of this program. A trace that would go past
    /// the pipeline's `max_trace_depth` is not made: it throws
    /// [`TRACE_DEPTH_EXCEEDED`](crate::exception::TRACE_DEPTH_EXCEEDED) and
    /// leaves `payload` as it was (see [`RayType::CHECK_DEPTH`]).
    pub fn trace<R: RayType>(&mut self, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
        if self.depth >= self.max_trace_depth {
            self.throw_exception(crate::exception::TRACE_DEPTH_EXCEEDED);
            return;
        }
        if R::CHECK_DEPTH {
            R::set_depth(payload, self.depth + 1);
        }
        super::trace::<R>(scene, ray, payload)
    }
}
