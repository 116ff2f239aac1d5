//! Device programs of the texture tests. An orthographic camera looks down −z
//! at a quad in the plane z = 0 whose texture coordinates are its x and y; the
//! pixel `(x, y)` of an `n × n` image has coordinates [`pixel_uv`], from
//! [`UV_MIN`] to [`UV_MAX`] (past `[0, 1]`, so address modes matter). Which stage
//! samples is chosen by [`Params::stage`]: every stage writes the same texel, so
//! one CPU reference checks them all.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit_device::{
    any_hit, closest_hit, direct_callable, miss, raygen, AnyHit, Buffer, ClosestHit, DirectCallable, LaunchParams,
    Miss, Ray, RayType, Raygen, SampleTexture, SbtRecordData, Texture2D, TextureTable, Traversable,
};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// One sample per pixel, row-major.
    pub out: Buffer<Vec4>,
    /// Image size.
    pub size: UVec2,
    /// The texture raygen, any-hit, miss and the callable sample (closest-hit
    /// samples its record's).
    pub texture: Texture2D,
    /// Which stage samples: one of the `STAGE_*` constants.
    pub stage: u32,
    /// The level of detail.
    pub lod: f32,
    /// The quad.
    pub scene: Traversable,
}

/// Raygen samples.
pub const STAGE_RAYGEN: u32 = 0;
/// Closest-hit samples (its SBT record's texture).
pub const STAGE_CLOSEST_HIT: u32 = 1;
/// Any-hit samples.
pub const STAGE_ANY_HIT: u32 = 2;
/// Miss samples.
pub const STAGE_MISS: u32 = 3;
/// A direct callable, called by closest-hit, samples.
pub const STAGE_CALLABLE: u32 = 4;
/// Every stage.
pub const STAGES: [(u32, &str); 5] = [
    (STAGE_RAYGEN, "raygen"),
    (STAGE_CLOSEST_HIT, "closest-hit"),
    (STAGE_ANY_HIT, "any-hit"),
    (STAGE_MISS, "miss"),
    (STAGE_CALLABLE, "callable"),
];

/// The texture coordinate of the first pixel's edge.
pub const UV_MIN: f32 = -0.75;
/// The texture coordinate of the last pixel's edge.
pub const UV_MAX: f32 = 1.75;

/// The quad (two triangles), covering `[UV_MIN, UV_MAX]²` at z = 0.
pub const QUAD: [Vec3; 6] = [
    Vec3::new(UV_MIN, UV_MIN, 0.0),
    Vec3::new(UV_MAX, UV_MIN, 0.0),
    Vec3::new(UV_MAX, UV_MAX, 0.0),
    Vec3::new(UV_MIN, UV_MIN, 0.0),
    Vec3::new(UV_MAX, UV_MAX, 0.0),
    Vec3::new(UV_MIN, UV_MAX, 0.0),
];

/// The texture coordinates of the centre of pixel `index`.
pub fn pixel_uv(index: UVec2, size: UVec2) -> Vec2 {
    let t = (index.as_vec2() + 0.5) / size.as_vec2();
    Vec2::splat(UV_MIN) + (UV_MAX - UV_MIN) * t
}

/// The texture coordinates of the hit at barycentrics `b` of quad triangle `primitive`.
pub fn quad_uv(primitive: u32, b: Vec2) -> Vec2 {
    let (v0, v1, v2) = if primitive == 0 { (QUAD[0], QUAD[1], QUAD[2]) } else { (QUAD[3], QUAD[4], QUAD[5]) };
    let p = v0 * (1.0 - b.x - b.y) + v1 * b.x + v2 * b.y;
    Vec2::new(p.x, p.y)
}

/// The closest-hit group's record: the texture it samples.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct HitRecord {
    /// The texture.
    pub texture: Texture2D,
}

/// What closest-hit hands the callable: where to sample; the sample comes back.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default)]
pub struct SampleCall {
    /// The sample.
    pub result: Vec4,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Level of detail.
    pub lod: f32,
    /// The texture.
    pub texture: Texture2D,
}

/// Rays whose closest-hit samples (hit record 0).
pub struct ViaClosestHit;
impl RayType for ViaClosestHit {
    type Payload = Vec4;
    const SBT_OFFSET: u32 = 0;
    const SBT_STRIDE: u32 = 1;
    const MISS_INDEX: u32 = 0;
}

/// Rays whose any-hit samples (hit record 1, no closest-hit).
pub struct ViaAnyHit;
impl RayType for ViaAnyHit {
    type Payload = Vec4;
    const SBT_OFFSET: u32 = 1;
    const SBT_STRIDE: u32 = 1;
    const MISS_INDEX: u32 = 0;
}

/// Rays whose closest-hit calls the sampling callable (hit record 2).
pub struct ViaCallable;
impl RayType for ViaCallable {
    type Payload = Vec4;
    const SBT_OFFSET: u32 = 2;
    const SBT_STRIDE: u32 = 1;
    const MISS_INDEX: u32 = 0;
}

/// Rays that miss the quad, whose miss program (miss record 1) samples.
pub struct ViaMiss;
impl RayType for ViaMiss {
    type Payload = Vec4;
    const SBT_OFFSET: u32 = 0;
    const SBT_STRIDE: u32 = 1;
    const MISS_INDEX: u32 = 1;
}

/// The value a ray that should have hit gets from the plain miss program.
pub const MISSED: Vec4 = Vec4::new(-1.0, -1.0, -1.0, -1.0);

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[textures] textures: &TextureTable, #[payload] sample: &mut Vec4) {
    let index = ctx.launch_index().truncate();
    let uv = pixel_uv(index, p.size);
    let above = Ray::new(Vec3::new(uv.x, uv.y, 1.0), Vec3::NEG_Z).with_interval(0.0, 10.0);
    *sample = Vec4::ZERO;
    if p.stage == STAGE_RAYGEN {
        *sample = textures.sample_lod(p.texture, uv, p.lod);
    } else if p.stage == STAGE_CLOSEST_HIT {
        ctx.trace::<ViaClosestHit>(p.scene, above, sample);
    } else if p.stage == STAGE_ANY_HIT {
        ctx.trace::<ViaAnyHit>(p.scene, above, sample);
    } else if p.stage == STAGE_CALLABLE {
        ctx.trace::<ViaCallable>(p.scene, above, sample);
    } else {
        let below = Ray::new(Vec3::new(uv.x, uv.y, -1.0), Vec3::NEG_Z).with_interval(0.0, 10.0);
        ctx.trace::<ViaMiss>(p.scene, below, sample);
    }
    let pixel = ctx.launch_linear_index();
    ctx.store(p.out, pixel, *sample);
}

#[miss(ray = ViaClosestHit)]
fn ms(_ctx: &mut Miss, #[payload] sample: &mut Vec4) {
    *sample = MISSED;
}

#[miss(ray = ViaMiss)]
fn ms_sample(ctx: &mut Miss, #[params] p: &Params, #[textures] textures: &TextureTable, #[payload] sample: &mut Vec4) {
    let origin = ctx.world_ray_origin();
    *sample = textures.sample_lod(p.texture, Vec2::new(origin.x, origin.y), p.lod);
}

#[closest_hit(ray = ViaClosestHit)]
fn ch(
    ctx: &mut ClosestHit,
    #[params] p: &Params,
    #[record] record: &HitRecord,
    #[textures] textures: &TextureTable,
    #[payload] sample: &mut Vec4,
) {
    let uv = quad_uv(ctx.primitive_index(), ctx.barycentrics());
    *sample = textures.sample_lod(record.texture, uv, p.lod);
}

#[any_hit(ray = ViaAnyHit)]
fn ah(
    ctx: &mut AnyHit,
    #[params] p: &Params,
    #[textures] textures: &TextureTable,
    #[attributes] barycentrics: &Vec2,
    #[payload] sample: &mut Vec4,
) {
    let uv = quad_uv(ctx.primitive_index(), *barycentrics);
    *sample = textures.sample_lod(p.texture, uv, p.lod);
}

#[closest_hit(ray = ViaCallable)]
fn ch_call(
    ctx: &mut ClosestHit,
    #[params] p: &Params,
    #[payload] sample: &mut Vec4,
    #[call_data] call: &mut SampleCall,
) {
    let uv = quad_uv(ctx.primitive_index(), ctx.barycentrics());
    *call = SampleCall { result: Vec4::ZERO, uv, lod: p.lod, texture: p.texture };
    ctx.call(0, call);
    *sample = call.result;
}

#[direct_callable]
fn sample_texture(
    _ctx: &mut DirectCallable,
    #[textures] textures: &TextureTable,
    #[callable_data] call: &mut SampleCall,
) {
    call.result = textures.sample_lod(call.texture, call.uv, call.lod);
}

/// Launch params of the `rg_environment` raygen: sample one direction per launch index from an
/// environment map's tables.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct EnvironmentParams {
    /// Per launch index: the direction (xyz) and its pdf (w).
    pub out: Buffer<Vec4>,
    /// The map's CDFs (`raykit_scene::EnvironmentMap::cdf`).
    pub cdf: Buffer<f32>,
    /// The map's width.
    pub width: u32,
    /// The map's height.
    pub height: u32,
}

/// The two uniform numbers launch index `i` samples the environment with.
pub fn environment_numbers(i: u32) -> (f32, f32) {
    let mut rng = raykit_device::sampling::Pcg::new(i, 7);
    let u1 = rng.next_f32();
    (u1, rng.next_f32())
}

#[raygen]
fn rg_environment(ctx: &mut Raygen, #[params] p: &EnvironmentParams) {
    let i = ctx.launch_linear_index();
    let (u1, u2) = environment_numbers(i);
    let table = p.cdf;
    let s = raykit_device::environment::sample_environment(p.width, p.height, |k| ctx.load(table, k), u1, u2);
    ctx.store(p.out, i, s.direction.extend(s.pdf));
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn the_quad_maps_positions_to_coordinates() {
        // Barycentrics (1, 0) of triangle 0 is its second vertex.
        assert_eq!(quad_uv(0, Vec2::new(1.0, 0.0)), Vec2::new(UV_MAX, UV_MIN));
        assert_eq!(quad_uv(1, Vec2::new(0.0, 1.0)), Vec2::new(UV_MIN, UV_MAX));
        assert_eq!(core::mem::size_of::<Params>(), 32);
    }
}
