//! Equirectangular environment maps, importance-sampled: the mapping between
//! directions and texture coordinates, and sampling of a direction in
//! proportion to the map's luminance through a piecewise-constant 2D
//! distribution (a marginal CDF over rows, a conditional CDF per row; built on
//! the host, `raykit_scene::EnvironmentMap`).
//!
//! The CDFs are one table of `f32`s, read through a function so that the same
//! code runs on the device (a `Buffer<f32>` read with the stage context's `load`)
//! and on the host (a slice): entries `0..=height` are the marginal CDF over rows
//! (`cdf[0] = 0`, `cdf[height] = 1`), then row `j`'s conditional CDF over its
//! columns at `height + 1 + j × (width + 1)`, `width + 1` entries.
//!
//! Directions are y-up: `v = 0` is straight up (+y), `u = 0.5` looks down −z.

use spirv_std::glam::{Vec2, Vec3};

use crate::math::{sin_cos, sqrt};
use crate::sampling::PI;

/// The direction of texture coordinates `uv` of an equirectangular map.
pub fn equirect_direction(uv: Vec2) -> Vec3 {
    let (sin_phi, cos_phi) = sin_cos(2.0 * PI * (uv.x - 0.5));
    let (sin_theta, cos_theta) = sin_cos(PI * uv.y);
    Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
}

/// The texture coordinates of unit direction `d` (the inverse of [`equirect_direction`]).
pub fn equirect_uv(d: Vec3) -> Vec2 {
    Vec2::new(atan2(d.x, -d.z) * (0.5 / PI) + 0.5, acos(d.y.clamp(-1.0, 1.0)) * (1.0 / PI))
}

fn atan2(y: f32, x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        y.atan2(x)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        y.atan2(x)
    }
}

fn acos(x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        x.acos()
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.acos()
    }
}

/// A direction sampled from an environment map.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct EnvironmentSample {
    /// Unit direction.
    pub direction: Vec3,
    /// Its texture coordinates.
    pub uv: Vec2,
    /// Its pdf per steradian.
    pub pdf: f32,
}

/// The interval `i` of the `n`-interval CDF at `base` holding `u`: `cdf(base + i) ≤ u <
/// cdf(base + i + 1)`; returns `i`, where in it `u` lies (0..1) and the interval's
/// probability mass.
fn find_interval(cdf: &impl Fn(u32) -> f32, base: u32, n: u32, u: f32) -> (u32, f32, f32) {
    // The largest i in [0, n) with cdf(base + i) <= u.
    let (mut lo, mut hi) = (0u32, n);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cdf(base + mid) <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let (a, b) = (cdf(base + lo), cdf(base + lo + 1));
    let mass = b - a;
    let offset = if mass > 0.0 { ((u - a) / mass).clamp(0.0, 1.0) } else { 0.5 };
    (lo, offset, mass)
}

/// Samples a direction of a `width × height` map from two uniform numbers in
/// `[0, 1)`, in proportion to the map's sampling weights.
pub fn sample_environment(width: u32, height: u32, cdf: impl Fn(u32) -> f32, u1: f32, u2: f32) -> EnvironmentSample {
    let (row, dv, row_mass) = find_interval(&cdf, 0, height, u2);
    let base = height + 1 + row * (width + 1);
    let (column, du, column_mass) = find_interval(&cdf, base, width, u1);
    let uv = Vec2::new((column as f32 + du) / width as f32, (row as f32 + dv) / height as f32);
    let pdf_uv = row_mass * height as f32 * column_mass * width as f32;
    let direction = equirect_direction(uv);
    let sin_theta = sqrt((1.0 - direction.y * direction.y).max(0.0));
    let pdf = if sin_theta > 0.0 { pdf_uv / (2.0 * PI * PI * sin_theta) } else { 0.0 };
    EnvironmentSample { direction, uv, pdf }
}

/// The pdf per steradian with which [`sample_environment`] picks unit direction `d`.
pub fn environment_pdf(width: u32, height: u32, cdf: impl Fn(u32) -> f32, d: Vec3) -> f32 {
    let uv = equirect_uv(d);
    let row = ((uv.y * height as f32) as u32).min(height - 1);
    let column = ((uv.x * width as f32) as u32).min(width - 1);
    let base = height + 1 + row * (width + 1);
    let row_mass = cdf(row + 1) - cdf(row);
    let column_mass = cdf(base + column + 1) - cdf(base + column);
    let sin_theta = sqrt((1.0 - d.y * d.y).max(0.0));
    if sin_theta > 0.0 {
        row_mass * height as f32 * column_mass * width as f32 / (2.0 * PI * PI * sin_theta)
    } else {
        0.0
    }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn directions_and_coordinates_round_trip() {
        for &(u, v) in &[(0.5f32, 0.5f32), (0.1, 0.3), (0.9, 0.8), (0.25, 0.5)] {
            let d = equirect_direction(Vec2::new(u, v));
            assert!((d.length() - 1.0).abs() < 1e-5);
            let back = equirect_uv(d);
            assert!((back - Vec2::new(u, v)).length() < 1e-4, "{u} {v} -> {back}");
        }
        assert!((equirect_direction(Vec2::new(0.5, 0.5)) - Vec3::NEG_Z).length() < 1e-6);
        assert!((equirect_direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
    }
}
