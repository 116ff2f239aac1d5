//! Participating media: a constant-density medium (*The Next Week*'s
//! `constant_medium`: smoke, fog, mist) bounded by any closed geometry.
//!
//! A ray inside such a medium travels a free-flight distance `d` (exponential,
//! with `density` as its rate: [`ConstantMedium::sample_distance`]) before it
//! scatters, in a direction the phase function picks (isotropic:
//! [`isotropic_direction`]), its light attenuated by the medium's `albedo`. If
//! the ray reaches the boundary (or a surface inside) first, it goes on from
//! there, as it would without the medium: the estimator is unbiased, with
//! transmittance `exp(−density · t)` ([`ConstantMedium::transmittance`]) over a
//! segment of length `t`.
//!
//! # The path loop
//! The boundary is a GAS of its own (a [`crate::triangle`] mesh or spheres)
//! whose hit group only reports where the boundary is: closest-hit records the
//! distance ([`crate::bounce::Bounce::hit`]) and moves the path across the
//! boundary (`scatter_from` with the ray's own direction and an attenuation of
//! 1), with the face saying whether the path now is inside. Raygen's loop, built
//! from [`crate::bounce::trace_bounce`], then does per trace:
//!
//! ```text
//! trace_bounce(ray)                                  // the next boundary or surface hit
//! if inside the medium:
//!     d = medium.sample_distance(rng.next_f32())
//!     if d < payload.distance:                       // scatters before the hit
//!         origin = ray.origin + d · ray.direction    // (direction of unit length)
//!         throughput *= medium.albedo
//!         ray = Ray::new(origin, isotropic_direction(rng.next_f32(), rng.next_f32()))
//!         continue                                    // still inside
//! handle the hit as [`crate::bounce::trace_path`] does (emission, escape, scatter)
//! ```
//!
//! Inside, the ray's direction must have unit length for `d` to be a distance;
//! [`crate::bounce::Bounce`] carries the hit's `distance` for this comparison.

use spirv_std::glam::Vec3;

use crate::math::{exp, ln, sin_cos, sqrt};

/// A medium of constant density.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ConstantMedium {
    /// Scattering events per unit length (the book's `-1/neg_inv_density`).
    pub density: f32,
    /// The fraction of light each scattering keeps, per channel.
    pub albedo: Vec3,
}

impl ConstantMedium {
    /// A free-flight distance for `u` uniform in `[0, 1)`: `−ln(1 − u) / density`
    /// (infinite for a density of 0).
    pub fn sample_distance(&self, u: f32) -> f32 {
        if self.density <= 0.0 {
            return f32::INFINITY;
        }
        -ln(1.0 - u) / self.density
    }

    /// The probability of crossing `distance` without scattering: `exp(−density · distance)`.
    pub fn transmittance(&self, distance: f32) -> f32 {
        exp(-self.density * distance)
    }
}

/// A direction uniform on the unit sphere from `u1`, `u2` uniform in `[0, 1)`:
/// the isotropic phase function's sample (pdf `1 / 4π`).
pub fn isotropic_direction(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = sqrt((1.0 - z * z).max(0.0));
    let (sin, cos) = sin_cos(2.0 * core::f32::consts::PI * u2);
    Vec3::new(r * cos, r * sin, z)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn free_flight_distances_are_exponential_with_the_density_as_rate() {
        let medium = ConstantMedium { density: 0.5, albedo: Vec3::ONE };
        let n = 100_000;
        let mut rng = crate::sampling::Pcg::new(7, 1);
        let (mut sum, mut beyond_two) = (0.0f64, 0u32);
        for _ in 0..n {
            let d = medium.sample_distance(rng.next_f32());
            assert!(d >= 0.0 && d.is_finite());
            sum += d as f64;
            beyond_two += u32::from(d > 2.0);
        }
        // Mean 1/density = 2, standard deviation 2: standard error 2/√n.
        let mean = sum / n as f64;
        assert!((mean - 2.0).abs() < 5.0 * 2.0 / (n as f64).sqrt(), "mean free path {mean}");
        // P(d > 2) = transmittance(2) = e⁻¹.
        let p = beyond_two as f64 / n as f64;
        let t = medium.transmittance(2.0) as f64;
        assert!((t - (-1.0f64).exp()).abs() < 1e-6, "{t}");
        assert!((p - t).abs() < 5.0 * (t * (1.0 - t) / n as f64).sqrt(), "P(d > 2) = {p}, want {t}");
        assert_eq!(ConstantMedium { density: 0.0, albedo: Vec3::ONE }.sample_distance(0.5), f32::INFINITY);
    }

    #[test]
    fn isotropic_directions_are_unit_and_uniform() {
        let mut rng = crate::sampling::Pcg::new(3, 2);
        let n = 100_000;
        let mut mean = Vec3::ZERO;
        let mut upper = 0u32;
        for _ in 0..n {
            let d = isotropic_direction(rng.next_f32(), rng.next_f32());
            assert!((d.length() - 1.0).abs() < 1e-5, "{d}");
            mean += d / n as f32;
            upper += u32::from(d.x > 0.0);
        }
        // Each coordinate has mean 0 and variance 1/3.
        let se = (1.0 / 3.0 / n as f32).sqrt();
        assert!(mean.abs().max_element() < 5.0 * se, "mean direction {mean}");
        let half = upper as f64 / n as f64;
        assert!((half - 0.5).abs() < 5.0 * (0.25 / n as f64).sqrt(), "x > 0 for {half}");
    }
}
