//! The miss stage (`__miss__`).

use spirv_std::glam::{UVec3, Vec3};

use crate::{Buffer, BufferTable, Element, Ray, RayType, Traversable};

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
        Miss { launch_index, launch_dimensions, world_ray_origin, world_ray_direction, buffers, exception_slot, exception_call }
    }

    /// Throws user exception `code` (OptiX's `optixThrowException`): the
    /// launch returns it to the host with this launch index. The program goes
    /// on: return after it (see [`crate::exception`]).
    pub fn throw_exception(&mut self, code: u32) {
        super::throw_and_handle(self.buffers, self.exception_slot, self.launch_index, code, self.exception_call)
    }

    /// This invocation's index in the launch grid.
    pub fn launch_index(&self) -> UVec3 {
        self.launch_index
    }

    /// The launch grid's size.
    pub fn launch_dimensions(&self) -> UVec3 {
        self.launch_dimensions
    }

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

    /// Runs the callable at `sbt_index` with `data` (a `#[call_data]` parameter).
    pub fn call<T>(&mut self, sbt_index: u32, data: &mut T) {
        super::execute_callable(sbt_index, data)
    }

    /// Reads element `index` of `buffer`.
    pub fn load<T: Element>(&self, buffer: Buffer<T>, index: u32) -> T {
        super::load(self.buffers, buffer, index)
    }

    /// Writes element `index` of `buffer`.
    pub fn store<T: Element>(&mut self, buffer: Buffer<T>, index: u32, value: T) {
        super::store(self.buffers, buffer, index, value)
    }


}
