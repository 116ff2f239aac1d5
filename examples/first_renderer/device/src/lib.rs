//! The device programs of the first renderer: optixTriangle grown into the path
//! tracer of *Ray Tracing in One Weekend*, over built-in spheres.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::bounce::{self, Bounce};
use raykit_device::bytemuck::{Pod, Zeroable};
use raykit_device::camera::ThinLensCamera;
use raykit_device::glam::{UVec2, Vec3, Vec4};
use raykit_device::sampling::Pcg;
use raykit_device::sphere::{self, SphereHit};
use raykit_device::{closest_hit, intersection, miss, raygen, scatter, Buffer, ClosestHit, Element, Intersection};
use raykit_device::{LaunchParams, Miss, RayType, Raygen, SbtRecordData, Traversable};

/// The launch params: one definition for the host and the device.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable, LaunchParams)]
#[bytemuck(crate = "raykit_device::bytemuck")]
pub struct Params {
    /// Per pixel: the radiance summed over every sample so far (`w`: their count).
    pub image: Buffer<Vec4>,
    /// The image size.
    pub size: UVec2,
    /// Samples per pixel in this launch.
    pub samples: u32,
    /// The number of this launch (seeds the random numbers).
    pub launch: u32,
    /// The camera.
    pub camera: ThinLensCamera,
    /// The scene.
    pub scene: Traversable,
}

/// What each sphere has of its own, in a buffer indexed by primitive: its colour.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable, Element)]
#[bytemuck(crate = "raykit_device::bytemuck")]
pub struct Paint {
    /// The reflectance (white for glass).
    pub albedo: Vec3,
}

/// A material, the hit record of one GAS of spheres.
#[repr(C)]
#[derive(Copy, Clone, Zeroable, SbtRecordData)]
#[bytemuck(crate = "raykit_device::bytemuck")]
pub struct Material {
    /// The GAS's spheres (`Gas::sphere_buffer`), for the intersection program.
    pub spheres: Buffer<Vec4>,
    /// Each sphere's paint.
    pub paints: Buffer<Paint>,
    /// [`LAMBERTIAN`], [`METAL`] or [`DIELECTRIC`].
    pub kind: u32,
    /// Metal: the fuzz radius; dielectric: the index of refraction.
    pub param: f32,
}

/// Diffuse.
pub const LAMBERTIAN: u32 = 0;
/// A mirror blurred by `param`.
pub const METAL: u32 = 1;
/// Glass of index `param`.
pub const DIELECTRIC: u32 = 2;
/// Traces a path takes at most.
pub const MAX_BOUNCES: u32 = 16;

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
        sum += bounce::trace_path::<Radiance>(ctx, p.scene, ray, &mut rng, MAX_BOUNCES, bounce);
        s += 1;
    }
    ctx.store(p.image, index, ctx.load(p.image, index) + sum.extend(p.samples as f32));
}

/// The sky: white at the horizon, blue above.
#[miss(ray = Radiance)]
fn ms(ctx: &mut Miss, #[payload] bounce: &mut Bounce) {
    let t = 0.5 * (ctx.world_ray_direction().normalize().y + 1.0);
    bounce.escape((1.0 - t) * Vec3::ONE + t * Vec3::new(0.5, 0.7, 1.0));
}

#[intersection]
fn is_sphere(ctx: &mut Intersection, #[record] m: &Material, #[attributes] hit: &mut SphereHit) {
    sphere::report(ctx, m.spheres, hit);
}

#[closest_hit(ray = Radiance)]
fn ch(ctx: &mut ClosestHit, #[record] m: &Material, #[attributes] hit: &SphereHit, #[payload] bounce: &mut Bounce) {
    let (surface, d) = (hit.surface(ctx), ctx.world_ray_direction());
    let paint = ctx.load(m.paints, ctx.primitive_index());
    let direction = if m.kind == METAL {
        scatter::metal(&surface, d, m.param, &mut bounce.rng)
    } else if m.kind == DIELECTRIC {
        Some(scatter::dielectric(&surface, d, m.param, &mut bounce.rng))
    } else {
        Some(scatter::lambertian(&surface, &mut bounce.rng))
    };
    bounce.scatter_from(&surface, direction, paint.albedo);
}
