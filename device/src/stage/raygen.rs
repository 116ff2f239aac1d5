//! The ray-generation stage (`__raygen__`).

use spirv_std::glam::{UVec3, Vec3};

use crate::{Ray, RayType, Traversable};

/// What a raygen program may use: launch index and size, tracing, callables,
/// buffers.
pub struct Raygen<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
}

impl<'a> Raygen<'a> {
    #[doc(hidden)]
    pub fn __new(
        launch_index: UVec3,
        launch_dimensions: UVec3,
        device: super::DeviceAccess<'a>,
        exception_slot: u32,
        exception_call: &'a mut crate::exception::ExceptionDetails,
    ) -> Self {
        Raygen { launch_index, launch_dimensions, device, exception_slot, exception_call }
    }

    super::launch_accessors!();

    /// `x + y * width + z * width * height`: the index of this invocation's pixel in
    /// a row-major image.
    pub fn launch_linear_index(&self) -> u32 {
        let (i, d) = (self.launch_index, self.launch_dimensions);
        i.x + d.x * (i.y + d.y * i.z)
    }

    /// Traces `ray` of ray type `R` into `scene`; the miss or closest-hit program
    /// writes the result into `payload` (`optixTrace`).
    #[doc(alias("optixTrace", "traceRayEXT", "OpTraceRayKHR"))]
    pub fn trace<R: RayType>(&mut self, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
        if R::CHECK_DEPTH {
            // Raygen traces at depth 1 (see `crate::exception`).
            R::set_depth(payload, 1);
        }
        super::trace::<R>(self.device, scene, ray, payload)
    }

    /// Shorthand for a ray from `origin` along `direction` over `[0, 1e16]`.
    #[doc(alias("optixTrace", "traceRayEXT"))]
    pub fn trace_from<R: RayType>(
        &mut self,
        scene: Traversable,
        origin: Vec3,
        direction: Vec3,
        payload: &mut R::Payload,
    ) {
        self.trace::<R>(scene, Ray::new(origin, direction), payload)
    }
}
