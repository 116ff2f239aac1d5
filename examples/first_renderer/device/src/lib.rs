//! The device half of the README's first renderer: optixTriangle grown into a
//! small path tracer over built-in spheres, with three materials (diffuse,
//! metal, glass) in SBT records, a thin-lens camera and a sky.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::camera::ThinLensCamera;
use raykit_device::glam::{UVec2, Vec3, Vec4};
use raykit_device::optics::{reflect, refract, schlick};
use raykit_device::sampling::Pcg;
use raykit_device::sphere::{self, SphereHit};
use raykit_device::{
    closest_hit, intersection, miss, raygen, Buffer, ClosestHit, Intersection, LaunchParams, Miss, RayType, Raygen,
    SbtRecordData, Traversable,
};

/// Launch params, shared with the host.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// Per pixel: linear radiance summed over every sample so far (`w`: the count).
    pub image: Buffer<Vec4>,
    /// Image size in pixels.
    pub size: UVec2,
    /// Samples per pixel in this launch.
    pub samples: u32,
    /// Number of this launch (seeds the random numbers).
    pub launch: u32,
    /// The camera.
    pub camera: ThinLensCamera,
    /// The scene.
    pub scene: Traversable,
}

/// A material: the hit record of one GAS of spheres.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct Material {
    /// The GAS's spheres (`Gas::sphere_buffer`), for the intersection program.
    pub spheres: Buffer<Vec4>,
    /// [`DIFFUSE`], [`METAL`] or [`GLASS`].
    pub kind: u32,
    /// Metal: fuzz radius; glass: index of refraction.
    pub param: f32,
    /// Reflectance (diffuse, metal).
    pub albedo: Vec3,
}

/// Lambertian reflection.
pub const DIFFUSE: u32 = 0;
/// A mirror, blurred by a random offset of radius `param`.
pub const METAL: u32 = 1;
/// A dielectric of index `param`: Schlick's reflectance, refraction otherwise.
pub const GLASS: u32 = 2;
/// Bounces a path takes at most.
pub const MAX_DEPTH: u32 = 16;

/// What a bounce did: [`SCATTERED`] along `direction` from `origin` with
/// `weight`, [`ABSORBED`], or [`ESCAPED`] to the sky (whose colour is `weight`).
#[derive(Copy, Clone)]
pub struct Bounce {
    /// The path's random numbers, carried along.
    pub rng: Pcg,
    /// Attenuation of the scattered ray, or the sky's radiance.
    pub weight: Vec3,
    /// Where the scattered ray starts.
    pub origin: Vec3,
    /// Its direction.
    pub direction: Vec3,
    /// What happened.
    pub state: u32,
}

/// The ray went on.
pub const SCATTERED: u32 = 0;
/// The path ended on a surface.
pub const ABSORBED: u32 = 1;
/// The path left the scene.
pub const ESCAPED: u32 = 2;

/// The one ray type.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = Bounce;
}

/// The sky: white at the horizon, blue above (*Ray Tracing in One Weekend*).
pub fn sky(direction: Vec3) -> Vec3 {
    let t = 0.5 * (direction.normalize().y + 1.0);
    (1.0 - t) * Vec3::ONE + t * Vec3::new(0.5, 0.7, 1.0)
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] bounce: &mut Bounce) {
    let pixel = ctx.launch_index().truncate();
    let index = ctx.launch_linear_index();
    let mut sum = Vec3::ZERO;
    let mut s = 0;
    while s < p.samples {
        let mut rng = Pcg::new(index, p.launch * p.samples + s);
        let uv = (pixel.as_vec2() + rng.next_vec2()) / p.size.as_vec2();
        let ray = p.camera.ray(uv.x, uv.y, rng.next_vec2());
        let (mut origin, mut direction, mut throughput) = (ray.origin, ray.direction, Vec3::ONE);
        let mut depth = 0;
        while depth < MAX_DEPTH {
            *bounce = Bounce { rng, weight: Vec3::ZERO, origin, direction, state: ABSORBED };
            ctx.trace_from::<Radiance>(p.scene, origin, direction, bounce);
            rng = bounce.rng;
            if bounce.state == ESCAPED {
                sum += throughput * bounce.weight;
            }
            if bounce.state != SCATTERED {
                break;
            }
            (origin, direction, throughput) = (bounce.origin, bounce.direction, throughput * bounce.weight);
            depth += 1;
        }
        s += 1;
    }
    let old = ctx.load(p.image, index);
    ctx.store(p.image, index, old + sum.extend(p.samples as f32));
}

#[miss(ray = Radiance)]
fn ms(ctx: &mut Miss, #[payload] bounce: &mut Bounce) {
    bounce.weight = sky(ctx.world_ray_direction());
    bounce.state = ESCAPED;
}

#[intersection]
fn is_sphere(ctx: &mut Intersection, #[record] m: &Material, #[attributes] hit: &mut SphereHit) {
    sphere::report(ctx, m.spheres, hit);
}

#[closest_hit(ray = Radiance)]
fn ch(ctx: &mut ClosestHit, #[record] m: &Material, #[attributes] hit: &SphereHit, #[payload] bounce: &mut Bounce) {
    let surface = hit.surface(ctx);
    let d = ctx.world_ray_direction().normalize();
    let n = surface.facing_normal();
    let mut weight = m.albedo;
    let direction = if m.kind == METAL {
        (reflect(d, n) + m.param * bounce.rng.in_unit_sphere()).normalize()
    } else if m.kind == GLASS {
        weight = Vec3::ONE;
        let eta = if surface.front_face { 1.0 / m.param } else { m.param };
        let refracted = refract(d, n, eta);
        let reflects = bounce.rng.next_f32() < schlick(-d.dot(n), eta);
        match refracted {
            Some(t) if !reflects => t,
            _ => reflect(d, n),
        }
    } else {
        bounce.rng.cosine_around(n)
    };
    // A fuzzed mirror ray below the surface is absorbed.
    bounce.state = if direction.dot(n) > 0.0 || m.kind == GLASS { SCATTERED } else { ABSORBED };
    bounce.weight = weight;
    bounce.origin = surface.spawn_origin(direction);
    bounce.direction = direction;
}
