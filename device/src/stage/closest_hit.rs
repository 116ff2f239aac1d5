//! The closest-hit stage (`__closesthit__`).

use spirv_std::glam::{UVec3, Vec2, Vec3};

use crate::{Buffer, BufferTable, Element};

/// What a closest-hit program may use: launch index and size, the ray, the hit
/// (distance, primitive, barycentrics), buffers.
pub struct ClosestHit<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    world_ray_origin: Vec3,
    world_ray_direction: Vec3,
    hit_t: f32,
    primitive_index: u32,
    barycentrics: Vec2,
    buffers: &'a mut BufferTable,
}

impl<'a> ClosestHit<'a> {
    #[doc(hidden)]
    #[allow(clippy::too_many_arguments)]
    pub fn __new(
        launch_index: UVec3,
        launch_dimensions: UVec3,
        world_ray_origin: Vec3,
        world_ray_direction: Vec3,
        hit_t: f32,
        primitive_index: u32,
        barycentrics: Vec2,
        buffers: &'a mut BufferTable,
    ) -> Self {
        ClosestHit {
            launch_index,
            launch_dimensions,
            world_ray_origin,
            world_ray_direction,
            hit_t,
            primitive_index,
            barycentrics,
            buffers,
        }
    }

    /// This invocation's index in the launch grid.
    pub fn launch_index(&self) -> UVec3 {
        self.launch_index
    }

    /// The launch grid's size.
    pub fn launch_dimensions(&self) -> UVec3 {
        self.launch_dimensions
    }

    /// The ray's origin in world space.
    pub fn world_ray_origin(&self) -> Vec3 {
        self.world_ray_origin
    }

    /// The ray's direction in world space.
    pub fn world_ray_direction(&self) -> Vec3 {
        self.world_ray_direction
    }

    /// Distance along the ray to the hit (`optixGetRayTmax` in closest-hit).
    pub fn hit_t(&self) -> f32 {
        self.hit_t
    }

    /// Index of the hit primitive in its geometry (`optixGetPrimitiveIndex`).
    pub fn primitive_index(&self) -> u32 {
        self.primitive_index
    }

    /// The triangle barycentrics `(u, v)` of the hit (`optixGetTriangleBarycentrics`):
    /// the hit point is `(1-u-v)·v0 + u·v1 + v·v2`.
    pub fn barycentrics(&self) -> Vec2 {
        self.barycentrics
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
