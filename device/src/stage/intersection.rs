//! The intersection stage (`__intersection__`): computes hits with custom
//! primitives (AABBs in the GAS) and reports them with typed attributes.

use super::hit::{hit_accessors, HitRef};

/// What an intersection program may use: the ray, the primitive, device, and
/// [`Intersection::report_intersection`]. Its hit attributes are a
/// `#[attributes] a: &mut T` parameter, written before reporting.
pub struct Intersection<'a> {
    hit: HitRef<'a>,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
}

impl<'a> Intersection<'a> {
    #[doc(hidden)]
    pub fn __new(hit: HitRef<'a>, device: super::DeviceAccess<'a>, exception_slot: u32) -> Self {
        Intersection { hit, device, exception_slot }
    }

    hit_accessors!();

    /// Throws user exception `code` (OptiX's `optixThrowException`): the launch
    /// returns it to the host with this launch index. Vulkan forbids calls from
    /// this stage, so no `#[exception]` program runs. The program goes on:
    /// follow it with `ignore_intersection`, `terminate_ray` or a return.
    #[doc(alias("optixThrowException"))]
    pub fn throw_exception(&mut self, code: u32) {
        super::throw_exception(self.device, self.exception_slot, self.hit.launch_index, code);
    }

    /// Reports a hit at distance `t` with `hit_kind` (`0..=127`; larger values
    /// are reserved by Vulkan and are masked to 7 bits). The hit attributes are
    /// the values in the `#[attributes]` parameter at this moment. Returns
    /// whether the hit was accepted (`optixReportIntersection`).
    #[doc(alias("optixReportIntersection", "reportIntersectionEXT"))]
    pub fn report_intersection(&mut self, t: f32, hit_kind: u32) -> bool {
        #[cfg(target_arch = "spirv")]
        // SAFETY: only intersection programs have an `Intersection` context.
        unsafe {
            spirv_std::arch::report_intersection(t, hit_kind & 0x7f)
        }
        #[cfg(not(target_arch = "spirv"))]
        self.device.report_intersection(t, hit_kind & 0x7f)
    }
}
