//! The closest-hit stage (`__closesthit__`): runs once for the closest hit a
//! ray accepted; may trace further rays and call callables.

use spirv_std::glam::Vec2;

use super::hit::{hit_accessors, hit_kind_accessors, HitRef};

/// What a closest-hit program may use: the ray, the hit, device, tracing and
/// callables. Typed hit attributes (from an intersection program) are an
/// `#[attributes] a: &T` parameter; for triangles without one,
/// [`ClosestHit::barycentrics`] gives the built-in attributes.
pub struct ClosestHit<'a> {
    hit: HitRef<'a>,
    barycentrics: Vec2,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
    /// The trace depth of the ray being shaded (see [`ClosestHit::trace_depth`]).
    depth: u32,
    /// The pipeline's `max_trace_depth` (`u32::MAX` when unknown).
    max_trace_depth: u32,
}

impl<'a> ClosestHit<'a> {
    #[doc(hidden)]
    pub fn __new(
        hit: HitRef<'a>,
        barycentrics: Vec2,
        device: super::DeviceAccess<'a>,
        exception_slot: u32,
        exception_call: &'a mut crate::exception::ExceptionDetails,
    ) -> Self {
        ClosestHit { hit, barycentrics, device, exception_slot, exception_call, depth: 1, max_trace_depth: u32::MAX }
    }

    super::recursive_trace!();

    /// Throws user exception `code` (OptiX's `optixThrowException`): the launch
    /// returns it to the host with this launch index, and the pipeline's
    /// `#[exception]` program, if any, runs now. The program goes on: return
    /// after it (see [`crate::exception`](mod@crate::exception)).
    #[doc(alias("optixThrowException"))]
    pub fn throw_exception(&mut self, code: u32) {
        super::throw_and_handle(self.device, self.exception_slot, self.hit.launch_index, code, self.exception_call)
    }

    hit_accessors!();
    hit_kind_accessors!();

    /// Distance along the ray to the hit (`optixGetRayTmax` in closest-hit).
    #[doc(alias("optixGetRayTmax", "gl_HitTEXT"))]
    pub fn hit_t(&self) -> f32 {
        self.hit.ray_tmax
    }

    /// The triangle barycentrics `(u, v)` of the hit (`optixGetTriangleBarycentrics`):
    /// the hit point is `(1-u-v)·v0 + u·v1 + v·v2`. Zero in programs that declare
    /// `#[attributes]` (they read their attributes there).
    #[doc(alias("optixGetTriangleBarycentrics"))]
    pub fn barycentrics(&self) -> Vec2 {
        self.barycentrics
    }

    /// Runs the callable at `sbt_index` with `data` (a `#[call_data]` parameter).
    #[doc(alias("optixDirectCall", "optixContinuationCall", "executeCallableEXT"))]
    pub fn call<T>(&mut self, sbt_index: u32, data: &mut T) {
        super::execute_callable(self.device, sbt_index, data)
    }
}
