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

/// Both parametric distances where the line `origin + t · direction` meets the
/// sphere (`xyz` centre, `w` radius), nearest first; `None` when it misses or
/// the radius is not positive. Stable form (see the [module docs](self)).
pub fn roots(origin: Vec3, direction: Vec3, sphere: Vec4) -> Option<(f32, f32)> {
    let radius = sphere.w;
    let a = direction.dot(direction);
    // Also false for NaN.
    let valid = radius > 0.0 && a > 0.0;
    if !valid {
        return None;
    }
    let f = origin - sphere.truncate();
    let b = f.dot(direction);
    let c = f.dot(f) - radius * radius;
    // The ray's closest approach to the centre.
    let l = f - (b / a) * direction;
    let l_len = sqrt(l.dot(l));
    let disc = a * ((radius - l_len) * (radius + l_len));
    let meets = disc >= 0.0;
    if !meets {
        return None;
    }
    let s = sqrt(disc);
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

/// The attributes of a hit at distance `t` along the ray with the sphere: the
/// point projected onto the sphere, its outward normal and error bound.
pub fn hit_at(origin: Vec3, direction: Vec3, sphere: Vec4, t: f32) -> SphereHit {
    let centre = sphere.truncate();
    let radius = sphere.w;
    let local = (origin - centre) + t * direction;
    let length = sqrt(local.dot(local));
    let normal = if length > 0.0 { local / length } else { Vec3::Z };
    let point = centre + radius * normal;
    // The radius times a normal of a few ulps' error, and the rounding of the
    // sum; Vulkan allows 2.5 ulps for division and square roots: a factor of 2
    // to spare on both.
    let error = UNIT_ROUNDOFF * (8.0 * radius + 2.0 * point.abs().max_element());
    SphereHit { normal, point, error }
}

/// The nearest hit of the ray with the sphere with `t` in `[t_min, t_max]`:
/// its distance, hit kind ([`FRONT_FACE`] or [`BACK_FACE`]) and attributes.
pub fn intersect(origin: Vec3, direction: Vec3, sphere: Vec4, t_min: f32, t_max: f32) -> Option<(f32, u32, SphereHit)> {
    let (near, far) = roots(origin, direction, sphere)?;
    if near >= t_min && near <= t_max {
        Some((near, FRONT_FACE, hit_at(origin, direction, sphere, near)))
    } else if far >= t_min && far <= t_max {
        Some((far, BACK_FACE, hit_at(origin, direction, sphere, far)))
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
    let origin = ctx.object_ray_origin();
    let direction = ctx.object_ray_direction();
    let Some((near, far)) = roots(origin, direction, sphere) else { return false };
    let t_min = ctx.ray_tmin();
    if near >= t_min && near <= ctx.ray_tmax() {
        *hit = hit_at(origin, direction, sphere, near);
        if ctx.report_intersection(near, FRONT_FACE) {
            return true;
        }
    }
    if far >= t_min && far <= ctx.ray_tmax() {
        *hit = hit_at(origin, direction, sphere, far);
        return ctx.report_intersection(far, BACK_FACE);
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
