//! The any-hit stage (`__anyhit__`): runs for each candidate hit along a ray
//! (unless the geometry is opaque) and may reject it or end the traversal.

use super::hit::{hit_accessors, hit_kind_accessors, HitRef};

/// What an any-hit program may use: the ray, the candidate hit, device, and
/// [`AnyHit::ignore_intersection`] / [`AnyHit::terminate_ray`].
pub struct AnyHit<'a> {
    hit: HitRef<'a>,
    device: super::DeviceAccess<'a>,
    exception_slot: u32,
}

impl<'a> AnyHit<'a> {
    #[doc(hidden)]
    pub fn __new(hit: HitRef<'a>, device: super::DeviceAccess<'a>, exception_slot: u32) -> Self {
        AnyHit { hit, device, exception_slot }
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
    hit_kind_accessors!();

    /// Rejects this candidate hit; traversal goes on (`optixIgnoreIntersection`).
    #[doc(alias("optixIgnoreIntersection", "ignoreIntersectionEXT"))]
    pub fn ignore_intersection(&mut self) -> ! {
        #[cfg(target_arch = "spirv")]
        // SAFETY: only any-hit programs have an `AnyHit` context.
        unsafe {
            spirv_std::arch::ignore_intersection()
        }
        #[cfg(not(target_arch = "spirv"))]
        self.device.ignore_intersection()
    }

    /// Accepts this hit and ends the traversal: the closest-hit program of this
    /// hit runs next (`optixTerminateRay`).
    #[doc(alias("optixTerminateRay", "terminateRayEXT"))]
    pub fn terminate_ray(&mut self) -> ! {
        #[cfg(target_arch = "spirv")]
        // SAFETY: only any-hit programs have an `AnyHit` context.
        unsafe {
            spirv_std::arch::terminate_ray()
        }
        #[cfg(not(target_arch = "spirv"))]
        self.device.terminate_ray()
    }
}
