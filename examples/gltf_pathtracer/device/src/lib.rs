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
pub mod materials;

use raykit_device::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit_device::{
    any_hit, closest_hit, direct_callable, miss, raygen, AnyHit, Buffer, ClosestHit, DirectCallable, LaunchParams,
    Miss, Ray, RayType, Raygen, SampleTexture, SbtRecordData, Texture2D, TextureTable, Traversable,
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
    /// Per pixel: the primary hit's shading normal (world space, after the normal map) and 0.
    pub normal: Buffer<Vec4>,
    /// Padding (launch params have none implicit).
    pub _pad: u32,
}

/// The shading normal from a normal-map texel `texel` (RGB in 0..1, glTF's tangent
/// space: x along the tangent, y along the bitangent `sign × n × t`, z along the
/// normal), scaled by `scale` in x and y, given the unit normal `n` and the tangent
/// `t` (world space; orthogonalised against `n` here). `n` when the tangent is
/// degenerate.
pub fn perturb_normal(n: Vec3, t: Vec3, sign: f32, texel: Vec3, scale: f32) -> Vec3 {
    let t = (t - n * n.dot(t)).normalize_or_zero();
    if t == Vec3::ZERO {
        return n;
    }
    let b = n.cross(t) * if sign < 0.0 { -1.0 } else { 1.0 };
    let m = texel * 2.0 - Vec3::ONE;
    let perturbed = (t * (m.x * scale) + b * (m.y * scale) + n * m.z).normalize_or_zero();
    if perturbed == Vec3::ZERO {
        n
    } else {
        perturbed
    }
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
    /// Tangents per vertex (object space xyz, w the bitangent sign); read only with a normal map.
    pub tangents: Buffer<Vec4>,
    /// Tangent-space normal map, linear (the null handle for none, or when the
    /// primitive has no tangents).
    pub normal_texture: Texture2D,
    /// The normal map's scale (multiplies its x and y).
    pub normal_scale: f32,
    /// The material's index in the scene.
    pub material: u32,
    /// The index in the light buffer of this geometry's first triangle when its
    /// material emits (triangle `k` is light `light_offset + k`), [`NO_LIGHT`] otherwise.
    pub light_offset: u32,
    /// The callable `ch_callables` calls for this geometry's material (an index
    /// into the SBT's callable region).
    pub callable: u32,
    /// Base-colour texture (the null handle for none).
    pub base_color: Texture2D,
    /// Base-colour factor (linear RGB).
    pub base_color_factor: Vec3,
    /// Metallic (blue) and roughness (green) texture, linear (the null handle for none).
    pub metallic_roughness: Texture2D,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Emissive texture, sRGB (the null handle for none).
    pub emissive_texture: Texture2D,
    /// Emissive factor (linear RGB).
    pub emissive: Vec3,
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
    /// Metallic (factor × texture).
    pub metallic: f32,
    /// Emitted radiance (factor × texture).
    pub emission: Vec3,
    /// Roughness (factor × texture).
    pub roughness: f32,
    /// The hit triangle's index in the light buffer, [`NO_LIGHT`] when it does not emit.
    pub light: u32,
}

/// [`GeometryRecord::light_offset`] and [`PrimaryHit::light`] of surfaces that emit nothing.
pub const NO_LIGHT: u32 = u32::MAX;

/// `Vec4`s per triangle of the light buffer ([`TraceParams::lights`]): vertex 0 (world
/// space) and the probability of picking the triangle; vertex 1 and the area; vertex 2
/// and 0; the emitted radiance (factor × strength, linear RGB) and 0; texture
/// coordinates of vertices 0 and 1; of vertex 2 and 0, 0.
pub const LIGHT_STRIDE: u32 = 6;

/// A point sampled on an emissive triangle.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LightSample {
    /// The point (world space).
    pub position: Vec3,
    /// The triangle's unit geometric normal.
    pub normal: Vec3,
    /// Texture coordinates at the point.
    pub uv: Vec2,
    /// The triangle's emitted radiance factor (linear RGB, without the texture).
    pub radiance: Vec3,
    /// The triangle's emissive texture.
    pub texture: Texture2D,
    /// The pdf per unit area of the point: the triangle's probability over its area.
    pub pdf_area: f32,
}

/// Picks a light triangle with probability proportional to its power (`u0` through
/// the CDF `cdf` of `count` entries), then a point uniformly on it (`u1`, `u2`).
/// `light(k)` reads `Vec4` `k` of the light buffer, `texture(i)` light `i`'s texture.
pub fn sample_light(
    count: u32,
    cdf: impl Fn(u32) -> f32,
    light: impl Fn(u32) -> Vec4,
    texture: impl Fn(u32) -> Texture2D,
    u0: f32,
    u1: f32,
    u2: f32,
) -> LightSample {
    // The first entry whose CDF exceeds u0.
    let (mut lo, mut hi) = (0u32, count - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if cdf(mid) > u0 {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let base = lo * LIGHT_STRIDE;
    let (a, b, c) = (light(base), light(base + 1), light(base + 2));
    let (radiance, uv01, uv2) = (light(base + 3), light(base + 4), light(base + 5));
    let r = raykit_device::math::sqrt(u1);
    let (b1, b2) = (r * (1.0 - u2), r * u2);
    let position = a.truncate() * (1.0 - b1 - b2) + b.truncate() * b1 + c.truncate() * b2;
    let normal = (b.truncate() - a.truncate()).cross(c.truncate() - a.truncate()).normalize_or_zero();
    let uv =
        Vec2::new(uv01.x, uv01.y) * (1.0 - b1 - b2) + Vec2::new(uv01.z, uv01.w) * b1 + Vec2::new(uv2.x, uv2.y) * b2;
    let pdf_area = if b.w > 0.0 { a.w / b.w } else { 0.0 };
    LightSample { position, normal, uv, radiance: radiance.truncate(), texture: texture(lo), pdf_area }
}

/// The pdf per steradian with which [`sample_light`] picks a point of light triangle
/// `index` at distance `distance` along unit direction `dir` (0 for a triangle seen
/// edge-on or of no area).
pub fn light_pdf(light: impl Fn(u32) -> Vec4, index: u32, dir: Vec3, distance: f32) -> f32 {
    let base = index * LIGHT_STRIDE;
    let (a, b, c) = (light(base), light(base + 1), light(base + 2));
    let normal = (b.truncate() - a.truncate()).cross(c.truncate() - a.truncate()).normalize_or_zero();
    let cos = normal.dot(dir).abs();
    if b.w > 0.0 && cos > 0.0 {
        a.w / b.w * distance * distance / cos
    } else {
        0.0
    }
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
    ctx.store(p.normal, pixel, hit.normal.extend(0.0));
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
    if g.normal_texture != Texture2D::NULL {
        let tangents = g.tangents;
        let t = ctx.load(tangents, ctx.load(indices, base)) * (1.0 - b.x - b.y)
            + ctx.load(tangents, ctx.load(indices, base + 1)) * b.x
            + ctx.load(tangents, ctx.load(indices, base + 2)) * b.y;
        let m = ctx.object_to_world();
        let t_world = m.x_axis * t.x + m.y_axis * t.y + m.z_axis * t.z;
        let texel = textures.sample_lod(g.normal_texture, uv, 0.0).truncate();
        hit.normal = perturb_normal(hit.normal, t_world, t.w, texel, g.normal_scale);
    }
    hit.uv = uv;
    hit.t = ctx.hit_t();
    hit.material = g.material;
    let sample = |t: Texture2D| if t == Texture2D::NULL { Vec4::ONE } else { textures.sample_lod(t, uv, 0.0) };
    hit.color = sample(g.base_color).truncate() * g.base_color_factor;
    let mr = sample(g.metallic_roughness);
    hit.metallic = mr.z * g.metallic;
    hit.roughness = mr.y * g.roughness;
    hit.emission = sample(g.emissive_texture).truncate() * g.emissive;
    hit.light = if g.light_offset == NO_LIGHT { NO_LIGHT } else { g.light_offset + primitive };
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

/// Shadow rays: the first hit ends them (any-hit programs of masked materials
/// still run) and closest-hit is skipped, so the payload's `t` stays as the
/// caller set it unless the miss program runs (`t = -1`: the light is visible).
pub struct Shadow;
impl RayType for Shadow {
    type Payload = PrimaryHit;
    const FLAGS: raykit_device::RayFlags =
        raykit_device::RayFlags::TERMINATE_ON_FIRST_HIT.union(raykit_device::RayFlags::SKIP_CLOSEST_HIT_SHADER);
}

/// Launch params of the path tracer (the `rg_path` raygen, [`RG_PATH`]).
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct TraceParams {
    /// Per pixel: the sum of the radiance samples so far (xyz) and of the rays traced (w).
    pub accum: Buffer<Vec4>,
    /// The environment map's CDFs (`raykit_scene::EnvironmentMap::cdf`).
    pub env_cdf: Buffer<f32>,
    /// Image size.
    pub size: UVec2,
    /// The environment map (equirectangular, linear radiance).
    pub env: Texture2D,
    /// The environment map's width.
    pub env_width: u32,
    /// The environment map's height.
    pub env_height: u32,
    /// Index of this launch in the progressive sequence (seeds the random numbers).
    pub subframe: u32,
    /// Paths per pixel traced by this launch.
    pub samples: u32,
    /// Safety cap on bounces (Russian roulette ends paths).
    pub max_depth: u32,
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
    /// The emissive triangles, [`LIGHT_STRIDE`] `Vec4`s each (see there).
    pub lights: Buffer<Vec4>,
    /// Per light triangle: its emissive texture (the null handle for none).
    pub light_textures: Buffer<u32>,
    /// The lights' CDF in power: entry `i` is the probability of picking a light `≤ i`.
    pub light_cdf: Buffer<f32>,
    /// The number of light triangles sampled; 0 turns light sampling off (emissive
    /// surfaces are then found by BSDF sampling alone).
    pub light_count: u32,
    /// Whether launches also write the denoiser's guides (`albedo`, `normal`); 0: they
    /// are not touched.
    pub guides: u32,
    /// With `guides`: per pixel, the sum over its paths of the first hit's albedo
    /// (its base colour; an emitter's colour normalised to a largest channel of 1;
    /// 0 for a miss) in xyz and the paths in w. Launch `subframe == 0` overwrites it.
    pub albedo: Buffer<Vec4>,
    /// With `guides`: per pixel, the sum over its paths of the first hit's shading
    /// normal, facing the camera (0 for a miss), in xyz and the paths in w.
    pub normal: Buffer<Vec4>,
    /// Launch params have no implicit padding.
    pub _pad: u32,
}

/// Offset of secondary rays from the surface.
pub const RAY_OFFSET: f32 = 1e-3;

/// The path tracer: per path, next-event estimation of the environment map and of
/// the emissive triangles (area sampling, proportional to power), and BSDF sampling,
/// weighted by the power heuristic; Russian roulette. Emissive triangles emit from
/// both sides.
#[raygen]
fn rg_path(
    ctx: &mut Raygen,
    #[params] p: &TraceParams,
    #[textures] textures: &TextureTable,
    #[payload] hit: &mut PrimaryHit,
    #[payload] shadow: &mut PrimaryHit,
) {
    use raykit_device::environment::{environment_pdf, equirect_uv, sample_environment};
    use raykit_device::sampling::{power_heuristic, Onb, Pcg};
    let index = ctx.launch_index().truncate();
    let pixel = ctx.launch_linear_index();
    let (cdf, env) = (p.env_cdf, p.env);
    let (ew, eh) = (p.env_width, p.env_height);
    let (lights, light_textures, light_cdf) = (p.lights, p.light_textures, p.light_cdf);
    let mut sum = Vec3::ZERO;
    let mut rays = 0u32;
    let (mut albedo_sum, mut normal_sum) = (Vec3::ZERO, Vec3::ZERO);
    let mut sample = 0;
    while sample < p.samples {
        let mut rng = Pcg::new(pixel, p.subframe.wrapping_mul(4096).wrapping_add(sample));
        let jitter = rng.next_vec2();
        let d = 2.0 * (index.as_vec2() + jitter) / p.size.as_vec2() - 1.0;
        let mut origin = p.cam_eye;
        let mut dir = (d.x * p.cam_u - d.y * p.cam_v + p.cam_w).normalize();
        let mut throughput = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        let mut bsdf_pdf = 0.0f32;
        let mut depth = 0;
        while depth < p.max_depth {
            *hit = PrimaryHit { t: -1.0, ..Default::default() };
            ctx.trace::<Primary>(p.scene, Ray::new(origin, dir).with_interval(1e-4, 1e16), hit);
            rays += 1;
            if hit.t < 0.0 {
                let light = textures.sample_lod(env, equirect_uv(dir), 0.0).truncate();
                let weight = if depth == 0 {
                    1.0
                } else {
                    power_heuristic(bsdf_pdf, environment_pdf(ew, eh, |k| ctx.load(cdf, k), dir))
                };
                radiance += throughput * light * weight;
                break;
            }
            let emission_weight = if depth == 0 || p.light_count == 0 || hit.light == NO_LIGHT {
                1.0
            } else {
                power_heuristic(bsdf_pdf, light_pdf(|k| ctx.load(lights, k), hit.light, dir, hit.t))
            };
            radiance += throughput * hit.emission * emission_weight;
            let n = if hit.normal.dot(dir) > 0.0 { -hit.normal } else { hit.normal };
            if depth == 0 {
                let emitter = hit.emission.max_element();
                albedo_sum += if emitter > 0.0 { hit.emission / emitter } else { hit.color };
                normal_sum += n;
            }
            let position = origin + hit.t * dir + n * RAY_OFFSET;
            let frame = Onb::new(n);
            let v = frame.to_local(-dir);
            let material = bsdf::SurfaceMaterial {
                base_color: hit.color,
                metallic: hit.metallic.clamp(0.0, 1.0),
                roughness: hit.roughness.clamp(0.0, 1.0),
            };
            // Next-event estimation: a direction of the environment map.
            let (u1, u2) = (rng.next_f32(), rng.next_f32());
            let s = sample_environment(ew, eh, |k| ctx.load(cdf, k), u1, u2);
            let l = frame.to_local(s.direction);
            let f = bsdf::eval(&material, v, l);
            if s.pdf > 0.0 && f != Vec3::ZERO {
                shadow.t = 1.0;
                ctx.trace::<Shadow>(p.scene, Ray::new(position, s.direction).with_interval(0.0, 1e16), shadow);
                rays += 1;
                if shadow.t < 0.0 {
                    let light = textures.sample_lod(env, s.uv, 0.0).truncate();
                    let weight = power_heuristic(s.pdf, bsdf::pdf(&material, v, l));
                    radiance += throughput * f * light * (weight / s.pdf);
                }
            }
            // Next-event estimation: a point of an emissive triangle.
            if p.light_count > 0 {
                let (u0, u1, u2) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
                let s = sample_light(
                    p.light_count,
                    |k| ctx.load(light_cdf, k),
                    |k| ctx.load(lights, k),
                    |k| Texture2D::from_raw(ctx.load(light_textures, k)),
                    u0,
                    u1,
                    u2,
                );
                let to_light = s.position - position;
                let distance = to_light.length();
                let wi = to_light / distance;
                let cos_light = s.normal.dot(wi).abs();
                let l = frame.to_local(wi);
                let f = bsdf::eval(&material, v, l);
                if s.pdf_area > 0.0 && cos_light > 0.0 && distance > 0.0 && f != Vec3::ZERO {
                    let pdf = s.pdf_area * distance * distance / cos_light;
                    shadow.t = 1.0;
                    let ray = Ray::new(position, wi).with_interval(0.0, distance * (1.0 - 1e-3));
                    ctx.trace::<Shadow>(p.scene, ray, shadow);
                    rays += 1;
                    if shadow.t < 0.0 {
                        let texture = if s.texture == Texture2D::NULL {
                            Vec3::ONE
                        } else {
                            textures.sample_lod(s.texture, s.uv, 0.0).truncate()
                        };
                        let weight = power_heuristic(pdf, bsdf::pdf(&material, v, l));
                        radiance += throughput * f * s.radiance * texture * (weight / pdf);
                    }
                }
            }
            // The next direction, from the BSDF.
            let (u0, u1, u2) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
            let next = bsdf::sample(&material, v, u0, u1, u2);
            if next.pdf <= 0.0 || next.weight == Vec3::ZERO {
                break;
            }
            throughput *= next.weight;
            bsdf_pdf = next.pdf;
            origin = position;
            dir = frame.to_world(next.l).normalize();
            depth += 1;
            if depth >= 3 {
                let q = throughput.max_element().min(0.95);
                if rng.next_f32() >= q {
                    break;
                }
                throughput /= q;
            }
        }
        sum += radiance;
        sample += 1;
    }
    let previous = if p.subframe == 0 { Vec4::ZERO } else { ctx.load(p.accum, pixel) };
    ctx.store(p.accum, pixel, previous + sum.extend(rays as f32));
    if p.guides != 0 {
        let paths = p.samples as f32;
        let (albedo, normal) = if p.subframe == 0 {
            (Vec4::ZERO, Vec4::ZERO)
        } else {
            (ctx.load(p.albedo, pixel), ctx.load(p.normal, pixel))
        };
        ctx.store(p.albedo, pixel, albedo + albedo_sum.extend(paths));
        ctx.store(p.normal, pixel, normal + normal_sum.extend(paths));
    }
}

/// The primary hit of `g` at this closest-hit: texture coordinates, distance,
/// material (the colour is the caller's).
fn primary_surface(ctx: &ClosestHit, g: &GeometryRecord, hit: &mut PrimaryHit) {
    let (indices, uvs) = (g.indices, g.uvs);
    hit.uv = interpolate2(
        triangle_uvs(|i| ctx.load(indices, i), |v| ctx.load(uvs, v), ctx.primitive_index()),
        ctx.barycentrics(),
    );
    hit.t = ctx.hit_t();
    hit.material = g.material;
}

/// Callables mode: one closest-hit calls the material's callable from its record.
#[closest_hit(ray = Primary)]
fn ch_callables(
    ctx: &mut ClosestHit,
    #[record] g: &GeometryRecord,
    #[payload] hit: &mut PrimaryHit,
    #[call_data] call: &mut materials::ShadeCall,
) {
    primary_surface(ctx, g, hit);
    *call = materials::ShadeCall { uv: hit.uv, ..Default::default() };
    ctx.call(g.callable, call);
    hit.color = call.color;
}

macro_rules! material_programs {
    ($($material:ident => $callable:ident $CALLABLE:ident, $inlined:ident $INLINED:ident;)*) => {
        $(
            #[direct_callable]
            fn $callable(_ctx: &mut DirectCallable, #[callable_data] call: &mut materials::ShadeCall) {
                call.color = materials::shade::<materials::$material>(call.uv);
            }

            #[closest_hit(ray = Primary)]
            fn $inlined(ctx: &mut ClosestHit, #[record] g: &GeometryRecord, #[payload] hit: &mut PrimaryHit) {
                primary_surface(ctx, g, hit);
                hit.color = materials::shade::<materials::$material>(hit.uv);
            }
        )*

        /// Callables mode: the material callables, in material order.
        pub const MATERIAL_CALLABLES: [raykit_device::EntryPoint; materials::MATERIAL_COUNT as usize] = [$($CALLABLE),*];
        /// Inlined mode: the closest-hit of each material, in material order.
        pub const MATERIAL_CLOSEST_HITS: [raykit_device::EntryPoint; materials::MATERIAL_COUNT as usize] = [$($INLINED),*];
    };
}

material_programs! {
    Checks => mat_checks MAT_CHECKS, ch_mat_checks CH_MAT_CHECKS;
    Stripes => mat_stripes MAT_STRIPES, ch_mat_stripes CH_MAT_STRIPES;
    Gradient => mat_gradient MAT_GRADIENT, ch_mat_gradient CH_MAT_GRADIENT;
    Rings => mat_rings MAT_RINGS, ch_mat_rings CH_MAT_RINGS;
    Dots => mat_dots MAT_DOTS, ch_mat_dots CH_MAT_DOTS;
    Bands => mat_bands MAT_BANDS, ch_mat_bands CH_MAT_BANDS;
    Waves => mat_waves MAT_WAVES, ch_mat_waves CH_MAT_WAVES;
    Grid => mat_grid MAT_GRID, ch_mat_grid CH_MAT_GRID;
}
