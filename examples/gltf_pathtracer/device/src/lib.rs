//! The glTF renderer's device programs and the types the host shares with them.
//!
//! Each glTF primitive is one geometry of its mesh's GAS, and each (instance,
//! primitive) pair has a hit record ([`GeometryRecord`]) with its vertex
//! buffers, its material's index and base-colour texture. Closest-hit
//! interpolates the texture coordinates and the shading normal; any-hit, in the
//! hit groups of alpha-masked materials, ignores hits where the base colour's
//! alpha is below the cutoff (through a coverage bitmask of the texture). Raygen writes, per pixel, the primary hit's
//! material index and texture coordinates ([`PrimaryHit`]).
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod bsdf;

use raykit_device::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit_device::{
    any_hit, closest_hit, miss, raygen, AnyHit, Buffer, ClosestHit, LaunchParams, Miss, Ray, RayType, Raygen,
    SampleTexture, SbtRecordData, Texture2D, TextureTable, Traversable,
};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// Per pixel: material index (as f32, −1 for a miss), u, v, hit distance.
    pub out: Buffer<Vec4>,
    /// Image size.
    pub size: UVec2,
    /// Per pixel: the primary hit's base colour (linear RGB, factor × texture) and 1.
    pub color: Buffer<Vec4>,
    /// Camera position.
    pub cam_eye: Vec3,
    /// Camera right, scaled to half the image-plane width.
    pub cam_u: Vec3,
    /// Camera up, scaled to half the image-plane height.
    pub cam_v: Vec3,
    /// Camera forward, to the image-plane centre.
    pub cam_w: Vec3,
    /// The scene.
    pub scene: Traversable,
}

/// The hit record of one primitive of one instance.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Zeroable, SbtRecordData)]
pub struct GeometryRecord {
    /// Three vertex indices per triangle.
    pub indices: Buffer<u32>,
    /// Texture coordinates per vertex.
    pub uvs: Buffer<Vec2>,
    /// Normals per vertex (object space).
    pub normals: Buffer<Vec3>,
    /// The material's index in the scene.
    pub material: u32,
    /// Base-colour texture (the null handle for none).
    pub base_color: Texture2D,
    /// Base-colour factor (linear RGB).
    pub base_color_factor: Vec3,
    /// A masked material's coverage: one bit per texel of its base-colour texture
    /// (alpha × the factor's alpha ≥ the cutoff), row-major, 32 texels per word.
    pub coverage: Buffer<u32>,
    /// The coverage's width in texels.
    pub coverage_width: u32,
    /// The coverage's height in texels.
    pub coverage_height: u32,
}

/// What closest-hit reports to raygen.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct PrimaryHit {
    /// Texture coordinates.
    pub uv: Vec2,
    /// Hit distance; negative for a miss.
    pub t: f32,
    /// The material's index.
    pub material: u32,
    /// Shading normal (world space, unnormalised interpolation normalised).
    pub normal: Vec3,
    /// Base colour (linear RGB, factor × texture).
    pub color: Vec3,
}

/// Primary rays.
pub struct Primary;
impl RayType for Primary {
    type Payload = PrimaryHit;
}

/// The texture coordinates at barycentrics `b` of a triangle with vertex coordinates `t`.
pub fn interpolate2(t: [Vec2; 3], b: Vec2) -> Vec2 {
    t[0] * (1.0 - b.x - b.y) + t[1] * b.x + t[2] * b.y
}

/// The texel index (nearest, repeat) of texture coordinates `uv` in a `width × height` texture.
pub fn texel_index(uv: Vec2, width: u32, height: u32) -> u32 {
    let wrap = |c: f32, n: u32| {
        let x = c * n as f32;
        let t = x as i32;
        let t = if (t as f32) > x { t - 1 } else { t };
        let m = t % n as i32;
        (if m < 0 { m + n as i32 } else { m }) as u32
    };
    wrap(uv.y, height) * width + wrap(uv.x, width)
}

/// The vertex attributes of triangle `primitive` of `record`'s geometry, read with `load`.
fn triangle_uvs(load_index: impl Fn(u32) -> u32, load_uv: impl Fn(u32) -> Vec2, primitive: u32) -> [Vec2; 3] {
    let base = primitive * 3;
    [load_uv(load_index(base)), load_uv(load_index(base + 1)), load_uv(load_index(base + 2))]
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] hit: &mut PrimaryHit) {
    let index = ctx.launch_index().truncate();
    let d = 2.0 * (index.as_vec2() + 0.5) / p.size.as_vec2() - 1.0;
    let direction = (d.x * p.cam_u - d.y * p.cam_v + p.cam_w).normalize();
    *hit = PrimaryHit { t: -1.0, ..Default::default() };
    ctx.trace::<Primary>(p.scene, Ray::new(p.cam_eye, direction).with_interval(1e-4, 1e16), hit);
    let material = if hit.t < 0.0 { -1.0 } else { hit.material as f32 };
    let pixel = ctx.launch_linear_index();
    ctx.store(p.out, pixel, Vec4::new(material, hit.uv.x, hit.uv.y, hit.t));
    ctx.store(p.color, pixel, hit.color.extend(1.0));
}

#[miss(ray = Primary)]
fn ms(_ctx: &mut Miss, #[payload] hit: &mut PrimaryHit) {
    hit.t = -1.0;
}

#[closest_hit(ray = Primary)]
fn ch(
    ctx: &mut ClosestHit,
    #[record] g: &GeometryRecord,
    #[textures] textures: &TextureTable,
    #[payload] hit: &mut PrimaryHit,
) {
    let primitive = ctx.primitive_index();
    let (indices, uvs, normals) = (g.indices, g.uvs, g.normals);
    let uv = interpolate2(triangle_uvs(|i| ctx.load(indices, i), |v| ctx.load(uvs, v), primitive), ctx.barycentrics());
    let base = primitive * 3;
    let b = ctx.barycentrics();
    let n = ctx.load(normals, ctx.load(indices, base)) * (1.0 - b.x - b.y)
        + ctx.load(normals, ctx.load(indices, base + 1)) * b.x
        + ctx.load(normals, ctx.load(indices, base + 2)) * b.y;
    hit.normal = raykit_device::sampling::transform_normal_to_world(&ctx.world_to_object(), n);
    hit.uv = uv;
    hit.t = ctx.hit_t();
    hit.material = g.material;
    let texel = if g.base_color == Texture2D::NULL { Vec4::ONE } else { textures.sample_lod(g.base_color, uv, 0.0) };
    hit.color = texel.truncate() * g.base_color_factor;
}

#[any_hit(ray = Primary)]
fn ah_mask(
    ctx: &mut AnyHit,
    #[record] g: &GeometryRecord,
    #[attributes] barycentrics: &Vec2,
    #[payload] _hit: &mut PrimaryHit,
) {
    let (indices, uvs) = (g.indices, g.uvs);
    let uv = interpolate2(
        triangle_uvs(|i| ctx.load(indices, i), |v| ctx.load(uvs, v), ctx.primitive_index()),
        *barycentrics,
    );
    // A lookup in the coverage bits rather than a filtered texture sample: exact (nearest,
    // repeat), and cheaper in the program that runs most often.
    let texel = texel_index(uv, g.coverage_width, g.coverage_height);
    let word = ctx.load(g.coverage, texel / 32);
    if (word >> (texel % 32)) & 1 == 0 {
        ctx.ignore_intersection();
    }
}
