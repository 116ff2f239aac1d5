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
    /// Whether rays of this type carry their trace depth in their payload, so
    /// that the miss and closest-hit programs declared for this ray type
    /// (`#[closest_hit(ray = R)]`) know how deep they run and their own traces
    /// stop at the pipeline's `max_trace_depth`: a trace that would go deeper is
    /// not made, and throws [`TRACE_DEPTH_EXCEEDED`](crate::exception::TRACE_DEPTH_EXCEEDED)
    /// instead (see [`crate::exception`](mod@crate::exception)). Opt-in, because
    /// the depth is a word of the payload that every program of the ray type,
    /// GLSL and WGSL twins included, must agree on: implement
    /// [`RayType::depth`] and [`RayType::set_depth`] on that word.
    ///
    /// ```
    /// # use raykit_device::RayType;
    /// #[derive(Copy, Clone, Default)]
    /// pub struct Payload { pub color: [f32; 3], pub depth: u32 }
    /// pub struct Radiance;
    /// impl RayType for Radiance {
    ///     type Payload = Payload;
    ///     const CHECK_DEPTH: bool = true;
    ///     fn depth(payload: &Payload) -> u32 { payload.depth }
    ///     fn set_depth(payload: &mut Payload, depth: u32) { payload.depth = depth }
    /// }
    /// ```
    const CHECK_DEPTH: bool = false;
    /// The trace depth `payload` carries (1 for a ray traced by raygen), when
    /// [`RayType::CHECK_DEPTH`]; never called otherwise.
    fn depth(_payload: &Self::Payload) -> u32 {
        1
    }
    /// Writes the trace depth into `payload`: `trace::<R>` calls it just before
    /// tracing, when [`RayType::CHECK_DEPTH`].
    fn set_depth(_payload: &mut Self::Payload, _depth: u32) {}
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
