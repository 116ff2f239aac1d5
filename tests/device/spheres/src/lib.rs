//! Device programs of the built-in sphere tests: raygen traces ray `i` of a
//! buffer into a scene of `raykit::Gas::spheres` GASes, the library's sphere
//! intersection program finds the hits, and closest-hit records what a shader
//! sees (distance, hit kind, primitive, instance, the world-space surface
//! point, its error bound and normal). From each hit raygen traces one more
//! ray, from the surface's spawn origin along a direction the host chose, and
//! records what that ray hits. The triangle hit groups do the same for
//! `raykit::Gas::mesh` meshes through `raykit_device::triangle`. The motion
//! programs take a picture of moving spheres (`raykit::Gas::moving_spheres`):
//! orthographic rays down −z, each sample at a random time.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit_device::sampling::Pcg;
use raykit_device::sphere::{self, SphereHit};
use raykit_device::triangle::{self, MeshData};
use raykit_device::{
    any_hit, closest_hit, intersection, miss, motion, raygen, AnyHit, Buffer, ClosestHit, Intersection, LaunchParams,
    Miss, Ray, RayType, Raygen, SbtRecordData, Traversable,
};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// [`RAY_WORDS`] per ray: origin and `t_min`, direction and `t_max`, the
    /// bounce direction and 1 in `w` to trace it (0 not to).
    pub rays: Buffer<Vec4>,
    /// [`HIT_WORDS`] per ray, written as [`HitRecord::words`] lays them out.
    pub hits: Buffer<Vec4>,
    /// The scene.
    pub scene: Traversable,
}

/// `Vec4`s per ray in [`Params::rays`].
pub const RAY_WORDS: u32 = 3;
/// `Vec4`s per ray in [`Params::hits`]: the primary hit (three) and the bounce's (one).
pub const HIT_WORDS: u32 = 4;
/// The hit kind recorded for a miss.
pub const MISS: u32 = 99;

/// The record of the sphere hit group: the spheres of the GAS its instance holds.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct SphereRecord {
    /// `raykit::Gas::sphere_buffer` of the instance's GAS.
    pub spheres: Buffer<Vec4>,
}

/// What closest-hit saw, and (in) the bounce direction / (out) its origin.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct HitRecord {
    /// `hit_t`.
    pub t: f32,
    /// The hit kind, or [`MISS`].
    pub kind: u32,
    /// Primitive index.
    pub primitive: u32,
    /// Instance index.
    pub instance: u32,
    /// World-space surface point.
    pub position: Vec3,
    /// Its error bound.
    pub error: f32,
    /// World-space outward normal.
    pub normal: Vec3,
    /// 1 for a front-face hit.
    pub front: u32,
    /// In: the bounce direction; out: the spawn origin for it.
    pub bounce: Vec3,
}

impl HitRecord {
    /// Nothing hit yet, with the bounce direction to spawn for.
    pub fn miss(bounce: Vec3) -> HitRecord {
        HitRecord { kind: MISS, bounce, ..Default::default() }
    }

    /// The three `Vec4`s of the primary hit in [`Params::hits`].
    pub fn words(&self) -> [Vec4; 3] {
        [
            Vec4::new(self.t, self.kind as f32, self.primitive as f32, self.instance as f32),
            self.position.extend(self.error),
            self.normal.extend(self.front as f32),
        ]
    }
}

/// The one ray type.
pub struct Probe;
impl RayType for Probe {
    type Payload = HitRecord;
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] hit: &mut HitRecord) {
    let i = ctx.launch_index().x;
    let a = ctx.load(p.rays, RAY_WORDS * i);
    let b = ctx.load(p.rays, RAY_WORDS * i + 1);
    let bounce = ctx.load(p.rays, RAY_WORDS * i + 2);
    *hit = HitRecord::miss(bounce.truncate());
    ctx.trace::<Probe>(p.scene, Ray::new(a.truncate(), b.truncate()).with_interval(a.w, b.w), hit);
    let words = hit.words();
    ctx.store(p.hits, HIT_WORDS * i, words[0]);
    ctx.store(p.hits, HIT_WORDS * i + 1, words[1]);
    ctx.store(p.hits, HIT_WORDS * i + 2, words[2]);
    let mut second = Vec4::new(-1.0, -1.0, -1.0, -1.0);
    if hit.kind != MISS && bounce.w > 0.0 {
        let origin = hit.bounce;
        *hit = HitRecord::miss(Vec3::ZERO);
        ctx.trace::<Probe>(p.scene, Ray::new(origin, bounce.truncate()).with_interval(0.0, 1e30), hit);
        second = hit.words()[0];
    }
    ctx.store(p.hits, HIT_WORDS * i + 3, second);
}

#[miss(ray = Probe)]
fn ms(_ctx: &mut Miss, #[payload] hit: &mut HitRecord) {
    hit.kind = MISS;
}

/// The library's sphere test: the whole intersection program.
#[intersection]
fn is_sphere(ctx: &mut Intersection, #[record] r: &SphereRecord, #[attributes] hit: &mut SphereHit) {
    sphere::report(ctx, r.spheres, hit);
}

/// Ignores every entry, so the intersection program falls back to the exit.
#[any_hit(ray = Probe)]
fn ah_ignore_entries(ctx: &mut AnyHit, #[payload] _hit: &mut HitRecord) {
    if ctx.hit_kind() == sphere::FRONT_FACE {
        ctx.ignore_intersection();
    }
}

#[closest_hit(ray = Probe)]
fn ch_sphere(ctx: &mut ClosestHit, #[attributes] hit: &SphereHit, #[payload] p: &mut HitRecord) {
    let surface = hit.surface(ctx);
    p.t = ctx.hit_t();
    p.kind = ctx.hit_kind();
    p.primitive = ctx.primitive_index();
    p.instance = ctx.instance_index();
    p.position = surface.position;
    p.error = surface.error;
    p.normal = surface.normal;
    p.front = surface.front_face as u32;
    p.bounce = surface.spawn_origin(p.bounce);
}

/// The record of the triangle hit groups: the mesh of the instance's GAS.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct MeshRecord {
    /// `raykit::Gas::mesh_data` of the instance's GAS.
    pub mesh: MeshData,
}

/// A triangle hit: the surface point, its error bound along the normal (in
/// `error`), the geometric normal, the face, and the spawn origin.
#[closest_hit(ray = Probe)]
fn ch_triangle(ctx: &mut ClosestHit, #[record] r: &MeshRecord, #[payload] p: &mut HitRecord) {
    let surface = triangle::surface(ctx, &r.mesh);
    p.t = ctx.hit_t();
    p.kind = ctx.hit_kind();
    p.primitive = ctx.primitive_index();
    p.instance = ctx.instance_index();
    p.position = surface.position;
    p.error = surface.plane_error();
    p.normal = surface.geometric_normal;
    p.front = surface.front_face as u32;
    p.bounce = surface.spawn_origin(p.bounce);
}

/// A triangle hit's shading: the texture coordinates (in `position.xy`) and the
/// shading normal (in `normal`).
#[closest_hit(ray = Probe)]
fn ch_triangle_shading(ctx: &mut ClosestHit, #[record] r: &MeshRecord, #[payload] p: &mut HitRecord) {
    let surface = triangle::surface(ctx, &r.mesh);
    p.t = ctx.hit_t();
    p.kind = ctx.hit_kind();
    p.primitive = ctx.primitive_index();
    p.instance = ctx.instance_index();
    p.position = surface.uv.extend(0.0);
    p.normal = surface.shading_normal;
    p.front = surface.front_face as u32;
}

/// Launch params of the motion-blur picture.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct MotionParams {
    /// Per pixel (row-major, bottom row first): the fraction of its samples
    /// whose ray hit.
    pub image: Buffer<f32>,
    /// Per pixel: the time of its current sample.
    pub times: Buffer<f32>,
    /// The picture's lower-left corner in the `z = 0` plane.
    pub corner: Vec2,
    /// A pixel's side.
    pub pixel: f32,
    /// Samples per pixel.
    pub samples: u32,
    /// With 1, every sample's time is [`MotionParams::fixed_time`] instead of random.
    pub fixed: u32,
    /// The time of every sample when `fixed` is 1.
    pub fixed_time: f32,
    /// The picture's size in pixels.
    pub size: UVec2,
    /// The scene.
    pub scene: Traversable,
}

/// The record of the moving-sphere hit group.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct MovingRecord {
    /// `raykit::Gas::moving_sphere_buffer` of the instance's GAS.
    pub spheres: Buffer<Vec4>,
    /// [`MotionParams::times`].
    pub times: Buffer<f32>,
}

/// The ray type of the motion picture: 1 for a hit, 0 for a miss.
pub struct Exposure;
impl RayType for Exposure {
    type Payload = f32;
}

/// One ray per sample through the pixel's centre, down −z from `z = 10`, at
/// a random time in `[0, 1)` (or the fixed one).
#[raygen]
fn rg_motion(ctx: &mut Raygen, #[params] p: &MotionParams, #[payload] hit: &mut f32) {
    let (pixel, index) = (ctx.launch_index().truncate().as_vec2(), ctx.launch_linear_index());
    let centre = p.corner + (pixel + Vec2::splat(0.5)) * p.pixel;
    let mut rng = Pcg::new(index, 17);
    let mut hits = 0.0;
    let mut s = 0;
    while s < p.samples {
        let time = if p.fixed == 1 { p.fixed_time } else { rng.next_f32() };
        motion::set_ray_time(ctx, p.times, time);
        *hit = 0.0;
        ctx.trace::<Exposure>(p.scene, Ray::new(centre.extend(10.0), -Vec3::Z).with_interval(0.0, 100.0), hit);
        hits += *hit;
        s += 1;
    }
    ctx.store(p.image, index, hits / p.samples as f32);
}

#[miss(ray = Exposure)]
fn ms_motion(_ctx: &mut Miss, #[payload] hit: &mut f32) {
    *hit = 0.0;
}

/// Moving spheres where they are at the ray's time.
#[intersection]
fn is_moving(ctx: &mut Intersection, #[record] r: &MovingRecord, #[attributes] hit: &mut SphereHit) {
    let time = motion::ray_time(ctx, r.times);
    sphere::report_moving(ctx, r.spheres, time, hit);
}

#[closest_hit(ray = Exposure)]
fn ch_motion(_ctx: &mut ClosestHit, #[attributes] _hit: &SphereHit, #[payload] hit: &mut f32) {
    *hit = 1.0;
}
