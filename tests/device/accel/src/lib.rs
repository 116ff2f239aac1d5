//! Device programs of the acceleration-structure tests, and what the host's CPU
//! reference shares with them.
//!
//! The camera is orthographic: the ray of pixel `(x, y)` starts at
//! `(px, py, 10)` and goes along -z, so a CPU reference only needs 2-D tests.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, UVec3, Vec2, Vec3};
use raykit_device::math::sqrt;
use raykit_device::{
    any_hit, closest_hit, intersection, miss, raygen, AnyHit, Buffer, ClosestHit, Intersection, LaunchParams, Miss,
    Ray, RayFlags, RayType, Raygen, Traversable,
};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// RGBA8 pixels, row-major, row 0 at the top.
    pub image: Buffer<u32>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Padding to keep the window on 16 bytes.
    pub _pad: u32,
    /// Left edge of the orthographic window (world x).
    pub x0: f32,
    /// Bottom edge (world y).
    pub y0: f32,
    /// Right edge.
    pub x1: f32,
    /// Top edge.
    pub y1: f32,
    /// The scene.
    pub scene: Traversable,
}

/// SBT data of hit groups and of the miss program: a colour.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ColorData {
    /// Linear RGB in `[0, 1]`.
    pub color: Vec3,
}

/// The one ray type. Its cull mask is 0x01: instances whose mask lacks bit 0
/// are invisible to it.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = Vec3;
    const CULL_MASK: u32 = 0x01;
}

/// Height the camera's rays start from.
pub const CAMERA_Z: f32 = 10.0;

/// World `(x, y)` of the centre of pixel `index` (row 0 at the top).
pub fn pixel_position(index: UVec2, params: &Params) -> Vec2 {
    let fx = (index.x as f32 + 0.5) / params.width as f32;
    let fy = (index.y as f32 + 0.5) / params.height as f32;
    Vec2::new(params.x0 + fx * (params.x1 - params.x0), params.y1 - fy * (params.y1 - params.y0))
}

/// Packs a colour in `[0, 1]` as RGBA8 without any transfer function.
pub fn pack_unorm(c: Vec3) -> u32 {
    let q = |v: f32| -> u32 { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u32 };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

/// The barycentric colour `(1 - u - v, u, v)`.
pub fn barycentric_color(b: Vec2) -> Vec3 {
    Vec3::new(1.0 - b.x - b.y, b.x, b.y)
}

/// Centre and radius of the sphere inside AABB `primitive` of the procedural tests.
pub fn sphere(primitive: u32) -> (Vec3, f32) {
    (Vec3::new(primitive as f32 - 1.0, 0.0, 0.0), 0.4)
}

/// Distance along the ray to the first hit with the sphere within
/// `[t_min, t_max]`, or a negative value for none.
pub fn hit_sphere(origin: Vec3, direction: Vec3, center: Vec3, radius: f32, t_min: f32, t_max: f32) -> f32 {
    let oc = origin - center;
    let a = direction.dot(direction);
    let b = oc.dot(direction);
    let c = oc.dot(oc) - radius * radius;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return -1.0;
    }
    let s = sqrt(disc);
    let t0 = (-b - s) / a;
    let t1 = (-b + s) / a;
    if t0 >= t_min && t0 <= t_max {
        t0
    } else if t1 >= t_min && t1 <= t_max {
        t1
    } else {
        -1.0
    }
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] params: &Params, #[payload] color: &mut Vec3) {
    let index: UVec3 = ctx.launch_index();
    let p = pixel_position(index.truncate(), params);
    *color = Vec3::ZERO;
    ctx.trace_from::<Radiance>(params.scene, Vec3::new(p.x, p.y, CAMERA_Z), Vec3::new(0.0, 0.0, -1.0), color);
    let pixel = ctx.launch_linear_index();
    ctx.store(params.image, pixel, pack_unorm(*color));
}

#[miss(ray = Radiance)]
fn ms(_ctx: &mut Miss, #[record] data: &ColorData, #[payload] color: &mut Vec3) {
    *color = data.color;
}

/// Colours a hit with its hit group record's colour.
#[closest_hit(ray = Radiance)]
fn ch_record(_ctx: &mut ClosestHit, #[record] data: &ColorData, #[payload] color: &mut Vec3) {
    *color = data.color;
}

/// Colours a hit like [`ch_record`], after an `assert!` that it is not on
/// primitive `refused` (a specialization constant; none by default), which it
/// first announces with `println!` when it runs on the CPU backend.
#[closest_hit(ray = Radiance)]
fn ch_checked(
    ctx: &mut ClosestHit,
    #[record] data: &ColorData,
    #[payload] color: &mut Vec3,
    #[spec_constant(id = 7, default = 4294967295)] refused: u32,
) {
    let primitive = ctx.primitive_index();
    #[cfg(not(target_arch = "spirv"))]
    if primitive == refused {
        let index = ctx.launch_index();
        println!("ch_checked: primitive {primitive} hit at launch index ({}, {})", index.x, index.y);
    }
    assert!(primitive != refused, "the ray hit the refused primitive");
    *color = data.color;
}

/// Colours a triangle hit by its barycentrics.
#[closest_hit(ray = Radiance)]
fn ch_bary(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    *color = barycentric_color(ctx.barycentrics());
}

/// Intersection program: the sphere of [`sphere`] inside each AABB, in object space.
#[intersection]
fn is_sphere(ctx: &mut Intersection, #[attributes] attribute: &mut Vec2) {
    let (center, radius) = sphere(ctx.primitive_index());
    let t =
        hit_sphere(ctx.object_ray_origin(), ctx.object_ray_direction(), center, radius, ctx.ray_tmin(), ctx.ray_tmax());
    if t >= 0.0 {
        *attribute = Vec2::new(0.0, 0.0);
        ctx.report_intersection(t, 0);
    }
}

/// Closest-hit that writes the instance's custom index into the red channel
/// (as `index / 255`) and 1 into blue.
#[closest_hit(ray = Radiance)]
fn ch_custom_index(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    *color = Vec3::new(ctx.instance_custom_index() as f32 / 255.0, 0.0, 1.0);
}

/// The ray types of the traversal-rules test: one per set of ray flags (and
/// one with another cull mask); all share the SBT placement of [`Radiance`].
macro_rules! rule_rays {
    ($($(#[$doc:meta])* $name:ident = $flags:expr, $mask:expr;)*) => {$(
        $(#[$doc])*
        pub struct $name;
        impl RayType for $name {
            type Payload = Vec3;
            const FLAGS: RayFlags = $flags;
            const CULL_MASK: u32 = $mask;
        }
    )*};
}
rule_rays! {
    /// No flags, every instance visible.
    Plain = RayFlags::NONE, 0xff;
    /// Back-facing triangles culled.
    CullBack = RayFlags::CULL_BACK_FACING_TRIANGLES, 0xff;
    /// Front-facing triangles culled.
    CullFront = RayFlags::CULL_FRONT_FACING_TRIANGLES, 0xff;
    /// Every candidate opaque (no any-hit).
    AllOpaque = RayFlags::OPAQUE, 0xff;
    /// Every candidate non-opaque (any-hit everywhere).
    NoneOpaque = RayFlags::NO_OPAQUE, 0xff;
    /// Opaque candidates culled.
    CullOpaque = RayFlags::CULL_OPAQUE, 0xff;
    /// Non-opaque candidates culled.
    CullNoOpaque = RayFlags::CULL_NO_OPAQUE, 0xff;
    /// A shadow ray: the first accepted hit ends it, no closest-hit runs.
    Shadow = RayFlags::from_bits_retain(
        RayFlags::TERMINATE_ON_FIRST_HIT.bits() | RayFlags::SKIP_CLOSEST_HIT_SHADER.bits()
    ), 0xff;
    /// Only instances with mask bit 1.
    MaskTwo = RayFlags::NONE, 0x02;
    /// Triangles skipped.
    NoTriangles = RayFlags::SKIP_TRIANGLES, 0xff;
}

/// How many ray types [`RG_RULES`] chooses from.
pub const RULE_MODES: u32 = 10;

/// Traces one ray along -z per pixel with the ray type `mode` selects (a
/// specialization constant: 0 [`Plain`] … 9 [`NoTriangles`]); the payload
/// starts green, which a shadow ray that hits keeps.
#[raygen]
fn rg_rules(
    ctx: &mut Raygen,
    #[params] params: &Params,
    #[payload] color: &mut Vec3,
    #[spec_constant(id = 8, default = 0)] mode: u32,
) {
    let index: UVec3 = ctx.launch_index();
    let p = pixel_position(index.truncate(), params);
    let (origin, direction) = (Vec3::new(p.x, p.y, CAMERA_Z), Vec3::new(0.0, 0.0, -1.0));
    *color = Vec3::new(0.0, 1.0, 0.0);
    let scene = params.scene;
    match mode {
        0 => ctx.trace_from::<Plain>(scene, origin, direction, color),
        1 => ctx.trace_from::<CullBack>(scene, origin, direction, color),
        2 => ctx.trace_from::<CullFront>(scene, origin, direction, color),
        3 => ctx.trace_from::<AllOpaque>(scene, origin, direction, color),
        4 => ctx.trace_from::<NoneOpaque>(scene, origin, direction, color),
        5 => ctx.trace_from::<CullOpaque>(scene, origin, direction, color),
        6 => ctx.trace_from::<CullNoOpaque>(scene, origin, direction, color),
        7 => ctx.trace_from::<Shadow>(scene, origin, direction, color),
        8 => ctx.trace_from::<MaskTwo>(scene, origin, direction, color),
        _ => ctx.trace_from::<NoTriangles>(scene, origin, direction, color),
    }
    let pixel = ctx.launch_linear_index();
    ctx.store(params.image, pixel, pack_unorm(*color));
}

/// Writes what was hit: red 1 for a front face and 0.5 for a back face, green
/// the instance index + 1 and blue the primitive index + 1, in sixteenths.
#[closest_hit(ray = Plain)]
fn ch_rules(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    let red = if ctx.is_front_face_hit() { 1.0 } else { 0.5 };
    let green = (ctx.instance_index() + 1) as f32 / 16.0;
    let blue = (ctx.primitive_index() + 1) as f32 / 16.0;
    *color = Vec3::new(red, green, blue);
}

/// Rejects every candidate on primitive 1 of instance 2; accepts the others.
#[any_hit(ray = Plain)]
fn ah_rules(ctx: &mut AnyHit, #[payload] _color: &mut Vec3) {
    if ctx.primitive_index() == 1 && ctx.instance_index() == 2 {
        ctx.ignore_intersection();
    }
}

/// Params of the packet test: a pinhole camera at `eye` looking down -z over
/// `[-1, 1]²` at distance 1, `rays` rays per pixel, each direction moved by up
/// to `spread` in x and y (a hash of the pixel and the ray), and where each
/// ray's hit goes.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct PacketParams {
    /// `width × height × rays` records of [`HIT_WORDS`] words, pixel-major.
    pub hits: Buffer<u32>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rays per pixel.
    pub rays: u32,
    /// The camera's position.
    pub eye: Vec3,
    /// How far directions are moved at random.
    pub spread: f32,
    /// Every odd ray of a pixel starts this far along x from `eye`.
    pub shift: f32,
    /// Nonzero: some rays are degenerate (see [`probe_interval_ray`]).
    pub degenerate: u32,
    /// The scene.
    pub scene: Traversable,
}

/// What a ray of the packet test hit: everything a closest-hit program sees of
/// the triangle, bit for bit (`t` is `-1` for a miss).
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HitRecord {
    /// The hit distance.
    pub t: f32,
    /// Barycentric u.
    pub u: f32,
    /// Barycentric v.
    pub v: f32,
    /// The primitive index.
    pub primitive: u32,
    /// The instance index.
    pub instance: u32,
    /// The geometry index.
    pub geometry: u32,
    /// 1 for a front face, 0 for a back face.
    pub front: u32,
    /// The instance's custom index.
    pub custom: u32,
}

/// Words of a [`HitRecord`] in [`PacketParams::hits`].
pub const HIT_WORDS: u32 = 8;

/// The packet test's ray type: cull mask 0x01.
pub struct Probe;
impl RayType for Probe {
    type Payload = HitRecord;
    const CULL_MASK: u32 = 0x01;
}

/// A hash of `a` and `b` in `[0, 1)`.
pub fn hash01(a: u32, b: u32) -> f32 {
    let mut h = a.wrapping_mul(0x9e37_79b9) ^ b.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    (h >> 8) as f32 / 16_777_216.0
}

/// The ray `k` of pixel `index` of the packet test: `(origin, direction)`.
pub fn probe_ray(index: UVec2, k: u32, params: &PacketParams) -> (Vec3, Vec3) {
    let fx = (index.x as f32 + 0.5) / params.width as f32 * 2.0 - 1.0;
    let fy = 1.0 - (index.y as f32 + 0.5) / params.height as f32 * 2.0;
    let pixel = index.x + index.y * params.width;
    let jx = (hash01(pixel, 2 * k) - 0.5) * params.spread;
    let jy = (hash01(pixel, 2 * k + 1) - 0.5) * params.spread;
    let origin = if k % 2 == 1 { params.eye + Vec3::new(params.shift, 0.0, 0.0) } else { params.eye };
    (origin, Vec3::new(fx + jx, fy + jy, -1.0))
}

/// The ray `k` of pixel `pixel` of the packet test, from `origin` along
/// `direction` over `[0, 1e16]`; with `degenerate`, some are not: one in seven
/// has a NaN or infinite direction component, one in five of the others an
/// empty or NaN `t` interval.
pub fn probe_interval_ray(pixel: u32, k: u32, degenerate: u32, origin: Vec3, direction: Vec3) -> Ray {
    let ray = Ray::new(origin, direction);
    let n = pixel.wrapping_mul(31).wrapping_add(k);
    if degenerate == 0 {
        return ray;
    }
    match (n % 7, n % 3, n % 5, n % 2) {
        (0, 0, _, _) => Ray { direction: Vec3::new(f32::NAN, direction.y, direction.z), ..ray },
        (0, _, _, _) => Ray { direction: Vec3::new(direction.x, f32::INFINITY, direction.z), ..ray },
        (_, _, 0, 0) => ray.with_interval(3.0, 2.0),
        (_, _, 0, _) => ray.with_interval(f32::NAN, 1e16),
        _ => ray,
    }
}

/// Traces the rays of the packet test and writes their records.
#[raygen]
fn rg_probe(ctx: &mut Raygen, #[params] params: &PacketParams, #[payload] hit: &mut HitRecord) {
    let index: UVec3 = ctx.launch_index();
    let pixel = ctx.launch_linear_index();
    let mut k = 0;
    while k < params.rays {
        let (origin, direction) = probe_ray(index.truncate(), k, params);
        *hit = HitRecord { t: -1.0, ..Default::default() };
        let ray = probe_interval_ray(pixel, k, params.degenerate, origin, direction);
        ctx.trace::<Probe>(params.scene, ray, hit);
        let at = (pixel * params.rays + k) * HIT_WORDS;
        let words = [
            hit.t.to_bits(),
            hit.u.to_bits(),
            hit.v.to_bits(),
            hit.primitive,
            hit.instance,
            hit.geometry,
            hit.front,
            hit.custom,
        ];
        let mut w = 0;
        while w < HIT_WORDS {
            ctx.store(params.hits, at + w, words[w as usize]);
            w += 1;
        }
        k += 1;
    }
}

/// Leaves the miss record (`t = -1`).
#[miss(ray = Probe)]
fn ms_probe(_ctx: &mut Miss, #[payload] _hit: &mut HitRecord) {}

/// Records the hit.
#[closest_hit(ray = Probe)]
fn ch_probe(ctx: &mut ClosestHit, #[payload] hit: &mut HitRecord) {
    let b = ctx.barycentrics();
    *hit = HitRecord {
        t: ctx.ray_tmax(),
        u: b.x,
        v: b.y,
        primitive: ctx.primitive_index(),
        instance: ctx.instance_index(),
        geometry: ctx.geometry_index(),
        front: u32::from(ctx.is_front_face_hit()),
        custom: ctx.instance_custom_index(),
    };
}

/// How deep [`recurse`] goes on the way to `stop`: one frame of 256 bytes and
/// more per level, so a bound past what any stack holds recurses without end.
#[cfg(not(target_arch = "spirv"))]
pub fn recurse(level: u32, stop: u32) -> u32 {
    let mut frame = [level; 64];
    core::hint::black_box(&mut frame);
    if frame[7] >= stop {
        return frame[3];
    }
    recurse(frame[5] + 1, stop).wrapping_add(frame[9])
}

/// A raygen that recurses without end (on the CPU backend only: SPIR-V has no
/// recursion), for the stack-overflow tests.
#[cfg(not(target_arch = "spirv"))]
#[raygen]
fn rg_recursing(ctx: &mut Raygen) {
    let index: UVec3 = ctx.launch_index();
    core::hint::black_box(recurse(index.x, u32::MAX));
}

/// A closest-hit that recurses without end (CPU backend only, as [`rg_recursing`]).
#[cfg(not(target_arch = "spirv"))]
#[closest_hit(ray = Radiance)]
fn ch_recursing(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    let depth = recurse(ctx.primitive_index(), u32::MAX);
    *color = Vec3::splat(depth as f32);
}

/// An intersection program that recurses without end (CPU backend only, as
/// [`rg_recursing`]).
#[cfg(not(target_arch = "spirv"))]
#[intersection]
fn is_recursing(ctx: &mut Intersection) {
    let depth = recurse(ctx.primitive_index(), u32::MAX);
    ctx.report_intersection(depth as f32, 0);
}

/// An intersection program that panics in every box a ray enters (CPU backend
/// only: the message names the box).
#[cfg(not(target_arch = "spirv"))]
#[intersection]
fn is_panicking(ctx: &mut Intersection) {
    panic!("the ray entered box {}", ctx.primitive_index());
}

/// A ray type placed past the bits a trace reads: Vulkan takes the low 4 bits
/// of the SBT offset and stride and the low 16 of the miss index, so offset 17,
/// stride 18 and miss index `0x1_0001` select as offset 1, stride 2 and miss 1.
pub struct Wide;
impl RayType for Wide {
    type Payload = Vec3;
    const SBT_OFFSET: u32 = 17;
    const SBT_STRIDE: u32 = 18;
    const MISS_INDEX: u32 = 0x1_0001;
}

/// Traces one [`Wide`] ray along -z per pixel.
#[raygen]
fn rg_wide(ctx: &mut Raygen, #[params] params: &Params, #[payload] color: &mut Vec3) {
    let index: UVec3 = ctx.launch_index();
    let p = pixel_position(index.truncate(), params);
    *color = Vec3::ZERO;
    ctx.trace_from::<Wide>(params.scene, Vec3::new(p.x, p.y, CAMERA_Z), Vec3::new(0.0, 0.0, -1.0), color);
    let pixel = ctx.launch_linear_index();
    ctx.store(params.image, pixel, pack_unorm(*color));
}

/// The miss program of [`Wide`]: its record's colour.
#[miss(ray = Wide)]
fn ms_wide(_ctx: &mut Miss, #[record] data: &ColorData, #[payload] color: &mut Vec3) {
    *color = data.color;
}

/// The closest-hit program of [`Wide`]: its record's colour.
#[closest_hit(ray = Wide)]
fn ch_wide(_ctx: &mut ClosestHit, #[record] data: &ColorData, #[payload] color: &mut Vec3) {
    *color = data.color;
}
