//! Built-in spheres (OptiX's `OPTIX_PRIMITIVE_TYPE_SPHERE`): a numerically robust
//! ray–sphere test, the hit attributes it reports and the surface point a
//! closest-hit program shades.
//!
//! Vulkan has no sphere primitive: a sphere is an AABB in the GAS and an
//! intersection program decides the hit. `raykit::Gas::spheres(ctx, centres, radii)`
//! builds those boxes and keeps the spheres in a `Buffer<Vec4>` (centre in `xyz`,
//! radius in `w`; `gas.sphere_buffer()`), indexed by the primitive index. The
//! intersection program is one line of the user's:
//!
//! ```
//! use raykit_device::glam::{Vec3, Vec4};
//! use raykit_device::sphere::{self, SphereHit};
//! use raykit_device::{closest_hit, intersection, Buffer, ClosestHit, Intersection, RayType, SbtRecordData};
//!
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Zeroable, SbtRecordData)]
//! pub struct Material { pub spheres: Buffer<Vec4>, pub albedo: Vec3 } // the hit group's record
//!
//! pub struct Radiance;
//! impl RayType for Radiance { type Payload = Vec3; }
//!
//! #[intersection]
//! fn spheres(ctx: &mut Intersection, #[record] m: &Material, #[attributes] hit: &mut SphereHit) {
//!     sphere::report(ctx, m.spheres, hit);
//! }
//!
//! #[closest_hit(ray = Radiance)]
//! fn shade(ctx: &mut ClosestHit, #[record] m: &Material, #[attributes] hit: &SphereHit, #[payload] c: &mut Vec3) {
//!     let surface = hit.surface(ctx); // world-space point on the sphere, outward normal, face
//!     *c = m.albedo * surface.normal.dot(-ctx.world_ray_direction().normalize()).max(0.0);
//!     // A bounce ray starts at `surface.spawn_origin(direction)` with t_min = 0.
//! }
//! ```
//!
//! Why a function rather than a ready entry point: the program needs the
//! spheres' buffer, and only the application knows where its handle lives (the
//! launch params or the hit group's record, both checked at every launch). A
//! function keeps that choice and its layout check in the user's types while the
//! user writes no intersection code; [`intersect`] is the same test for any
//! ray, on the host too (CPU references, tests).
//!
//! # The test
//! With `f = o − c`, the roots of `|o + t d − c|² = r²` are found in the stable
//! form of *Ray Tracing Gems*, ch. 7 ("Precision Improvements for Ray/Sphere
//! Intersection"): the discriminant from the ray's closest approach to the
//! centre, `a (r² − |f − (f·d / d·d) d|²)` instead of `b² − a c` (which cancels
//! for distant origins and grazing rays), and the near root as `c / q` with
//! `q = −b − sign(b) √disc` (no cancellation between `b` and `√disc`; the far
//! root is `q / a`). The ray may start inside the sphere (then the exit is the
//! hit, from the back face). Directions need not be normalised.
//!
//! The test stays finite and accurate for every sphere `Gas::spheres` accepts
//! (finite centre ± radius) and every finite ray: it runs in a frame centred on
//! the sphere, with `f` and `r` scaled by one power of two (exactly) to bring
//! the larger of `|f|∞` and `r` into `[1, 2)` and `d` by another to bring `|d|∞`
//! there, so that no square overflows (a centre at 1e20) or underflows (a
//! radius of 1e-20), and the roots are scaled back. Lengths are taken the same
//! way, and the discriminant's root as `√(a (r − |l|)) · √(r + |l|)` where the
//! product under one root would underflow. Rays and
//! spheres of ordinary size (the direction's largest component and the radius
//! within `[2⁻³⁰, 2³⁰]`, the origin within `2³⁰` of the centre) need no scaling
//! and skip it, as lengths whose square is within `[2⁻¹⁰⁰, 2¹⁰⁰]` do.
//!
//! # Hit attributes ([`SphereHit`]) and hit kinds
//! * `normal`: the object-space outward unit normal;
//! * `point`: the hit point projected onto the sphere (`centre + radius · normal`,
//!   object space), within `error` of it: no `f32` point lies exactly on a large
//!   sphere, so secondary rays start from [`SurfaceHit::spawn_origin`], outside;
//! * `error`: a bound on the point's distance from the exact surface.
//!
//! The hit kind is [`FRONT_FACE`] (the ray enters the sphere) or [`BACK_FACE`]
//! (it leaves: the origin is inside, or the entry was rejected by an any-hit
//! program); the parametric distance is the closest-hit's `ctx.hit_t()`.
//! [`SphereHit::surface`] takes all of it to world space ([`SurfaceHit`]), and
//! [`SurfaceHit::spawn_origin`] offsets the point along the normal by its error
//! bound and by [`offset_ray_origin`], so
//! secondary rays from a radius-1000 ground start outside it with `t_min = 0`.

// Comparisons, not `RangeInclusive::contains`: rust-gpu does not compile the
// reference `contains` takes in this code to valid SPIR-V.
#![allow(clippy::manual_range_contains)]

use spirv_std::glam::{Vec3, Vec4};

use crate::math::sqrt;
use crate::ray::offset_ray_origin;
use crate::sampling::{transform_normal_to_world, transform_point};
use crate::{Buffer, ClosestHit, Intersection, Matrix4x3};

/// Hit kind of a ray entering a sphere (hitting its outside).
pub const FRONT_FACE: u32 = 0;
/// Hit kind of a ray leaving a sphere (hitting its inside).
pub const BACK_FACE: u32 = 1;

/// 2⁻²⁴, the unit roundoff of `f32`.
const UNIT_ROUNDOFF: f32 = 1.0 / 16_777_216.0;

/// The hit attributes [`report`] writes (28 bytes, within Vulkan's guaranteed 32).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SphereHit {
    /// Outward unit normal at the hit, in object space.
    pub normal: Vec3,
    /// The hit point projected onto the sphere, in object space.
    pub point: Vec3,
    /// A bound on `point`'s distance from the exact surface (object space).
    pub error: f32,
}

/// A sphere hit in world space, for shading and spawning rays.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SurfaceHit {
    /// The hit point on the sphere, in world space.
    pub position: Vec3,
    /// The outward unit normal, in world space (not flipped towards the ray).
    pub normal: Vec3,
    /// Whether the ray hit the outside ([`FRONT_FACE`]).
    pub front_face: bool,
    /// A bound on `position`'s distance from the exact surface.
    pub error: f32,
}

impl SurfaceHit {
    /// The normal on the side the ray came from (`normal`, or `−normal` for a
    /// back-face hit), as Lambertian and dielectric materials use it.
    pub fn facing_normal(&self) -> Vec3 {
        if self.front_face {
            self.normal
        } else {
            -self.normal
        }
    }

    /// The origin of a ray leaving the surface along `direction`: the point
    /// moved off the surface, to the side `direction` goes, by its error bound
    /// and then by [`offset_ray_origin`]. Trace from it with `t_min = 0`.
    pub fn spawn_origin(&self, direction: Vec3) -> Vec3 {
        let n = if direction.dot(self.normal) >= 0.0 { self.normal } else { -self.normal };
        offset_ray_origin(self.position + self.error * n, n)
    }
}

impl SphereHit {
    /// The hit in world space, through the instance's transforms and with the
    /// hit kind of `ctx`.
    pub fn surface(&self, ctx: &ClosestHit) -> SurfaceHit {
        self.to_world(&ctx.object_to_world(), &ctx.world_to_object(), ctx.hit_kind())
    }

    /// The hit in world space, given the instance's transforms and the hit kind.
    pub fn to_world(&self, object_to_world: &Matrix4x3, world_to_object: &Matrix4x3, hit_kind: u32) -> SurfaceHit {
        let position = transform_point(object_to_world, self.point);
        let normal = transform_normal_to_world(world_to_object, self.normal);
        // The point's error grows with the transform's largest row sum; the
        // transform's own rounding is a few ulps of the terms it adds.
        let m = object_to_world;
        let row = |x: f32, y: f32, z: f32| x.abs() + y.abs() + z.abs();
        let scale = row(m.x_axis.x, m.y_axis.x, m.z_axis.x)
            .max(row(m.x_axis.y, m.y_axis.y, m.z_axis.y))
            .max(row(m.x_axis.z, m.y_axis.z, m.z_axis.z));
        let magnitude = scale * self.point.abs().max_element() + m.w_axis.abs().max_element();
        let error = self.error * scale + 8.0 * UNIT_ROUNDOFF * magnitude;
        SurfaceHit { position, normal, front_face: hit_kind == FRONT_FACE, error }
    }
}

/// Squares in `[2⁻¹⁰⁰, 2¹⁰⁰]`: no term of a dot product this large under- or
/// overflowed enough to change it.
const TINY_SQUARE: f32 = 1.0 / 1_267_650_600_228_229_401_496_703_205_376.0;
const HUGE_SQUARE: f32 = 1_267_650_600_228_229_401_496_703_205_376.0;

/// Whether `square` is within `[2⁻¹⁰⁰, 2¹⁰⁰]` (false for NaN).
fn ordinary_square(square: f32) -> bool {
    TINY_SQUARE <= square && square <= HUGE_SQUARE
}

/// Magnitudes in `[2⁻³⁰, 2³⁰]`: rays and spheres this size need no frame
/// scaling, as no sum or product of the test leaves `f32`'s normal range.
const SMALLEST_UNSCALED: f32 = 1.0 / 1_073_741_824.0;
const LARGEST_UNSCALED: f32 = 1_073_741_824.0;

/// `2^e` for `e` in `[-126, 127]` (normal `f32`s only: GPUs flush subnormals).
fn power_of_two(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

/// The exponent `e` of the power of two `2^-e` that takes `m > 0` into `[1, 2)`,
/// clamped so that `2^-e` stays a normal `f32` (`m`'s exponent; subnormal `m`
/// and those near `f32::MAX` land a little outside `[1, 2)`).
fn exponent_of(m: f32) -> i32 {
    let biased = ((m.to_bits() >> 23) & 0xff) as i32;
    normal_exponent(biased - 127)
}

/// `e` clamped to `[-126, 126]`, where `2^e` and `2^-e` are normal `f32`s.
fn normal_exponent(e: i32) -> i32 {
    e.clamp(-126, 126)
}

/// `x · 2^e` for `e` in `[-378, 378]`, in steps that never leave the normal
/// range themselves: exact unless the result overflows or underflows.
fn scale_by_power_of_two(x: f32, e: i32) -> f32 {
    if -126 <= e && e <= 126 {
        // One step: the same product (the other two factors are 1).
        return x * power_of_two(e);
    }
    let first = normal_exponent(e);
    let second = normal_exponent(e - first);
    x * power_of_two(first) * power_of_two(second) * power_of_two(e - first - second)
}

/// `|v|` without overflow or underflow of `v · v`: computed on `v` scaled by a
/// power of two to a largest component in `[1, 2)`.
fn robust_length(v: Vec3) -> f32 {
    let squared = v.dot(v);
    // Also false for NaN and infinities.
    if ordinary_square(squared) {
        // No square under- or overflowed: the scaled computation below gives
        // the same value.
        return sqrt(squared);
    }
    if !v.is_finite() {
        return f32::NAN;
    }
    let largest = v.abs().max_element();
    if largest == 0.0 {
        return 0.0;
    }
    let e = exponent_of(largest);
    let w = v * power_of_two(-e);
    scale_by_power_of_two(sqrt(w.dot(w)), e)
}

/// The ray relative to the sphere, scaled so that every sum and product of the
/// test stays in `f32`'s normal range: `f = (o − c) · 2^-ef`, `r · 2^-ef` with
/// the larger of `|f|∞` and `r` in `[1, 2)`, and `d · 2^-ed` with `|d|∞` in
/// `[1, 2)`. A distance `t'` along the scaled ray is `t = t' · 2^(ef − ed)`.
#[derive(Copy, Clone)]
struct SphereFrame {
    f: Vec3,
    d: Vec3,
    radius: f32,
    /// `ef − ed`.
    t_exponent: i32,
}

impl SphereFrame {
    /// The frame of the ray and sphere; `None` when the radius is not positive,
    /// the direction is zero, or an input is not finite.
    fn new(origin: Vec3, direction: Vec3, sphere: Vec4) -> Option<SphereFrame> {
        let radius = sphere.w;
        let centre = sphere.truncate();
        let d_largest = direction.abs().max_element();
        // Also false for NaN.
        let valid = radius > 0.0 && radius.is_finite() && d_largest > 0.0 && direction.is_finite();
        if !valid {
            return None;
        }
        // The common case: every magnitude within `[2⁻³⁰, 2³⁰]` (also false
        // for infinities), the frame the caller's own.
        let f = origin - centre;
        let unscaled = |m: f32| SMALLEST_UNSCALED <= m && m <= LARGEST_UNSCALED;
        if unscaled(d_largest) && unscaled(radius) && f.abs().max_element() <= LARGEST_UNSCALED {
            return Some(SphereFrame { f, d: direction, radius, t_exponent: 0 });
        }
        // `o − c` overflows when the two are more than `f32::MAX` apart: then
        // both are halved first (exactly), and the radius with them.
        let mut f = f;
        let mut radius = radius;
        let mut halved = 0;
        if !f.is_finite() {
            f = origin * 0.5 - centre * 0.5;
            radius *= 0.5;
            halved = 1;
            if !f.is_finite() {
                return None;
            }
        }
        let ef = exponent_of(f.abs().max_element().max(radius));
        let ed = exponent_of(d_largest);
        let to_frame = power_of_two(-ef);
        Some(SphereFrame {
            f: f * to_frame,
            d: direction * power_of_two(-ed),
            radius: radius * to_frame,
            t_exponent: ef + halved - ed,
        })
    }

    /// Both roots in the frame's scale, nearest first, in the stable form of
    /// the [module docs](self).
    fn roots(&self) -> Option<(f32, f32)> {
        let (f, d, radius) = (self.f, self.d, self.radius);
        let a = d.dot(d);
        let b = f.dot(d);
        let c = f.dot(f) - radius * radius;
        // The ray's closest approach to the centre.
        let l = robust_length(f - (b / a) * d);
        // Also false for NaN.
        let meets = l <= radius;
        if !meets {
            return None;
        }
        // √(a (r − l)(r + l)): one root where the product is of ordinary size,
        // else two, so that a tiny radius does not underflow.
        let discriminant = a * (radius - l) * (radius + l);
        let s =
            if ordinary_square(discriminant) { sqrt(discriminant) } else { sqrt(a * (radius - l)) * sqrt(radius + l) };
        let q = if b < 0.0 { s - b } else { -s - b };
        if q == 0.0 {
            // b = 0 and a tangent line: the double root at the closest approach.
            return Some((0.0, 0.0));
        }
        let (t0, t1) = (c / q, q / a);
        if t0 <= t1 {
            Some((t0, t1))
        } else {
            Some((t1, t0))
        }
    }

    /// A distance along the scaled ray as one along the caller's ray.
    fn to_ray(self, t_frame: f32) -> f32 {
        scale_by_power_of_two(t_frame, self.t_exponent)
    }

    /// A distance along the caller's ray as one along the scaled ray.
    fn to_frame(self, t: f32) -> f32 {
        scale_by_power_of_two(t, -self.t_exponent)
    }

    /// The hit attributes at distance `t_frame` along the scaled ray.
    fn hit(&self, sphere: Vec4, t_frame: f32) -> SphereHit {
        let centre = sphere.truncate();
        let radius = sphere.w;
        let local = self.f + t_frame * self.d;
        let length = robust_length(local);
        let normal = if length > 0.0 { local / length } else { Vec3::Z };
        let point = centre + radius * normal;
        // The radius times a normal of a few ulps' error, and the rounding of the
        // sum; Vulkan allows 2.5 ulps for division and square roots: a factor of 2
        // to spare on both.
        let error = UNIT_ROUNDOFF * (8.0 * radius + 2.0 * point.abs().max_element());
        SphereHit { normal, point, error }
    }
}

/// Both parametric distances where the line `origin + t · direction` meets the
/// sphere (`xyz` centre, `w` radius), nearest first; `None` when it misses, the
/// radius is not positive or the direction is zero. Stable form (see the
/// [module docs](self)), for every sphere `Gas::spheres` accepts and every
/// finite ray: computed relative to the centre and scaled by powers of two, so
/// that no square overflows or underflows (a root is infinite only where the
/// distance itself is past `f32::MAX`).
pub fn roots(origin: Vec3, direction: Vec3, sphere: Vec4) -> Option<(f32, f32)> {
    let frame = SphereFrame::new(origin, direction, sphere)?;
    let (t0, t1) = frame.roots()?;
    Some((frame.to_ray(t0), frame.to_ray(t1)))
}

/// The attributes of a hit at distance `t` along the ray with the sphere: the
/// point projected onto the sphere, its outward normal and error bound.
pub fn hit_at(origin: Vec3, direction: Vec3, sphere: Vec4, t: f32) -> SphereHit {
    match SphereFrame::new(origin, direction, sphere) {
        Some(frame) => frame.hit(sphere, frame.to_frame(t)),
        // No direction or radius: the point is the centre's.
        None => {
            let centre = sphere.truncate();
            SphereHit { normal: Vec3::Z, point: centre, error: UNIT_ROUNDOFF * 2.0 * centre.abs().max_element() }
        }
    }
}

/// The nearest hit of the ray with the sphere with `t` in `[t_min, t_max]`:
/// its distance, hit kind ([`FRONT_FACE`] or [`BACK_FACE`]) and attributes.
pub fn intersect(origin: Vec3, direction: Vec3, sphere: Vec4, t_min: f32, t_max: f32) -> Option<(f32, u32, SphereHit)> {
    let frame = SphereFrame::new(origin, direction, sphere)?;
    let (near, far) = frame.roots()?;
    let (near_t, far_t) = (frame.to_ray(near), frame.to_ray(far));
    if near_t >= t_min && near_t <= t_max {
        Some((near_t, FRONT_FACE, frame.hit(sphere, near)))
    } else if far_t >= t_min && far_t <= t_max {
        Some((far_t, BACK_FACE, frame.hit(sphere, far)))
    } else {
        None
    }
}

/// The intersection program of built-in spheres: reads sphere
/// `ctx.primitive_index()` from `spheres` (the GAS's `sphere_buffer()`),
/// intersects it with the object-space ray and reports the entry, or, when
/// the entry is outside the ray's interval or an any-hit program ignores it,
/// the exit. Writes `hit` before each report; returns whether a hit was
/// accepted.
pub fn report(ctx: &mut Intersection, spheres: Buffer<Vec4>, hit: &mut SphereHit) -> bool {
    let sphere = ctx.load(spheres, ctx.primitive_index());
    report_sphere(ctx, sphere, hit)
}

/// The intersection program of moving spheres (`raykit::Gas::moving_spheres`):
/// sphere `i` of the GAS moves linearly from `spheres[2i]` at time 0 to
/// `spheres[2i + 1]` at time 1 (centre in `xyz`, radius in `w`, the
/// `moving_sphere_buffer()`); the ray meets it where it is at `time` (from
/// [`crate::motion::ray_time`]), as [`report`] meets a still one.
pub fn report_moving(ctx: &mut Intersection, spheres: Buffer<Vec4>, time: f32, hit: &mut SphereHit) -> bool {
    let primitive = ctx.primitive_index();
    let (start, end) = (ctx.load(spheres, 2 * primitive), ctx.load(spheres, 2 * primitive + 1));
    report_sphere(ctx, moving_sphere_at(start, end, time), hit)
}

/// The sphere moving from `start` (time 0) to `end` (time 1) at `time`: its
/// centre interpolated linearly, exactly `start` at 0 and `end` at 1, and the
/// start's radius.
pub fn moving_sphere_at(start: Vec4, end: Vec4, time: f32) -> Vec4 {
    let centre = start.truncate() * (1.0 - time) + end.truncate() * time;
    centre.extend(start.w)
}

/// [`report`] for a sphere already read.
fn report_sphere(ctx: &mut Intersection, sphere: Vec4, hit: &mut SphereHit) -> bool {
    let Some(frame) = SphereFrame::new(ctx.object_ray_origin(), ctx.object_ray_direction(), sphere) else {
        return false;
    };
    let Some((near, far)) = frame.roots() else { return false };
    let (near_t, far_t) = (frame.to_ray(near), frame.to_ray(far));
    let t_min = ctx.ray_tmin();
    if near_t >= t_min && near_t <= ctx.ray_tmax() {
        *hit = frame.hit(sphere, near);
        if ctx.report_intersection(near_t, FRONT_FACE) {
            return true;
        }
    }
    if far_t >= t_min && far_t <= ctx.ray_tmax() {
        *hit = frame.hit(sphere, far);
        return ctx.report_intersection(far_t, BACK_FACE);
    }
    false
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::sampling::Pcg;

    /// Roots in f64 by the textbook formula, as the independent reference.
    fn roots_f64(o: Vec3, d: Vec3, s: Vec4) -> Option<(f64, f64)> {
        let (o, d, c) = (o.as_dvec3(), d.as_dvec3(), s.truncate().as_dvec3());
        let r = s.w as f64;
        let f = o - c;
        let (a, b, cc) = (d.dot(d), f.dot(d), f.dot(f) - r * r);
        let disc = b * b - a * cc;
        (disc >= 0.0).then(|| ((-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a))
    }

    #[test]
    fn roots_match_f64_for_random_rays() {
        let mut rng = Pcg::new(11, 5);
        let mut hits = 0;
        for _ in 0..20_000 {
            let s = Vec4::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 0.0, 0.2 + rng.next_f32());
            let o = Vec3::new(rng.next_f32() * 8.0 - 4.0, rng.next_f32() * 8.0 - 4.0, 5.0);
            let target = Vec3::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 0.0);
            let d = (target - o) * (0.5 + rng.next_f32());
            let want = roots_f64(o, d, s);
            // How far from tangency the ray passes, relative to the radius: near
            // tangency the roots are ill-conditioned (√ of a small discriminant).
            let (o64, d64, c64) = (o.as_dvec3(), d.as_dvec3().normalize(), s.truncate().as_dvec3());
            let f = o64 - c64;
            let miss_distance = (f - f.dot(d64) * d64).length() - s.w as f64;
            match (roots(o, d, s), want) {
                (Some((t0, t1)), Some((w0, w1))) => {
                    hits += 1;
                    if miss_distance < -1e-3 * s.w as f64 {
                        let scale = f.length() / d.length() as f64 + 1.0;
                        assert!((t0 as f64 - w0).abs() < 1e-5 * scale, "near {t0} vs {w0}");
                        assert!((t1 as f64 - w1).abs() < 1e-5 * scale, "far {t1} vs {w1}");
                    }
                }
                (None, None) => {}
                (got, want) => {
                    // Only rays within rounding of tangency may disagree.
                    assert!(miss_distance.abs() < 1e-5, "got {got:?}, want {want:?}, off by {miss_distance}");
                }
            }
        }
        assert!(hits > 1_000, "{hits}");
    }

    #[test]
    fn large_sphere_hits_are_on_the_surface() {
        // The radius-1000 ground under a camera 13 away: the projected point is
        // within its error bound of the exact surface, and bounce rays start outside.
        let ground = Vec4::new(0.0, -1000.0, 0.0, 1000.0);
        let origin = Vec3::new(13.0, 2.0, 3.0);
        let mut rng = Pcg::new(3, 9);
        for _ in 0..20_000 {
            // A point on the ground near the top, where a camera sees it.
            let (x, z) = (rng.next_f32() as f64 * 40.0 - 20.0, rng.next_f32() as f64 * 40.0 - 20.0);
            let target = Vec3::new(x as f32, ((1e6 - x * x - z * z).sqrt() - 1000.0) as f32, z as f32);
            let d = (target - origin).normalize();
            let (t, kind, hit) = intersect(origin, d, ground, 1e-3, 1e30).expect("the ground is below");
            assert_eq!(kind, FRONT_FACE);
            let distance = (hit.point.as_dvec3() - ground.truncate().as_dvec3()).length() - 1000.0;
            assert!(distance.abs() <= hit.error as f64, "{distance} > {}", hit.error);
            assert!(hit.error < 1e-3, "{}", hit.error);
            assert!(t > 0.0);
            // The spawn origin is outside, the exact sphere is not hit again.
            let surface = hit.to_world(&IDENTITY, &IDENTITY, kind);
            let up = surface.spawn_origin(surface.normal);
            assert!((up.as_dvec3() - ground.truncate().as_dvec3()).length() > 1000.0);
        }
    }

    /// Rays from origins `distance` from the centre (random directions) towards
    /// random points well inside the sphere, their directions scaled by
    /// `direction_scale`: both roots are finite and within `1e-5 (|f| + r) / |d|`
    /// of the f64 reference, and the hit point lies within its error bound of
    /// the sphere.
    fn check_hits(name: &str, centre: [f64; 3], radius: f64, distance: f64, direction_scale: f64) {
        check_hits_from(name, centre, radius, None, distance, direction_scale);
    }

    /// [`check_hits`] from `fixed_origin` if given.
    fn check_hits_from(
        name: &str,
        centre: [f64; 3],
        radius: f64,
        fixed_origin: Option<Vec3>,
        distance: f64,
        direction_scale: f64,
    ) {
        let centre64 = spirv_std::glam::DVec3::from_array(centre);
        let sphere = Vec4::new(centre[0] as f32, centre[1] as f32, centre[2] as f32, radius as f32);
        let c = sphere.truncate().as_dvec3();
        let r = sphere.w as f64;
        let seed = distance.to_bits() ^ direction_scale.to_bits() ^ radius.to_bits();
        let mut rng = Pcg::new(7, (seed ^ seed >> 32) as u32);
        let mut unit = || {
            let v = spirv_std::glam::DVec3::new(rng.next_f32() as f64, rng.next_f32() as f64, rng.next_f32() as f64);
            (v * 2.0 - 1.0).clamp_length(0.05, 1.0)
        };
        for _ in 0..2_000 {
            let origin = fixed_origin.unwrap_or_else(|| (centre64 + unit().normalize() * distance).as_vec3());
            assert!(origin.is_finite(), "{name}: {origin}");
            let target = c + unit() * 0.8 * r;
            let d = ((target - origin.as_dvec3()).normalize() * direction_scale).as_vec3();
            let (w0, w1) = roots_f64(origin, d, sphere).unwrap_or_else(|| panic!("{name}: the reference misses"));
            let (t0, t1) = roots(origin, d, sphere).unwrap_or_else(|| panic!("{name}: {origin} {d} misses {sphere}"));
            assert!(t0.is_finite() && t1.is_finite(), "{name}: roots {t0}, {t1}");
            let f = origin.as_dvec3() - c;
            let tolerance = 1e-5 * (f.length() + r) / d.as_dvec3().length();
            assert!((t0 as f64 - w0).abs() <= tolerance, "{name}: near {t0} vs {w0} (tolerance {tolerance})");
            assert!((t1 as f64 - w1).abs() <= tolerance, "{name}: far {t1} vs {w1} (tolerance {tolerance})");
            let (t, kind, hit) = intersect(origin, d, sphere, 0.0, f32::MAX).expect("the sphere is ahead");
            assert_eq!((t, kind), if t0 >= 0.0 { (t0, FRONT_FACE) } else { (t1, BACK_FACE) }, "{name}");
            assert!(hit.normal.is_finite() && (hit.normal.length() - 1.0).abs() < 1e-5, "{name}: {hit:?}");
            let off_surface = (hit.point.as_dvec3() - c).length() - r;
            assert!(off_surface.abs() <= hit.error as f64, "{name}: {off_surface} > {}", hit.error);
            assert_eq!(hit, hit_at(origin, d, sphere, t), "{name}");
        }
    }

    #[test]
    fn extreme_spheres_give_finite_roots_that_match_f64() {
        // Directions scaled from 1e-30 to 1e30, where the distances stay in f32.
        let scales = |distance: f64| [1e-30, 1e-10, 1.0, 1e10, 1e30].into_iter().filter(move |s| distance / s < 1e37);
        for scale in scales(1e21) {
            check_hits("centre 1e20, radius 1e19", [1e20, -3e19, 2e19], 1e19, 5e19, scale);
            check_hits("seen from 1e21 away", [1e20, -3e19, 2e19], 1e19, 1e21, scale);
            check_hits("from inside", [1e20, -3e19, 2e19], 1e19, 5e18, scale);
            check_hits("unit sphere", [1.0, 2.0, 3.0], 1.0, 10.0, scale);
        }
        for scale in scales(1e-15).filter(|s| 1e-19 / s > 1e-30) {
            check_hits("radius 1e-20 near the origin", [3e-20, -2e-20, 1e-20], 1e-20, 1e-19, scale);
            check_hits("radius 1e-20 from 1e-15 away", [3e-20, -2e-20, 1e-20], 1e-20, 1e-15, scale);
        }
        for scale in scales(1e30) {
            check_hits("origin 1e30 away", [1.0, 2.0, 3.0], 1e25, 1e30, scale);
        }
        for scale in scales(5e38) {
            check_hits("near f32::MAX", [2e38, 0.0, 0.0], 1e38, 1.3e38, scale);
            // Centre and origin more than f32::MAX apart.
            check_hits_from("4e38 apart", [2e38, 0.0, 0.0], 1e38, Some(Vec3::new(-2e38, 0.0, 0.0)), 0.0, scale);
        }
    }

    /// Within 4 ulps (relative 2⁻²²).
    fn close(t: f32, want: f32) -> bool {
        ((t as f64 - want as f64) / want as f64).abs() < 4.0 / 8_388_608.0
    }

    #[test]
    fn tiny_and_distant_spheres_on_axis() {
        // A radius of 1e-20 at the origin, from one unit away: hit and just missed.
        let tiny = Vec4::new(0.0, 0.0, 0.0, 1e-20);
        let (t0, t1) = roots(Vec3::new(0.0, 0.0, -1.0), Vec3::Z, tiny).expect("straight at it");
        assert_eq!((t0, t1), (1.0, 1.0));
        assert!(roots(Vec3::new(0.0, 2e-20, -1.0), Vec3::Z, tiny).is_none());
        let (t, kind, hit) = intersect(Vec3::new(0.0, 5e-21, -1e-19), Vec3::Z * 1e-30, tiny, 0.0, f32::MAX).unwrap();
        assert_eq!(kind, FRONT_FACE);
        let want = (1e-19f64 - (1e-40f64 - 25e-42).sqrt()) / 1e-30;
        assert!((t as f64 - want).abs() < 1e-6 * want, "{t} vs {want}");
        assert!((hit.normal - Vec3::new(0.0, 0.5, -0.866_025_4)).length() < 1e-5, "{hit:?}");
        // A unit sphere 1e30 down the axis.
        let (t0, t1) = roots(Vec3::new(-1e30, 0.0, 0.0), Vec3::X, Vec4::new(0.0, 0.0, 0.0, 1.0)).unwrap();
        assert!(close(t0, 1e30) && close(t1, 1e30), "{t0}, {t1}");
        // The largest sphere whose box fits in f32, from beyond it.
        let s = Vec4::new(-1e38, 0.0, 0.0, 2e38);
        let (t0, t1) = roots(Vec3::new(3e38, 0.0, 0.0), -Vec3::X, s).unwrap();
        // The exit is 6e38 away, past f32::MAX.
        assert!(close(t0, 2e38) && t1 == f32::INFINITY, "{t0}, {t1}");
        let (t0, t1) = roots(Vec3::new(3e38, 0.0, 0.0), -4.0 * Vec3::X, s).unwrap();
        assert!(close(t0, 0.5e38) && close(t1, 1.5e38), "{t0}, {t1}");
    }

    const IDENTITY: Matrix4x3 = Matrix4x3 { x_axis: Vec3::X, y_axis: Vec3::Y, z_axis: Vec3::Z, w_axis: Vec3::ZERO };

    #[test]
    fn inside_grazing_and_degenerate_rays() {
        let s = Vec4::new(1.0, 2.0, 3.0, 2.0);
        // From the centre: the exit, from the back, at the radius.
        let (t, kind, hit) = intersect(Vec3::new(1.0, 2.0, 3.0), Vec3::X, s, 0.0, 1e30).unwrap();
        assert_eq!((t, kind), (2.0, BACK_FACE));
        assert_eq!(hit.normal, Vec3::X);
        assert_eq!(hit.point, Vec3::new(3.0, 2.0, 3.0));
        // Passing 1e-3 inside or outside the rim at distance 1000.
        let o = Vec3::new(1.0 - 1000.0, 2.0, 3.0 + 2.0 - 1e-3);
        assert!(roots(o, Vec3::X, s).is_some());
        let o = Vec3::new(1.0 - 1000.0, 2.0, 3.0 + 2.0 + 1e-3);
        assert!(roots(o, Vec3::X, s).is_none());
        // Behind the ray, zero radius, NaN, zero direction: no hit.
        assert!(intersect(Vec3::new(10.0, 2.0, 3.0), Vec3::X, s, 0.0, 1e30).is_none());
        assert!(roots(Vec3::ZERO, Vec3::X, Vec4::new(5.0, 0.0, 0.0, 0.0)).is_none());
        assert!(roots(Vec3::ZERO, Vec3::X, Vec4::new(5.0, 0.0, 0.0, f32::NAN)).is_none());
        assert!(roots(Vec3::ZERO, Vec3::ZERO, s).is_none());
        // An interval that ends before the sphere.
        assert!(intersect(Vec3::new(-10.0, 2.0, 3.0), Vec3::X, s, 0.0, 8.0).is_none());
    }
}
