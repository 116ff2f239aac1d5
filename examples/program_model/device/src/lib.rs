//! One scene per OptiX program kind, for raykit's program-model tests:
//!
//! * spheres: AABB primitives whose intersection program reports the hit with
//!   typed attributes (the normal), shaded by closest-hit;
//! * cut-out: a triangle pair whose any-hit program ignores hits where a
//!   checkerboard is clear;
//! * callables: the closest-hit program picks a material callable by the
//!   instance's custom index (direct callables, and a continuation callable).
//!
//! The scene helpers are shared with the host tests' CPU references.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit_device::math::sqrt;
use raykit_device::{
    any_hit, closest_hit, continuation_callable, direct_callable, exception, intersection, miss, raygen, AnyHit,
    Buffer, ClosestHit, ContinuationCallable, DirectCallable, Exception, Intersection, LaunchParams, Miss, Ray,
    RayFlags, RayType, Raygen, SbtRecordData, Traversable,
};

/// Launch params of every scene here.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// RGBA8 pixels, row-major, row 0 at the top.
    pub image: Buffer<u32>,
    /// Sphere centres (xyz) and radii (w), one per AABB primitive.
    pub spheres: Buffer<Vec4>,
    /// Image size.
    pub size: UVec2,
    /// The scene.
    pub scene: Traversable,
}

/// The radiance ray type: payload = linear colour.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = Vec3;
}

/// Background colour (miss).
pub const BACKGROUND: Vec3 = Vec3::new(0.1, 0.2, 0.3);

/// An orthographic camera looking down -z from z = 10, covering `[-1, 1]²`:
/// the ray of pixel `index`.
pub fn ortho_ray(index: UVec2, size: UVec2) -> (Vec3, Vec3) {
    let x = (index.x as f32 + 0.5) / size.x as f32 * 2.0 - 1.0;
    let y = 1.0 - (index.y as f32 + 0.5) / size.y as f32 * 2.0;
    (Vec3::new(x, y, 10.0), Vec3::new(0.0, 0.0, -1.0))
}

/// Quantises a colour to RGBA8 (no sRGB: tests compare exact values).
pub use raykit_device::color::pack_unorm8 as pack;

/// The nearest `t ≥ t_min` where the ray meets the sphere `(centre, radius)`.
pub fn ray_sphere(origin: Vec3, dir: Vec3, sphere: Vec4, t_min: f32) -> Option<f32> {
    let centre = sphere.truncate();
    let oc = origin - centre;
    let a = dir.dot(dir);
    let b = oc.dot(dir);
    let c = oc.dot(oc) - sphere.w * sphere.w;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let s = sqrt(disc);
    let t0 = (-b - s) / a;
    let t1 = (-b + s) / a;
    if t0 >= t_min {
        Some(t0)
    } else if t1 >= t_min {
        Some(t1)
    } else {
        None
    }
}

/// A normal's colour: `n * 0.5 + 0.5`.
pub fn normal_color(n: Vec3) -> Vec3 {
    n * 0.5 + Vec3::splat(0.5)
}

/// Hit attributes of the sphere intersection program.
#[derive(Copy, Clone, Default)]
pub struct SphereHit {
    /// Object-space normal at the hit.
    pub normal: Vec3,
}

/// Whether the cut-out's checkerboard is solid at barycentrics `b` (8 cells
/// across each edge).
pub fn cutout_solid(b: Vec2) -> bool {
    let cx = (b.x * 8.0) as u32;
    let cy = (b.y * 8.0) as u32;
    (cx + cy) & 1 == 0
}

/// The colours of the material callables, by SBT callable index.
pub const MATERIALS: [Vec3; 3] = [Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];

/// Data passed to the material callables: in, the hit's normal; out, a colour.
#[derive(Copy, Clone, Default)]
pub struct MaterialCall {
    /// The normal (in) / the colour (out).
    pub value: Vec3,
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] color: &mut Vec3) {
    let index = ctx.launch_index().truncate();
    let (origin, dir) = ortho_ray(index, p.size);
    *color = Vec3::ZERO;
    ctx.trace_from::<Radiance>(p.scene, origin, dir, color);
    let pixel = ctx.launch_linear_index();
    ctx.store(p.image, pixel, pack(*color));
}

#[miss(ray = Radiance)]
fn ms(_ctx: &mut Miss, #[payload] color: &mut Vec3) {
    *color = BACKGROUND;
}

#[intersection]
fn sphere(ctx: &mut Intersection, #[params] p: &Params, #[attributes] hit: &mut SphereHit) {
    let s = ctx.load(p.spheres, ctx.primitive_index());
    let origin = ctx.object_ray_origin();
    let dir = ctx.object_ray_direction();
    if let Some(t) = ray_sphere(origin, dir, s, ctx.ray_tmin()) {
        if t <= ctx.ray_tmax() {
            hit.normal = ((origin + t * dir) - s.truncate()) / s.w;
            ctx.report_intersection(t, 0);
        }
    }
}

#[closest_hit(ray = Radiance)]
fn sphere_shade(_ctx: &mut ClosestHit, #[attributes] hit: &SphereHit, #[payload] color: &mut Vec3) {
    *color = normal_color(hit.normal);
}

#[any_hit(ray = Radiance)]
fn cutout(ctx: &mut AnyHit, #[payload] _color: &mut Vec3) {
    let _ = ctx.hit_kind();
    if !cutout_solid(triangle_barycentrics(ctx)) {
        ctx.ignore_intersection();
    }
}

/// The barycentrics of the candidate triangle hit, from the object-space ray
/// and the unit triangle (0,0,0)-(1,0,0)-(0,1,0) the cut-out scene uses.
pub fn triangle_barycentrics(ctx: &AnyHit) -> Vec2 {
    let p = ctx.object_ray_origin() + ctx.ray_tmax() * ctx.object_ray_direction();
    Vec2::new(p.x, p.y)
}

#[closest_hit(ray = Radiance)]
fn cutout_shade(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    let b = ctx.barycentrics();
    *color = Vec3::new(1.0 - b.x - b.y, b.x, b.y);
}

#[closest_hit(ray = Radiance)]
fn material_shade(ctx: &mut ClosestHit, #[payload] color: &mut Vec3, #[call_data] call: &mut MaterialCall) {
    call.value = Vec3::new(0.0, 0.0, 1.0);
    let material = ctx.instance_custom_index();
    ctx.call(material, call);
    *color = call.value;
}

#[direct_callable]
fn red(_ctx: &mut DirectCallable, #[callable_data] data: &mut MaterialCall) {
    data.value = MATERIALS[0];
}

#[direct_callable]
fn green(_ctx: &mut DirectCallable, #[callable_data] data: &mut MaterialCall) {
    data.value = MATERIALS[1];
}

#[continuation_callable]
fn blue(_ctx: &mut ContinuationCallable, #[callable_data] data: &mut MaterialCall) {
    data.value = MATERIALS[2];
}

// ---------------------------------------------------------------- shadows ---

/// Radiance rays of the shadows scene: two ray types, so stride 2.
pub struct ShadowedRadiance;
impl RayType for ShadowedRadiance {
    type Payload = Vec3;
    const SBT_OFFSET: u32 = 0;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 0;
}

/// Shadow rays: payload 1 when the light is visible, 0 when occluded; the
/// first hit ends the traversal.
pub struct Shadow;
impl RayType for Shadow {
    type Payload = u32;
    const SBT_OFFSET: u32 = 1;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 1;
    const FLAGS: RayFlags =
        RayFlags::TERMINATE_ON_FIRST_HIT.union(RayFlags::SKIP_CLOSEST_HIT_SHADER).union(RayFlags::OPAQUE);
}

/// The point light of the shadows scene.
pub const LIGHT: Vec3 = Vec3::new(0.3, 0.2, 4.0);
/// Ground colour where the light is visible.
pub const LIT: Vec3 = Vec3::new(0.9, 0.8, 0.6);
/// Ground colour in shadow.
pub const SHADOWED: Vec3 = Vec3::new(0.2, 0.2, 0.25);
/// Colour of the occluder.
pub const OCCLUDER: Vec3 = Vec3::new(1.0, 1.0, 1.0);
/// Primitives from this index on are the occluder; below, the ground.
pub const FIRST_OCCLUDER_PRIMITIVE: u32 = 2;
/// How far above the ground shadow rays start.
pub const SHADOW_EPSILON: f32 = 1e-3;

#[raygen]
fn rg_shadows(ctx: &mut Raygen, #[params] p: &Params, #[payload] color: &mut Vec3) {
    let index = ctx.launch_index().truncate();
    let (origin, dir) = ortho_ray(index, p.size);
    *color = Vec3::ZERO;
    ctx.trace_from::<ShadowedRadiance>(p.scene, origin, dir, color);
    let pixel = ctx.launch_linear_index();
    ctx.store(p.image, pixel, pack(*color));
}

#[miss(ray = ShadowedRadiance)]
fn ms_shadows(_ctx: &mut Miss, #[payload] color: &mut Vec3) {
    *color = BACKGROUND;
}

#[miss(ray = Shadow)]
fn ms_shadow(_ctx: &mut Miss, #[payload] visible: &mut u32) {
    *visible = 1;
}

#[closest_hit(ray = ShadowedRadiance)]
fn shade_shadowed(
    ctx: &mut ClosestHit,
    #[params] p: &Params,
    #[payload] color: &mut Vec3,
    #[trace_payload] visible: &mut u32,
) {
    if ctx.primitive_index() >= FIRST_OCCLUDER_PRIMITIVE {
        *color = OCCLUDER;
        return;
    }
    let hit = ctx.world_ray_origin() + ctx.hit_t() * ctx.world_ray_direction();
    let origin = hit + Vec3::new(0.0, 0.0, SHADOW_EPSILON);
    let to_light = LIGHT - origin;
    *visible = 0;
    ctx.trace::<Shadow>(p.scene, Ray::new(origin, to_light).with_interval(0.0, 1.0), visible);
    *color = if *visible == 1 { LIT } else { SHADOWED };
}

/// The shadow ray type's hit group (never run: shadow rays skip closest-hit).
#[closest_hit(ray = Shadow)]
fn shadow_hit(_ctx: &mut ClosestHit, #[payload] visible: &mut u32) {
    *visible = 0;
}

// --------------------------------------------------------------- sbt data ---

/// A hit record's data: the colour of the instance using it.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ColorRecord {
    /// Linear colour.
    pub color: Vec3,
}

#[closest_hit(ray = Radiance)]
fn record_color(_ctx: &mut ClosestHit, #[record] record: &ColorRecord, #[payload] color: &mut Vec3) {
    *color = record.color;
}

/// A hit record's data naming a buffer of colours (xyz; w unused) and the one to
/// shade with. It derives `SbtRecordData`, so every launch checks the handle.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct PaletteRecord {
    /// The colours.
    pub palette: Buffer<Vec4>,
    /// Which colour.
    pub index: u32,
}

#[closest_hit(ray = Radiance)]
fn palette_color(ctx: &mut ClosestHit, #[record] record: &PaletteRecord, #[payload] color: &mut Vec3) {
    *color = ctx.load(record.palette, record.index).truncate();
}

// ------------------------------------------------------------- exceptions ---

/// The launch indices where `rg_throw` throws, with their codes.
pub const THROWN: [(UVec2, u32); 2] = [(UVec2::new(3, 5), 0xBAD), (UVec2::new(7, 1), 0xF00D)];

#[raygen]
fn rg_throw(ctx: &mut Raygen, #[params] p: &Params) {
    let index = ctx.launch_index().truncate();
    let pixel = ctx.launch_linear_index();
    if index == THROWN[0].0 {
        ctx.throw_exception(THROWN[0].1);
        return;
    }
    if index == THROWN[1].0 {
        ctx.throw_exception(THROWN[1].1);
        return;
    }
    ctx.store(p.image, pixel, 1);
}

// ------------------------------------------------ specialization constants ---

/// The specialization constant that picks the colour of [`SPEC_SHADE`] (`spec_shade`).
pub const SHADE_MODE_SPEC_ID: u32 = 7;

/// Colours of [`SPEC_SHADE`] by the value of specialization constant
/// [`SHADE_MODE_SPEC_ID`] (0 unless the pipeline sets it).
pub const SPEC_COLORS: [Vec3; 2] = [Vec3::new(1.0, 0.5, 0.0), Vec3::new(0.0, 0.5, 1.0)];

#[closest_hit(ray = Radiance)]
fn spec_shade(_ctx: &mut ClosestHit, #[spec_constant(id = 7, default = 0)] mode: u32, #[payload] color: &mut Vec3) {
    *color = if mode == 0 { SPEC_COLORS[0] } else { SPEC_COLORS[1] };
}

/// What [`ON_EXCEPTION`] (`on_exception`) writes at the pixel of an invocation that threw: this
/// marker with the exception code in its low bits.
pub const EXCEPTION_MARKER: u32 = 0xE000_0000;

#[exception]
fn on_exception(ctx: &mut Exception, #[params] p: &Params) {
    let pixel = ctx.launch_linear_index();
    let code = ctx.exception_code();
    ctx.store(p.image, pixel, EXCEPTION_MARKER | code);
}
