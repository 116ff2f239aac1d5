//! Motion blur in software: a time per ray, and geometry that moves with it
//! (OptiX's `rayTime` argument of `optixTrace` and `optixGetRayTime`).
//!
//! A camera's shutter is open over `[0, 1]`; each camera sample draws its time
//! uniformly there and every ray of its path sees the scene at that time, so a
//! moving object's picture converges to its time average, sample by sample
//! (not one shutter time per launch, which correlates the noise across
//! pixels).
//!
//! Vulkan's ray time (`VK_NV_ray_tracing_motion_blur`) is an NVIDIA extension
//! that lavapipe does not have; raykit does not use it, on any device, so a
//! scene renders the same everywhere. The time instead travels beside the ray:
//! an intersection program cannot read the payload, so raygen writes the
//! sample's time to a buffer at its launch index ([`set_ray_time`]) and the
//! intersection program of moving geometry reads it back ([`ray_time`]). The
//! buffer has one `f32` per launch index (`ctx.buffer::<f32>(width * height)` on
//! the host), in the launch params or a record.
//!
//! Moving spheres (`raykit::Gas::moving_spheres`) move linearly from a start
//! centre at time 0 to an end centre at time 1; their GAS holds each sphere's
//! box around the whole sweep, and [`crate::sphere::report_moving`] intersects
//! the sphere where it is at the ray's time. Closest-hit shades the hit as it
//! shades a still sphere's ([`crate::sphere::SphereHit::surface`]).
//!
//! ```
//! use raykit_device::glam::{Vec3, Vec4};
//! use raykit_device::sphere::{self, SphereHit};
//! use raykit_device::{intersection, motion, raygen, Buffer, Intersection, LaunchParams, Ray, RayType, Raygen};
//! use raykit_device::{SbtRecordData, Traversable};
//!
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
//! pub struct Params { pub scene: Traversable, pub times: Buffer<f32>, pub samples: u32 }
//!
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Zeroable, SbtRecordData)]
//! pub struct Moving { pub spheres: Buffer<Vec4>, pub times: Buffer<f32> } // the hit group's record
//!
//! pub struct Radiance;
//! impl RayType for Radiance { type Payload = Vec3; }
//!
//! #[raygen]
//! fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] colour: &mut Vec3) {
//!     let time = 0.5; // a random number in [0, 1) per camera sample
//!     motion::set_ray_time(ctx, p.times, time);
//!     ctx.trace::<Radiance>(p.scene, Ray::new(Vec3::ZERO, Vec3::Z), colour);
//! }
//!
//! #[intersection]
//! fn moving_spheres(ctx: &mut Intersection, #[record] m: &Moving, #[attributes] hit: &mut SphereHit) {
//!     let time = motion::ray_time(ctx, m.times);
//!     sphere::report_moving(ctx, m.spheres, time, hit);
//! }
//! ```

use crate::{Buffer, Intersection, Raygen};

/// Sets the time of the rays raygen traces from now on (until set again) to
/// `time`, for the intersection programs that read it with [`ray_time`]:
/// writes it to `times` at the launch index.
#[doc(alias("optixTrace", "rayTime"))]
pub fn set_ray_time(ctx: &mut Raygen, times: Buffer<f32>, time: f32) {
    let index = ctx.launch_linear_index();
    ctx.store(times, index, time);
}

/// The time of the ray being intersected, as raygen set it with
/// [`set_ray_time`] for this launch index, clamped to the shutter's `[0, 1]`
/// (0 for NaN).
#[doc(alias("optixGetRayTime"))]
pub fn ray_time(ctx: &Intersection, times: Buffer<f32>) -> f32 {
    let (i, d) = (ctx.launch_index(), ctx.launch_dimensions());
    let time = ctx.load(times, i.x + d.x * (i.y + d.y * i.z));
    // Comparisons, not `max`/`min`: they say the same for NaN on every device.
    if time > 1.0 {
        1.0
    } else if time >= 0.0 {
        time
    } else {
        0.0 // negative or NaN
    }
}
