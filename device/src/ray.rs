//! Rays and ray types.
//!
//! A *ray type* (OptiX's "ray type": radiance, shadow, …) is declared once, by
//! implementing [`RayType`] on a marker type. It names the payload type, the hit
//! group offset in the SBT and the miss program index; `trace::<R>` and the
//! programs declared with `ray = R` use the same declaration, so a payload that
//! differs between the caller and the callee is a compile error, and the host
//! places its SBT records from the same constants.

use spirv_std::glam::Vec3;

pub use spirv_std::ray_tracing::RayFlags;

/// A ray type: its payload, and where its programs sit in the SBT. The
/// defaults are those of a scene's only ray type (offset 0, stride 1, miss 0),
/// so one ray type needs only its payload:
/// `impl RayType for Radiance { type Payload = Vec3; }`.
pub trait RayType {
    /// The payload carried by rays of this type (`RayPayloadKHR`).
    type Payload;
    /// Offset of this ray type's hit groups in each SBT hit record block
    /// (`sbtRecordOffset` of `OpTraceRayKHR`).
    const SBT_OFFSET: u32 = 0;
    /// Number of ray types, the stride between consecutive geometries' hit records
    /// (`sbtRecordStride`).
    const SBT_STRIDE: u32 = 1;
    /// Index of this ray type's miss program in the SBT miss region.
    const MISS_INDEX: u32 = 0;
    /// Flags applied to every trace of this ray type.
    const FLAGS: RayFlags = RayFlags::NONE;
    /// Instance mask tested against each instance's mask (low 8 bits).
    const CULL_MASK: u32 = 0xff;
}

/// A ray: origin, direction and the parametric interval `[t_min, t_max]`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Ray {
    /// Origin in world space.
    pub origin: Vec3,
    /// Direction in world space (need not be normalised).
    pub direction: Vec3,
    /// Smallest accepted hit distance.
    pub t_min: f32,
    /// Largest accepted hit distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray over `[0, 1e16]`, as optixTriangle traces.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Ray { origin, direction, t_min: 0.0, t_max: 1e16 }
    }

    /// The same ray over `[t_min, t_max]`.
    pub fn with_interval(self, t_min: f32, t_max: f32) -> Self {
        Ray { t_min, t_max, ..self }
    }
}
