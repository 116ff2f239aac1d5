//! Callable programs (`__direct_callable__`, `__continuation_callable__`), run
//! through the SBT's callable region by index.
//!
//! Vulkan has one callable stage. OptiX's distinction is kept where it can be
//! enforced: a [`DirectCallable`] has no `trace` method (a direct callable
//! cannot trace, so it needs no continuation stack); a [`ContinuationCallable`]
//! may trace. Both may call further callables.

use spirv_std::glam::UVec3;

use crate::{Ray, RayType, Traversable};

/// What a direct callable may use: launch index and size, device, callables.
pub struct DirectCallable<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
}

/// What a continuation callable may use: a direct callable's, and tracing.
pub struct ContinuationCallable<'a> {
    launch_index: UVec3,
    launch_dimensions: UVec3,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
    exception_call: &'a mut crate::exception::ExceptionDetails,
}

macro_rules! callable_common {
    ($ty:ident) => {
        impl<'a> $ty<'a> {
            #[doc(hidden)]
            pub fn __new(
                launch_index: UVec3,
                launch_dimensions: UVec3,
                device: super::DeviceAccess<'a>,
                exception_slot: u32,
                exception_call: &'a mut crate::exception::ExceptionDetails,
            ) -> Self {
                $ty { launch_index, launch_dimensions, device, exception_slot, exception_call }
            }

            super::launch_accessors!();
        }
    };
}
callable_common!(DirectCallable);
callable_common!(ContinuationCallable);

impl ContinuationCallable<'_> {
    /// Traces `ray` of ray type `R` into `scene` (`optixTrace`); `payload` is a
    /// `#[trace_payload]` parameter.
    #[doc(alias("optixTrace", "traceRayEXT"))]
    pub fn trace<R: RayType>(&mut self, scene: Traversable, ray: Ray, payload: &mut R::Payload) {
        if R::CHECK_DEPTH {
            // A callable traces at depth 1 (see `crate::exception`).
            R::set_depth(payload, 1);
        }
        super::trace::<R>(self.device, scene, ray, payload)
    }
}
