//! Colour transfer functions and pixel packing shared by device programs and
//! the host: sRGB encode and decode, RGBA8 packing.

use spirv_std::glam::Vec3;

use crate::math::powf;

/// Linear → sRGB transfer of one channel in `[0, 1]`.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * powf(c, 1.0 / 2.4) - 0.055
    }
}

/// sRGB → linear transfer of one channel in `[0, 1]` (what a sampler does for an
/// sRGB texture format).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        powf((c + 0.055) / 1.055, 2.4)
    }
}

/// sutil's `make_color`: clamps a linear colour to `[0, 1]`, sRGB-encodes and
/// quantises it to 8 bits, packed as RGBA8 (red in the lowest byte, alpha 255).
pub fn pack_srgb8(c: Vec3) -> u32 {
    let q = |v: f32| -> u32 { (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u32 };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

/// Quantises a colour clamped to `[0, 1]` to RGBA8 without a transfer function
/// (red in the lowest byte, alpha 255): for pictures tests compare exactly.
pub fn pack_unorm8(c: Vec3) -> u32 {
    let q = |v: f32| -> u32 { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u32 };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_and_packs() {
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5, "{c}");
        }
        assert_eq!(pack_srgb8(Vec3::new(1.0, 0.0, 2.0)), 0xffff_00ff);
        assert_eq!(pack_unorm8(Vec3::new(0.5, 0.0, 1.0)), 0xffff_0080);
    }
}
