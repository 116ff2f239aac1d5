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
#[doc(alias(
    "optixGetPayload_0",
    "optixSetPayload_0",
    "optixGetPayload_1",
    "optixSetPayload_1",
    "optixGetPayload_2",
    "optixSetPayload_2",
    "optixGetPayload_3",
    "optixSetPayload_3",
    "rayPayloadEXT"
))]
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

/// The origin of a ray leaving a surface at `p` with unit normal `n` (pointing
/// to the side the ray goes), moved off the surface far enough that the ray
/// does not hit it again (Wächter and Binder, *Ray Tracing Gems* ch. 6, "A Fast
/// and Robust Method for Avoiding Self-Intersection"): each coordinate moves
/// `256 · n` units in the last place, or `n / 65536` near zero where ulps are
/// tiny. Trace from it with `t_min = 0`. For points whose error exceeds a few
/// ulps of their own coordinates (a large sphere's, computed from its centre),
/// offset by the error first, as `sphere::SurfaceHit::spawn_origin` does.
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    Vec3::new(offset_coordinate(p.x, n.x), offset_coordinate(p.y, n.y), offset_coordinate(p.z, n.z))
}

/// One coordinate of [`offset_ray_origin`].
fn offset_coordinate(p: f32, n: f32) -> f32 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    if p.abs() < ORIGIN {
        return p + FLOAT_SCALE * n;
    }
    let ulps = (INT_SCALE * n) as i32;
    // Moving away from zero adds to the magnitude's bits, towards zero subtracts.
    let step = if p < 0.0 { -ulps } else { ulps };
    f32::from_bits((p.to_bits() as i32).wrapping_add(step) as u32)
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

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::sampling::{random_unit_vector, Pcg};

    #[test]
    fn offset_origins_leave_the_plane_by_a_few_ulps() {
        // Points on random planes through the origin, at every scale: the offset
        // point is strictly on the normal's side (checked in f64), and not far.
        let mut rng = Pcg::new(21, 2);
        for i in 0..50_000 {
            let n = random_unit_vector(rng.next_vec2());
            let scale = 10f32.powi(i % 9 - 4);
            let q = random_unit_vector(rng.next_vec2()) * scale * rng.next_f32();
            let p = q - n * q.dot(n); // on the plane n·x = 0, up to rounding
            let off = offset_ray_origin(p, n);
            let (p64, o64, n64) = (p.as_dvec3(), off.as_dvec3(), n.as_dvec3());
            let lifted = (o64 - p64).dot(n64);
            assert!(lifted > 0.0, "{p} -> {off} along {n}");
            let bound = 3.0 * (256.0 * p.abs().max_element() as f64 * f32::EPSILON as f64 + 1.0 / 65536.0);
            assert!((o64 - p64).length() <= bound, "{p} -> {off}: {} > {bound}", (o64 - p64).length());
        }
        // Near zero the fixed step; exactly zero stays finite.
        assert_eq!(offset_ray_origin(Vec3::ZERO, Vec3::Y), Vec3::new(0.0, 1.0 / 65536.0, 0.0));
        let big = offset_ray_origin(Vec3::new(-1000.0, 1000.0, 1.0), Vec3::new(-1.0, 1.0, 0.0).normalize());
        assert!(big.x < -1000.0 && big.y > 1000.0 && big.z == 1.0);
    }
}
