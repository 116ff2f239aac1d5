//! The device programs of *Ray Tracing: The Next Week*'s final scene: spheres
//! (still and moving), boxes and a quad light as meshes, a checkered sphere,
//! a smoke-filled glass ball and a thin fog over everything.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::bounce::{self, state, Bounce};
use raykit_device::bytemuck::{Pod, Zeroable};
use raykit_device::camera::ThinLensCamera;
use raykit_device::glam::{UVec2, Vec3, Vec4};
use raykit_device::math::floor;
use raykit_device::medium::{isotropic_direction, ConstantMedium};
use raykit_device::sampling::Pcg;
use raykit_device::sphere::{self, SphereHit, SurfaceHit};
use raykit_device::triangle::{self, MeshData};
use raykit_device::{closest_hit, intersection, miss, motion, raygen, scatter, Buffer, ClosestHit, Intersection};
use raykit_device::{LaunchParams, Miss, Ray, RayType, Raygen, SbtRecordData, Traversable};

/// The launch params: one definition for the host and the device.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable, LaunchParams)]
#[bytemuck(crate = "raykit_device::bytemuck")]
pub struct Params {
    /// The scene.
    pub scene: Traversable,
    /// Per pixel: the radiance summed over every sample so far (`w`: their count).
    pub image: Buffer<Vec4>,
    /// Per pixel: the shutter time of its current sample, for moving spheres.
    pub times: Buffer<f32>,
    /// The image size.
    pub size: UVec2,
    /// Samples per pixel in this launch.
    pub samples: u32,
    /// The number of this launch (seeds the random numbers).
    pub launch: u32,
    /// Traces a path takes at most.
    pub bounces: u32,
    /// The camera.
    pub camera: ThinLensCamera,
}

/// A material, the hit record of one GAS.
#[repr(C)]
#[derive(Copy, Clone, Zeroable, SbtRecordData)]
#[bytemuck(crate = "raykit_device::bytemuck")]
pub struct Material {
    /// The GAS's spheres (still or moving), for the intersection programs.
    pub spheres: Buffer<Vec4>,
    /// [`Params::times`], for moving spheres.
    pub times: Buffer<f32>,
    /// The GAS's mesh, for closest-hit.
    pub mesh: MeshData,
    /// [`LAMBERTIAN`], [`METAL`], [`DIELECTRIC`], [`LIGHT`] or [`CHECKER`].
    pub kind: u32,
    /// Metal: the fuzz radius; dielectric: the index of refraction; checker: the squares' side.
    pub param: f32,
    /// The reflectance, or a light's radiance.
    pub albedo: Vec3,
}

/// Diffuse.
pub const LAMBERTIAN: u32 = 0;
/// A mirror blurred by `param`.
pub const METAL: u32 = 1;
/// Glass of index `param`.
pub const DIELECTRIC: u32 = 2;
/// A light of radiance `albedo`, from both faces.
pub const LIGHT: u32 = 3;
/// Diffuse, in 3D squares of side `param`: `albedo` and white.
pub const CHECKER: u32 = 4;

/// The smoke inside the glass ball at `SMOKE_BALL` (centre, radius).
pub const SMOKE: ConstantMedium = ConstantMedium { density: 0.2, albedo: Vec3::new(0.2, 0.4, 0.9) };
/// The glass ball the smoke fills.
pub const SMOKE_BALL: Vec4 = Vec4::new(360.0, 150.0, 145.0, 70.0);
/// The fog inside the ball `FOG_BALL`, around the whole scene.
pub const FOG: ConstantMedium = ConstantMedium { density: 0.0001, albedo: Vec3::ONE };
/// The fog's bounds.
pub const FOG_BALL: Vec4 = Vec4::new(0.0, 0.0, 0.0, 5000.0);

/// The one ray type.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = Bounce;
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] bounce: &mut Bounce) {
    let (pixel, index) = (ctx.launch_index().truncate().as_vec2(), ctx.launch_linear_index());
    let mut sum = Vec3::ZERO;
    let mut s = 0;
    while s < p.samples {
        let mut rng = Pcg::new(index, p.launch * p.samples + s);
        let uv = (pixel + rng.next_vec2()) / p.size.as_vec2();
        let ray = p.camera.ray(uv.x, uv.y, rng.next_vec2());
        motion::set_ray_time(ctx, p.times, rng.next_f32());
        sum += radiance(ctx, p, Ray::new(ray.origin, ray.direction.normalize()), &mut rng, bounce);
        s += 1;
    }
    ctx.store(p.image, index, ctx.load(p.image, index) + sum.extend(p.samples as f32));
}

/// Whether `point` is inside `ball` (centre, radius).
fn inside(point: Vec3, ball: Vec4) -> bool {
    (point - ball.truncate()).length() < ball.w
}

/// One path's radiance: a trace per step, and where the ray starts inside a
/// medium, a scattering distance that may come before the trace's hit.
fn radiance(ctx: &mut Raygen, p: &Params, mut ray: Ray, rng: &mut Pcg, bounce: &mut Bounce) -> Vec3 {
    let (mut throughput, mut radiance) = (Vec3::ONE, Vec3::ZERO);
    let mut traces = 0;
    while traces < p.bounces {
        bounce::trace_bounce::<Radiance>(ctx, p.scene, ray, rng, bounce);
        let (medium, mut reach) = (if inside(ray.origin, SMOKE_BALL) { SMOKE } else { FOG }, bounce.distance);
        if bounce.state == state::ESCAPED {
            // Out of the fog's ball, the light is gone (a black sky).
            reach = sphere::roots(ray.origin, ray.direction, FOG_BALL).map_or(0.0, |(_, far)| far.max(0.0));
        }
        let distance = medium.sample_distance(rng.next_f32());
        if distance < reach {
            throughput *= medium.albedo;
            let direction = isotropic_direction(rng.next_f32(), rng.next_f32());
            ray = Ray::new(ray.origin + distance * ray.direction, direction);
        } else {
            radiance += throughput * bounce.emitted;
            if bounce.state != state::SCATTERED {
                break;
            }
            throughput *= bounce.weight;
            ray = Ray::new(bounce.origin, bounce.direction);
        }
        traces += 1;
    }
    radiance
}

/// The sky is black: only the light lights the scene.
#[miss(ray = Radiance)]
fn ms(_ctx: &mut Miss, #[payload] bounce: &mut Bounce) {
    bounce.escape(Vec3::ZERO);
}

#[intersection]
fn is_sphere(ctx: &mut Intersection, #[record] m: &Material, #[attributes] hit: &mut SphereHit) {
    sphere::report(ctx, m.spheres, hit);
}

#[intersection]
fn is_moving(ctx: &mut Intersection, #[record] m: &Material, #[attributes] hit: &mut SphereHit) {
    let time = motion::ray_time(ctx, m.times);
    sphere::report_moving(ctx, m.spheres, time, hit);
}

#[closest_hit(ray = Radiance)]
fn ch_sphere(ctx: &mut ClosestHit, #[record] m: &Material, #[attributes] hit: &SphereHit, #[payload] b: &mut Bounce) {
    shade(m, &hit.surface(ctx), ctx.world_ray_direction(), ctx.hit_t(), b);
}

#[closest_hit(ray = Radiance)]
fn ch_mesh(ctx: &mut ClosestHit, #[record] m: &Material, #[payload] b: &mut Bounce) {
    let surface = triangle::surface(ctx, &m.mesh).surface_hit();
    shade(m, &surface, ctx.world_ray_direction(), ctx.hit_t(), b);
}

/// How the path goes on from a hit on material `m`.
fn shade(m: &Material, surface: &SurfaceHit, d: Vec3, t: f32, bounce: &mut Bounce) {
    bounce.hit(t);
    let mut albedo = m.albedo;
    let direction = if m.kind == METAL {
        scatter::metal(surface, d, m.param, &mut bounce.rng)
    } else if m.kind == DIELECTRIC {
        Some(scatter::dielectric(surface, d, m.param, &mut bounce.rng))
    } else if m.kind == LIGHT {
        bounce.emit(m.albedo);
        None
    } else {
        let square = surface.position / m.param;
        if m.kind == CHECKER && (floor(square.x) + floor(square.y) + floor(square.z)) as i32 & 1 == 1 {
            albedo = Vec3::splat(0.9);
        }
        Some(scatter::lambertian(surface, &mut bounce.rng))
    };
    bounce.scatter_from(surface, direction, albedo);
}
