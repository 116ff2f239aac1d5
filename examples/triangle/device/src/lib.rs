//! optixTriangle in Rust: one triangle, a pinhole camera, a miss program that
//! returns the background colour from its SBT record, a closest-hit program that
//! colours by barycentrics.
//!
//! This crate is compiled twice: to SPIR-V by `cargo xtask build-shaders`, and for
//! the host, where [`Params`], [`MissData`], the entry-point constants ([`RG`],
//! [`MS`], [`CH`]) and the colour helpers are shared with the host program and
//! the CPU reference of the tests.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, UVec3, Vec2, Vec3};
use raykit_device::{closest_hit, miss, raygen, Buffer, ClosestHit, LaunchParams, Miss, RayType, Raygen, Traversable};

/// Launch params, as in optixTriangle's `Params`: output image, its size, the camera
/// basis (`cam_u`, `cam_v`, `cam_w` scaled to the image plane) and the scene.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// RGBA8 pixels, row-major, row 0 at the top.
    pub image: Buffer<u32>,
    /// Image width and height in pixels.
    pub size: UVec2,
    /// Camera position.
    pub cam_eye: Vec3,
    /// Camera right vector, scaled to half the image plane width.
    pub cam_u: Vec3,
    /// Camera up vector, scaled to half the image plane height.
    pub cam_v: Vec3,
    /// Camera forward vector, from the eye to the image plane centre.
    pub cam_w: Vec3,
    /// Padding so `handle` sits on its 8-byte alignment on every target.
    pub _pad: u32,
    /// The scene's top-level acceleration structure.
    pub handle: Traversable,
}

/// The miss program's SBT record data.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MissData {
    /// Background colour (linear RGB).
    pub bg_color: Vec3,
}

/// The one ray type: radiance, payload = linear RGB colour.
pub struct Radiance;
impl RayType for Radiance {
    type Payload = Vec3;
}

/// Where on the image plane the centre of pixel `index` of a `dims`-sized image
/// lies, in `[-1, 1]²` with +y up (row 0 is the top row).
pub fn pixel_to_ndc(index: UVec2, dims: UVec2) -> Vec2 {
    let x = (index.x as f32 + 0.5) / dims.x as f32;
    let y = (index.y as f32 + 0.5) / dims.y as f32;
    Vec2::new(2.0 * x - 1.0, 1.0 - 2.0 * y)
}

/// The camera ray through the centre of pixel `index` (optixTriangle's `computeRay`).
pub fn camera_ray(index: UVec2, dims: UVec2, params: &Params) -> (Vec3, Vec3) {
    let d = pixel_to_ndc(index, dims);
    let direction = (d.x * params.cam_u + d.y * params.cam_v + params.cam_w).normalize();
    (params.cam_eye, direction)
}

/// sutil's `make_color`: clamp, sRGB-encode, quantise to 8 bits, pack as RGBA8
/// (red in the lowest byte, alpha 255).
pub use raykit_device::color::pack_srgb8 as make_color;

/// The closest-hit colour: `(1 - u - v, u, v)` from the barycentrics.
pub fn barycentric_color(b: Vec2) -> Vec3 {
    Vec3::new(1.0 - b.x - b.y, b.x, b.y)
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] params: &Params, #[payload] color: &mut Vec3) {
    let index: UVec3 = ctx.launch_index();
    let (origin, direction) = camera_ray(index.truncate(), ctx.launch_dimensions().truncate(), params);
    *color = Vec3::ZERO;
    ctx.trace_from::<Radiance>(params.handle, origin, direction, color);
    let pixel = ctx.launch_linear_index();
    ctx.store(params.image, pixel, make_color(*color));
}

#[miss(ray = Radiance)]
fn ms(_ctx: &mut Miss, #[record] data: &MissData, #[payload] color: &mut Vec3) {
    *color = data.bg_color;
}

#[closest_hit(ray = Radiance)]
fn ch(ctx: &mut ClosestHit, #[payload] color: &mut Vec3) {
    *color = barycentric_color(ctx.barycentrics());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entry_points_carry_optix_prefixes() {
        assert_eq!(RG.name, "__raygen__rg");
        assert_eq!(MS.name, "__miss__ms");
        assert_eq!(CH.name, "__closesthit__ch");
        assert_eq!(CH.kind, raykit_device::ProgramKind::ClosestHit);
    }

    #[test]
    fn params_layout_is_the_same_on_every_target() {
        assert_eq!(core::mem::size_of::<Params>(), 72);
        assert_eq!(core::mem::offset_of!(Params, handle), 64);
        assert_eq!(core::mem::offset_of!(Params, cam_w), 48);
    }

    #[test]
    fn derive_records_the_params_layout() {
        let layout = <Params as LaunchParams>::LAYOUT;
        assert_eq!(layout.name, "Params");
        assert_eq!(layout.size, 72);
        let names: Vec<&str> = layout.fields.iter().map(|f| f.name).collect();
        assert_eq!(names, ["image", "size", "cam_eye", "cam_u", "cam_v", "cam_w", "_pad", "handle"]);
        let handle = layout.fields[7];
        assert_eq!((handle.offset, handle.size, handle.type_name), (64, 8, "Traversable"));
    }

    #[test]
    fn make_color_quantises_like_sutil() {
        assert_eq!(make_color(Vec3::ZERO), 0xff00_0000);
        assert_eq!(make_color(Vec3::ONE), 0xffff_ffff);
        assert_eq!(make_color(Vec3::new(2.0, -1.0, 0.0)), 0xff00_00ff);
    }
}
