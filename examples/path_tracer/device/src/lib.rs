//! optixPathTracer in Rust: the Cornell box, Lambertian surfaces, next-event
//! estimation with a shadow ray type, Russian roulette, progressive
//! accumulation over launches with a deterministic per-pixel random sequence.
//!
//! As in optixPathTracer, the path loop runs in raygen: the closest-hit program
//! only reports the hit (normal, distance, material) in the payload, and
//! raygen traces the next bounce and the shadow rays. That keeps the trace depth
//! at 1 and the stack small.
//!
//! This crate is compiled twice: to SPIR-V by `cargo xtask build-shaders`, and
//! for the host, where [`Params`], the SBT record types, the ray types, the
//! entry-point constants, the [`math`] and the [`scene`] are shared with the
//! host program and the CPU reference of the tests.
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod math;
pub mod scene;

use raykit_device::glam::{UVec2, Vec3, Vec4};
use raykit_device::{
    closest_hit, miss, raygen, Buffer, ClosestHit, LaunchParams, Miss, Ray, RayFlags, RayType, Raygen, Traversable,
};

use math::{CameraFrame, HitInfo, Light, PathState, RAY_EPSILON};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// Per pixel: the sum of the radiance samples so far (xyz) and the number of
    /// rays traced for the pixel (w). Launch `subframe == 0` overwrites it.
    pub accum: Buffer<Vec4>,
    /// Unit geometric normal of each triangle of the scene.
    pub normals: Buffer<Vec3>,
    /// Image width and height.
    pub size: UVec2,
    /// Index of this launch in the progressive sequence (seeds the random numbers).
    pub subframe: u32,
    /// Paths per pixel traced by this launch.
    pub samples: u32,
    /// Longest path (bounces).
    pub max_depth: u32,
    /// First image row of this launch: a launch of `size.x × rows` renders rows
    /// `row_offset..row_offset + rows` (a band of a launch split across devices,
    /// see `raykit::device_group`); 0 for the whole image. Vulkan's launch index
    /// starts at 0 in every launch, so raygen adds this to it. (Also keeps
    /// `handle` 8-byte aligned on every target.)
    pub row_offset: u32,
    /// Camera position.
    pub cam_eye: Vec3,
    /// Camera right, scaled to half the image-plane width.
    pub cam_u: Vec3,
    /// Camera up, scaled to half the image-plane height.
    pub cam_v: Vec3,
    /// Camera forward, to the image-plane centre.
    pub cam_w: Vec3,
    /// The scene.
    pub handle: Traversable,
}

impl Params {
    /// The camera part of the params.
    pub fn camera(&self) -> CameraFrame {
        CameraFrame { eye: self.cam_eye, u: self.cam_u, v: self.cam_v, w: self.cam_w }
    }
}

/// The raygen program's SBT record: the light it samples.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RaygenRecord {
    /// A corner of the parallelogram light.
    pub corner: Vec3,
    /// Its first edge.
    pub v1: Vec3,
    /// Its second edge.
    pub v2: Vec3,
    /// Its emitted radiance.
    pub emission: Vec3,
}

impl RaygenRecord {
    /// The record of `light`.
    pub const fn new(light: &Light) -> Self {
        RaygenRecord { corner: light.corner, v1: light.v1, v2: light.v2, emission: light.emission }
    }
    /// The light.
    pub fn light(&self) -> Light {
        Light { corner: self.corner, v1: self.v1, v2: self.v2, emission: self.emission }
    }
}

/// The radiance hit group's SBT record, one per material group (geometry).
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HitRecord {
    /// Emitted radiance.
    pub emission: Vec3,
    /// Index of the geometry's first triangle in [`Params::normals`].
    pub first_triangle: u32,
    /// Diffuse reflectance.
    pub albedo: Vec3,
    /// Padding.
    pub _pad: u32,
}

/// Radiance rays: the payload is the hit, filled by closest-hit or miss.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = HitInfo;
    const SBT_OFFSET: u32 = 0;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 0;
}

/// Shadow rays: payload 1 when the light sample is visible (the miss program
/// ran), 0 when something is in the way; the first hit ends the traversal.
pub struct Shadow;
impl RayType for Shadow {
    type Payload = u32;
    const SBT_OFFSET: u32 = 1;
    const SBT_STRIDE: u32 = 2;
    const MISS_INDEX: u32 = 1;
    const FLAGS: RayFlags =
        RayFlags::TERMINATE_ON_FIRST_HIT.union(RayFlags::SKIP_CLOSEST_HIT_SHADER).union(RayFlags::OPAQUE);
}

/// The raygen program's SBT record when it also writes the guides of a
/// denoiser ([`RG_GUIDES`]): the light, and the buffers of the first-hit
/// albedo and normals.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GuidesRaygenRecord {
    /// A corner of the parallelogram light.
    pub corner: Vec3,
    /// Its first edge.
    pub v1: Vec3,
    /// Its second edge.
    pub v2: Vec3,
    /// Its emitted radiance.
    pub emission: Vec3,
    /// Per pixel: the sum over its paths of the first hit's albedo (xyz; the
    /// emitter's normalised colour on the light, 0 for a miss) and the paths (w).
    /// Launch `subframe == 0` overwrites it, as it does `Params::accum`.
    pub albedo: Buffer<Vec4>,
    /// Per pixel: the sum over its paths of the first hit's world normal, facing
    /// the camera (xyz; 0 for a miss), and the paths (w).
    pub normal: Buffer<Vec4>,
}

impl GuidesRaygenRecord {
    /// The light.
    pub fn light(&self) -> Light {
        Light { corner: self.corner, v1: self.v1, v2: self.v2, emission: self.emission }
    }
}

/// What one pixel's paths of a launch add up to.
struct PixelSums {
    radiance: Vec3,
    rays: u32,
    albedo: Vec3,
    normal: Vec3,
}

/// The albedo guide of a first hit: the surface's reflectance, or on an
/// emitter its colour normalised to a largest channel of 1 (as OIDN advises for lights).
fn guide_albedo(hit: &HitInfo) -> Vec3 {
    if hit.t < 0.0 {
        return Vec3::ZERO;
    }
    let peak = hit.emission.max_element();
    if peak > 0.0 {
        hit.emission / peak
    } else {
        hit.albedo
    }
}

/// The path loop of a pixel: `p.samples` paths from the camera through pixel
/// `index`, with next-event estimation towards `light`. Also sums the first
/// hit's albedo and normal (which [`rg`] leaves unused).
#[inline(always)]
fn trace_pixel(
    ctx: &mut Raygen,
    p: &Params,
    light: &Light,
    index: UVec2,
    hit: &mut HitInfo,
    visible: &mut u32,
) -> PixelSums {
    let dims: UVec2 = p.size;
    let pixel = index.x + dims.x * index.y;
    let mut seed = math::pixel_seed(pixel, p.subframe);
    let mut sums = PixelSums { radiance: Vec3::ZERO, rays: 0, albedo: Vec3::ZERO, normal: Vec3::ZERO };
    let mut sample = 0;
    // The camera (params) and the light (SBT record) are read where they are
    // used, inside the loops, as the GLSL twin does: read once before the loops,
    // their 24 floats would stay live across every trace call, and NVIDIA's
    // driver keeps a raygen's state across `OpTraceRayKHR` in registers (fewer
    // warps in flight). Re-reading push constants and the record is cheap.
    while sample < p.samples {
        let mut state = PathState::camera(&p.camera(), index, dims, &mut seed);
        let mut first = true;
        while !state.done {
            *hit = HitInfo::MISS;
            let ray = Ray::new(state.origin, state.direction).with_interval(RAY_EPSILON, 1e16);
            ctx.trace::<Radiance>(p.handle, ray, hit);
            sums.rays += 1;
            if first {
                first = false;
                sums.albedo += guide_albedo(hit);
                if hit.t >= 0.0 {
                    sums.normal += hit.normal;
                }
            }
            let shadow = state.shade(hit, light, &mut seed, p.max_depth);
            if shadow.contribution != Vec3::ZERO {
                *visible = 0;
                let ray = Ray::new(shadow.origin, shadow.direction).with_interval(RAY_EPSILON, shadow.t_max);
                ctx.trace::<Shadow>(p.handle, ray, visible);
                sums.rays += 1;
                if *visible != 0 {
                    state.radiance += shadow.contribution;
                }
            }
        }
        sums.radiance += state.radiance;
        sample += 1;
    }
    sums
}

/// Adds `value` to element `pixel` of `buffer`, or overwrites it on the first launch.
#[inline(always)]
fn accumulate(ctx: &mut Raygen, p: &Params, buffer: Buffer<Vec4>, pixel: u32, value: Vec4) {
    let previous = if p.subframe == 0 { Vec4::ZERO } else { ctx.load(buffer, pixel) };
    ctx.store(buffer, pixel, previous + value);
}

#[raygen]
fn rg(
    ctx: &mut Raygen,
    #[params] p: &Params,
    #[record] record: &RaygenRecord,
    #[payload] hit: &mut HitInfo,
    #[payload] visible: &mut u32,
) {
    // The pixel in the whole image: this launch may render a band of its rows.
    let index = ctx.launch_index().truncate() + UVec2::new(0, p.row_offset);
    let pixel = index.x + p.size.x * index.y;
    let sums = trace_pixel(ctx, p, &record.light(), index, hit, visible);
    accumulate(ctx, p, p.accum, pixel, sums.radiance.extend(sums.rays as f32));
}

/// [`rg`] that also writes the denoiser's guides: the first hit's albedo and
/// normal, summed over the same paths, in the same launch.
#[raygen]
fn rg_guides(
    ctx: &mut Raygen,
    #[params] p: &Params,
    #[record] record: &GuidesRaygenRecord,
    #[payload] hit: &mut HitInfo,
    #[payload] visible: &mut u32,
) {
    let index = ctx.launch_index().truncate() + UVec2::new(0, p.row_offset);
    let pixel = index.x + p.size.x * index.y;
    let sums = trace_pixel(ctx, p, &record.light(), index, hit, visible);
    let paths = p.samples as f32;
    accumulate(ctx, p, p.accum, pixel, sums.radiance.extend(sums.rays as f32));
    accumulate(ctx, p, record.albedo, pixel, sums.albedo.extend(paths));
    accumulate(ctx, p, record.normal, pixel, sums.normal.extend(paths));
}

#[miss(ray = Radiance)]
fn ms(_ctx: &mut Miss, #[payload] hit: &mut HitInfo) {
    hit.t = -1.0;
}

#[closest_hit(ray = Radiance)]
fn ch(ctx: &mut ClosestHit, #[params] p: &Params, #[record] material: &HitRecord, #[payload] hit: &mut HitInfo) {
    let normal = ctx.load(p.normals, material.first_triangle + ctx.primitive_index());
    hit.normal = math::face_forward(normal, ctx.world_ray_direction());
    hit.t = ctx.hit_t();
    hit.emission = material.emission;
    hit.albedo = material.albedo;
}

#[miss(ray = Shadow)]
fn ms_shadow(_ctx: &mut Miss, #[payload] visible: &mut u32) {
    *visible = 1;
}

/// The shadow ray type's hit group (never run: shadow rays skip closest-hit).
#[closest_hit(ray = Shadow)]
fn ch_shadow(_ctx: &mut ClosestHit, #[payload] visible: &mut u32) {
    *visible = 0;
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn params_fit_push_constants_and_have_the_same_layout_everywhere() {
        assert_eq!(core::mem::size_of::<Params>(), 88);
        assert_eq!(core::mem::offset_of!(Params, cam_eye), 32);
        assert_eq!(core::mem::offset_of!(Params, handle), 80);
        assert!(raykit_device::uses_push_constants::<Params>());
        assert_eq!(core::mem::size_of::<RaygenRecord>(), 48);
        assert_eq!(core::mem::size_of::<HitRecord>(), 32);
        assert_eq!(core::mem::size_of::<GuidesRaygenRecord>(), 56);
    }

    #[test]
    fn the_scene_groups_cover_every_triangle() {
        let mut next = 0;
        for group in scene::MATERIALS {
            assert_eq!(group.first_triangle, next, "{}", group.name);
            next += group.triangles;
        }
        assert_eq!(next as usize * 3, scene::VERTICES.len());
        assert!((scene::LIGHT.normal() - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6);
    }

    #[test]
    fn entry_points_carry_optix_prefixes() {
        assert_eq!(RG.name, "__raygen__rg");
        assert_eq!(RG_GUIDES.name, "__raygen__rg_guides");
        assert_eq!(CH.name, "__closesthit__ch");
        assert_eq!(MS_SHADOW.name, "__miss__ms_shadow");
    }
}
