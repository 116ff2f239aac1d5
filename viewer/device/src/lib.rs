//! The viewer's display pass: one raygen program, one invocation per pixel, that
//! divides the accumulated radiance by the samples taken, applies the exposure,
//! Reinhard's tonemap on each channel and the sRGB curve, and packs the result
//! into a `u32` whose bytes are the window's pixel format.
//!
//! It traces nothing: it is a raykit program so that one piece of code does the
//! display on every backend (the same function on the CPU backend, the same
//! SPIR-V on every Vulkan driver) and a headless render has the window's bytes.
//!
//! This crate is compiled twice: to SPIR-V by `cargo xtask build-shaders`, and for
//! the host, where [`DisplayParams`], [`DISPLAY`] and [`display_pixel`] are shared
//! with the viewer.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{Vec3, Vec4};
use raykit_device::{raygen, Buffer, LaunchParams, Raygen};

/// How [`display_pixel`] orders the channels in a `u32`.
pub mod layout {
    /// Red in the lowest byte, alpha in the highest: `VK_FORMAT_R8G8B8A8_UNORM` and PNG.
    pub const RGBA: u32 = 0;
    /// Blue in the lowest byte, alpha in the highest: `VK_FORMAT_B8G8R8A8_UNORM`, and
    /// softbuffer's `0RGB` words when alpha is 0.
    pub const BGRA: u32 = 1;
}

/// Launch params of the display pass.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct DisplayParams {
    /// Per pixel: the sum of the radiance samples (xyz); w is not read.
    pub accum: Buffer<Vec4>,
    /// The displayed pixels, row-major, row 0 at the top.
    pub pixels: Buffer<u32>,
    /// Pixels per row.
    pub width: u32,
    /// Samples per pixel in `accum` in the rows above `split_row` (0 shows black).
    pub samples: u32,
    /// Scale applied to the mean radiance before the tonemap.
    pub exposure: f32,
    /// [`layout::RGBA`] or [`layout::BGRA`].
    pub layout: u32,
    /// The alpha byte written (255 for a swapchain image, 0 for softbuffer).
    pub alpha: u32,
    /// The first row with `samples_below` samples per pixel: a pass of row bands
    /// has reached the rows above it (the image's height when no pass is under way).
    pub split_row: u32,
    /// Samples per pixel in the rows from `split_row` down.
    pub samples_below: u32,
}

/// The displayed `u32` of an accumulated radiance sum `sum` after `samples`
/// samples: exposure, Reinhard per channel, sRGB, 8 bits, in `layout` with `alpha`.
pub fn display_pixel(sum: Vec3, samples: u32, exposure: f32, layout: u32, alpha: u32) -> u32 {
    let mean = if samples == 0 { Vec3::ZERO } else { sum / samples as f32 };
    let q = |v: f32| -> u32 {
        let v = (v * exposure).max(0.0);
        raykit_device::color::srgb8(v / (1.0 + v))
    };
    let (r, g, b) = (q(mean.x), q(mean.y), q(mean.z));
    let (low, high) = if layout == layout::BGRA { (b, r) } else { (r, b) };
    low | (g << 8) | (high << 16) | ((alpha & 0xff) << 24)
}

#[raygen]
fn display(ctx: &mut Raygen, #[params] p: &DisplayParams) {
    let index = ctx.launch_index();
    let pixel = index.x + p.width * index.y;
    let sum: Vec4 = ctx.load(p.accum, pixel);
    let samples = if index.y < p.split_row { p.samples } else { p.samples_below };
    let value = display_pixel(sum.truncate(), samples, p.exposure, p.layout, p.alpha);
    ctx.store(p.pixels, pixel, value);
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn layouts_swap_red_and_blue_and_carry_alpha() {
        let sum = Vec3::new(2.0, 0.0, 0.0); // mean 1 after 2 samples: Reinhard 0.5
        let red = raykit_device::color::srgb8(0.5);
        assert_eq!(display_pixel(sum, 2, 1.0, layout::RGBA, 255), red | 0xff00_0000);
        assert_eq!(display_pixel(sum, 2, 1.0, layout::BGRA, 0), red << 16);
        assert_eq!(display_pixel(sum, 0, 1.0, layout::RGBA, 0), 0);
    }
}
