//! Random numbers and the sampling routines path tracers share: counter-based
//! random numbers ([`tea4`] seeds, an [`Lcg`] stream as sutil's, and a [`Pcg`]
//! stream), an orthonormal basis ([`Onb`]), the standard samplers (a uniform
//! [unit vector](random_unit_vector), a point [in the unit sphere](random_in_unit_sphere)
//! or [disk](random_in_unit_disk), cosine-weighted directions
//! [around +z](cosine_sample_hemisphere) or [a normal](cosine_sample_around)),
//! GGX (Trowbridge–Reitz) microfacet sampling of the visible normals (Heitz 2018),
//! and normals from object to world space.
//!
//! The samplers map uniform numbers in `[0, 1)` to their distribution directly
//! (no rejection loops, so every invocation takes the same steps); [`Pcg`] has
//! a method for each.
//!
//! Everything compiles for SPIR-V and for the host (CPU references compute the
//! same bits): integer arithmetic wraps explicitly.

use spirv_std::glam::{Vec2, Vec3};

use crate::math::{powf, sin_cos, sqrt};
use crate::Matrix4x3;

/// π.
pub const PI: f32 = core::f32::consts::PI;

/// The Tiny Encryption Algorithm with 4 rounds (sutil's `tea<4>`): a well-mixed
/// seed from two integers, such as a pixel index and a launch index.
pub fn tea4(val0: u32, val1: u32) -> u32 {
    let (mut v0, mut v1, mut s0) = (val0, val1, 0u32);
    let mut n = 0;
    while n < 4 {
        s0 = s0.wrapping_add(0x9e37_79b9);
        v0 = v0.wrapping_add(
            (v1 << 4).wrapping_add(0xa341_316c) ^ v1.wrapping_add(s0) ^ (v1 >> 5).wrapping_add(0xc801_3ea4),
        );
        v1 = v1.wrapping_add(
            (v0 << 4).wrapping_add(0xad90_777d) ^ v0.wrapping_add(s0) ^ (v0 >> 5).wrapping_add(0x7e95_761e),
        );
        n += 1;
    }
    v0
}

/// sutil's linear congruential generator: 24-bit numbers from a 32-bit state
/// (optixPathTracer's `lcg` and `rnd`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Lcg {
    /// The state.
    pub state: u32,
}

impl Lcg {
    /// A stream starting at `seed` (usually from [`tea4`]).
    pub const fn new(seed: u32) -> Lcg {
        Lcg { state: seed }
    }
    /// Advances the state; returns 24 bits.
    pub fn next_u24(&mut self) -> u32 {
        self.state = self.state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        self.state & 0x00ff_ffff
    }
    /// A uniform number in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        self.next_u24() as f32 / 16_777_216.0
    }
}

/// The PCG hash (Jarzynski and Olano 2020, "Hash Functions for GPU Rendering"):
/// one well-mixed 32-bit value from another, for counter-based random numbers.
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A PCG stream (the RXS-M-XS output of a 32-bit LCG state, as [`pcg_hash`]):
/// better distributed than [`Lcg`], as cheap.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Pcg {
    /// The state.
    pub state: u32,
}

impl Pcg {
    /// A stream for `(a, b)`, such as pixel and sample index.
    pub fn new(a: u32, b: u32) -> Pcg {
        Pcg { state: pcg_hash(a ^ pcg_hash(b)) }
    }
    /// 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        self.state = self.state.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        let s = self.state;
        let word = ((s >> ((s >> 28).wrapping_add(4))) ^ s).wrapping_mul(277_803_737);
        (word >> 22) ^ word
    }
    /// A uniform number in `[0, 1)` (24 bits, exact in `f32`).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / 16_777_216.0
    }
    /// Two uniform numbers in `[0, 1)`.
    pub fn next_vec2(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
    /// Three uniform numbers in `[0, 1)`.
    pub fn next_vec3(&mut self) -> Vec3 {
        let xy = self.next_vec2();
        Vec3::new(xy.x, xy.y, self.next_f32())
    }
    /// A uniformly distributed unit vector ([`random_unit_vector`]).
    pub fn unit_vector(&mut self) -> Vec3 {
        random_unit_vector(self.next_vec2())
    }
    /// A uniformly distributed point in the unit ball ([`random_in_unit_sphere`]).
    pub fn in_unit_sphere(&mut self) -> Vec3 {
        random_in_unit_sphere(self.next_vec3())
    }
    /// A uniformly distributed point in the unit disk, `z = 0` ([`random_in_unit_disk`]).
    pub fn in_unit_disk(&mut self) -> Vec3 {
        random_in_unit_disk(self.next_vec2())
    }
    /// A cosine-distributed direction around unit `normal` ([`cosine_sample_around`]).
    pub fn cosine_around(&mut self, normal: Vec3) -> Vec3 {
        cosine_sample_around(normal, self.next_vec2())
    }
}

/// A unit vector uniformly distributed over the sphere, from two uniform
/// numbers in `[0, 1)` (`z = 1 − 2u.x`, azimuth `2π u.y`: Archimedes' hat-box
/// theorem); pdf `1 / 4π` per steradian.
pub fn random_unit_vector(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt((1.0 - z * z).max(0.0));
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// A point uniformly distributed in the unit ball, from three uniform numbers
/// in `[0, 1)`: a [`random_unit_vector`] of `u.xy` scaled by `∛u.z`.
pub fn random_in_unit_sphere(u: Vec3) -> Vec3 {
    random_unit_vector(Vec2::new(u.x, u.y)) * powf(u.z, 1.0 / 3.0)
}

/// A point uniformly distributed in the unit disk of the xy-plane (`z = 0`),
/// from two uniform numbers in `[0, 1)`: radius `√u.x`, angle `2π u.y`. A
/// thin lens samples its aperture with it.
pub fn random_in_unit_disk(u: Vec2) -> Vec3 {
    let r = sqrt(u.x);
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, 0.0)
}

/// A cosine-weighted direction on the hemisphere around unit `normal` (a
/// [`cosine_sample_hemisphere`] in the normal's [`Onb`]); pdf
/// [`cosine_hemisphere_pdf`] of `normal · direction`. The Lambertian bounce.
pub fn cosine_sample_around(normal: Vec3, u: Vec2) -> Vec3 {
    Onb::new(normal).to_world(cosine_sample_hemisphere(u.x, u.y))
}

/// An orthonormal basis around a unit normal (optixPathTracer's `Onb`):
/// `tangent × binormal = normal`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Onb {
    /// First tangent direction.
    pub tangent: Vec3,
    /// Second tangent direction.
    pub binormal: Vec3,
    /// The normal (local +z).
    pub normal: Vec3,
}

impl Onb {
    /// The basis of unit `normal`.
    pub fn new(normal: Vec3) -> Onb {
        let binormal = if normal.x.abs() > normal.z.abs() {
            Vec3::new(-normal.y, normal.x, 0.0)
        } else {
            Vec3::new(0.0, -normal.z, normal.y)
        };
        let binormal = binormal.normalize();
        let tangent = binormal.cross(normal);
        Onb { tangent, binormal, normal }
    }
    /// `p` from the local frame (normal = +z) to world space.
    pub fn to_world(&self, p: Vec3) -> Vec3 {
        p.x * self.tangent + p.y * self.binormal + p.z * self.normal
    }
    /// `p` from world space to the local frame.
    pub fn to_local(&self, p: Vec3) -> Vec3 {
        Vec3::new(p.dot(self.tangent), p.dot(self.binormal), p.dot(self.normal))
    }
}

/// A cosine-weighted direction on the hemisphere around +z from two uniform
/// numbers in `[0, 1)` (optixPathTracer's `cosine_sample_hemisphere`); its pdf
/// is [`cosine_hemisphere_pdf`].
pub fn cosine_sample_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = sqrt(u1);
    let (s, c) = sin_cos(2.0 * PI * u2);
    let x = r * c;
    let y = r * s;
    Vec3::new(x, y, sqrt((1.0 - x * x - y * y).max(0.0)))
}

/// The pdf (per steradian) of [`cosine_sample_hemisphere`] for a direction with
/// `cos θ = cos_theta`.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * (1.0 / PI)
}

/// The GGX normal distribution `D(h)` for roughness `alpha` (= perceptual
/// roughness²), with `cos θh = n_dot_h`.
pub fn ggx_d(n_dot_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d).max(1e-20)
}

/// Smith's masking function `G1` for GGX, for a direction with `cos θ = n_dot_v`.
pub fn ggx_g1(n_dot_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c = n_dot_v.abs();
    2.0 * c / (c + sqrt(a2 + (1.0 - a2) * c * c)).max(1e-20)
}

/// Smith's height-uncorrelated masking-shadowing `G2 = G1(v) G1(l)` for GGX.
pub fn ggx_g2(n_dot_v: f32, n_dot_l: f32, alpha: f32) -> f32 {
    ggx_g1(n_dot_v, alpha) * ggx_g1(n_dot_l, alpha)
}

/// A GGX microfacet normal sampled from the normals visible from `v` (local
/// frame, normal = +z, `v.z > 0`), isotropic roughness `alpha` (Heitz 2018,
/// "Sampling the GGX Distribution of Visible Normals"); its pdf is
/// [`ggx_vndf_pdf`] (of the half vector).
pub fn ggx_sample_vndf(v: Vec3, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    // The view direction in the hemisphere configuration.
    let vh = Vec3::new(alpha * v.x, alpha * v.y, v.z).normalize();
    let len_sq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len_sq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) * (1.0 / sqrt(len_sq)) } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = sqrt(u1);
    let (s, c) = sin_cos(2.0 * PI * u2);
    let p1 = r * c;
    let p2 = r * s;
    let blend = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - blend) * sqrt((1.0 - p1 * p1).max(0.0)) + blend * p2;
    let nh = p1 * t1 + p2 * t2 + sqrt((1.0 - p1 * p1 - p2 * p2).max(0.0)) * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// The pdf of the half vector `h` that [`ggx_sample_vndf`] returns for `v`:
/// `G1(v) max(v·h, 0) D(h) / v.z`. The reflected direction's pdf is this over
/// `4 v·h`.
pub fn ggx_vndf_pdf(v: Vec3, h: Vec3, alpha: f32) -> f32 {
    ggx_g1(v.z, alpha) * v.dot(h).max(0.0) * ggx_d(h.z, alpha) / v.z.max(1e-20)
}

pub use crate::optics::reflect;

/// An object-space normal in world space, through the inverse transpose of the
/// object-to-world transform, given as the hit's world-to-object matrix
/// (`ctx.world_to_object()`); normalised.
pub fn transform_normal_to_world(world_to_object: &Matrix4x3, n: Vec3) -> Vec3 {
    // (W2Oᵀ n)_i is the dot product of W2O's column i with n.
    Vec3::new(world_to_object.x_axis.dot(n), world_to_object.y_axis.dot(n), world_to_object.z_axis.dot(n)).normalize()
}

/// An object-space point (or, with `w = 0`, direction) through a 4×3 transform.
pub fn transform_point(m: &Matrix4x3, p: Vec3) -> Vec3 {
    m.x_axis * p.x + m.y_axis * p.y + m.z_axis * p.z + m.w_axis
}

/// The power heuristic (β = 2) weight of a sample with pdf `a` against one
/// with pdf `b` (multiple importance sampling).
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn tea_and_lcg_are_sutils() {
        // sutil's tea<4>(0, 0) and the first LCG step.
        assert_eq!(tea4(12, 3), tea4(12, 3));
        assert_ne!(tea4(12, 3), tea4(13, 3));
        let mut s = Lcg::new(1);
        assert_eq!(s.next_u24(), (1_664_525u32 + 1_013_904_223) & 0x00ff_ffff);
    }

    #[test]
    fn pcg_numbers_are_uniform() {
        let mut rng = Pcg::new(7, 3);
        let n = 100_000;
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = rng.next_f32() as f64;
            assert!((0.0..1.0).contains(&x));
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / n as f64;
        let var = sum_sq / n as f64 - mean * mean;
        // Mean within 5 standard errors of 1/2 (SE = sqrt(1/12 / n)); variance near 1/12.
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt(), "{mean}");
        assert!((var - 1.0 / 12.0).abs() < 0.002, "{var}");
        assert_eq!(pcg_hash(0), pcg_hash(0));
        assert_ne!(Pcg::new(1, 2).next_u32(), Pcg::new(2, 1).next_u32());
    }

    #[test]
    fn onb_is_orthonormal_and_round_trips() {
        let mut rng = Pcg::new(1, 1);
        for _ in 0..1000 {
            let n = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0).normalize();
            let b = Onb::new(n);
            assert!(b.tangent.dot(b.binormal).abs() < 1e-5 && b.tangent.dot(n).abs() < 1e-5);
            assert!((b.tangent.cross(b.binormal) - n).length() < 1e-4);
            let p = Vec3::new(0.3, -0.2, 0.9);
            assert!((b.to_local(b.to_world(p)) - p).length() < 1e-5);
        }
    }

    #[test]
    fn cosine_sampling_has_the_mean_cosine_of_its_pdf() {
        // E[cos θ] under pdf cos θ / π is 2/3.
        let mut rng = Pcg::new(2, 2);
        let n = 100_000;
        let mean = (0..n)
            .map(|_| {
                let d = cosine_sample_hemisphere(rng.next_f32(), rng.next_f32());
                assert!((d.length() - 1.0).abs() < 1e-4 && d.z >= 0.0);
                d.z as f64
            })
            .sum::<f64>()
            / n as f64;
        // Var(cos θ) = 1/2 - 4/9 = 1/18.
        assert!((mean - 2.0 / 3.0).abs() < 5.0 * (1.0 / 18.0 / n as f64).sqrt(), "{mean}");
    }

    /// Whether `value` is within 5 standard errors of the `expected` mean.
    fn near(value: f64, expected: f64, se: f64) -> bool {
        (value - expected).abs() < 5.0 * se
    }

    #[test]
    fn unit_vectors_are_uniform_on_the_sphere() {
        let mut rng = Pcg::new(40, 1);
        let n = 200_000;
        let samples: Vec<Vec3> = (0..n).map(|_| rng.unit_vector()).collect();
        assert!(samples.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
        // The cap cos θ > 1/2 around any axis covers a quarter of the sphere;
        // each coordinate has mean 0 and variance 1/3.
        for axis in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(1.0, -2.0, 0.5).normalize()] {
            let cap = samples.iter().filter(|v| v.dot(axis) > 0.5).count() as f64 / n as f64;
            assert!(near(cap, 0.25, (0.25 * 0.75 / n as f64).sqrt()), "{axis}: {cap}");
            let mean = samples.iter().map(|v| v.dot(axis) as f64).sum::<f64>() / n as f64;
            assert!(near(mean, 0.0, (1.0 / 3.0 / n as f64).sqrt()), "{axis}: {mean}");
        }
    }

    #[test]
    fn points_in_the_unit_sphere_and_disk_are_uniform() {
        let mut rng = Pcg::new(41, 1);
        let n = 200_000;
        let ball: Vec<Vec3> = (0..n).map(|_| rng.in_unit_sphere()).collect();
        assert!(ball.iter().all(|p| p.length() <= 1.0 + 1e-6));
        // Volume fractions: the ball of radius 1/2 holds 1/8; the octant x, y, z > 0 holds 1/8.
        let inner = ball.iter().filter(|p| p.length() < 0.5).count() as f64 / n as f64;
        let octant = ball.iter().filter(|p| p.x > 0.0 && p.y > 0.0 && p.z > 0.0).count() as f64 / n as f64;
        let se = (0.125 * 0.875 / n as f64).sqrt();
        assert!(near(inner, 0.125, se) && near(octant, 0.125, se), "{inner} {octant}");
        // E|p|² = 3/5, Var |p|² = 3/7 - 9/25.
        let m2 = ball.iter().map(|p| p.length_squared() as f64).sum::<f64>() / n as f64;
        assert!(near(m2, 0.6, ((3.0 / 7.0 - 0.36) / n as f64).sqrt()), "{m2}");

        let disk: Vec<Vec3> = (0..n).map(|_| rng.in_unit_disk()).collect();
        assert!(disk.iter().all(|p| p.z == 0.0 && p.length() <= 1.0 + 1e-6));
        // Area fractions: radius 1/2 holds 1/4, as does each quadrant.
        let inner = disk.iter().filter(|p| p.length() < 0.5).count() as f64 / n as f64;
        let quadrant = disk.iter().filter(|p| p.x < 0.0 && p.y > 0.0).count() as f64 / n as f64;
        let se = (0.25 * 0.75 / n as f64).sqrt();
        assert!(near(inner, 0.25, se) && near(quadrant, 0.25, se), "{inner} {quadrant}");
    }

    #[test]
    fn cosine_directions_around_a_normal() {
        let mut rng = Pcg::new(42, 1);
        let normal = Vec3::new(-0.3, 0.8, 0.2).normalize();
        let n = 200_000;
        let cosines: Vec<f64> = (0..n)
            .map(|_| {
                let d = rng.cosine_around(normal);
                assert!((d.length() - 1.0).abs() < 1e-4);
                d.dot(normal) as f64
            })
            .collect();
        assert!(cosines.iter().all(|&c| c >= -1e-6));
        // Under pdf cos θ / π: P(cos θ > c) = 1 - c², E[cos θ] = 2/3 (variance 1/18).
        let above = cosines.iter().filter(|&&c| c > 0.5).count() as f64 / n as f64;
        assert!(near(above, 0.75, (0.75 * 0.25 / n as f64).sqrt()), "{above}");
        let mean = cosines.iter().sum::<f64>() / n as f64;
        assert!(near(mean, 2.0 / 3.0, (1.0 / 18.0 / n as f64).sqrt()), "{mean}");
    }

    /// Mean and standard error of `n` samples of `f`.
    fn estimate(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
        let (mut sum, mut sum_sq) = (0.0, 0.0);
        for _ in 0..n {
            let x = f();
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / n as f64;
        (mean, ((sum_sq / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }

    #[test]
    fn ggx_vndf_samples_follow_their_pdf() {
        for &(alpha, vz) in &[(0.2f32, 0.9f32), (0.5, 0.5), (0.9, 0.2)] {
            let v = Vec3::new(sqrt(1.0 - vz * vz), 0.0, vz);
            let mut rng = Pcg::new(3, (alpha * 100.0) as u32);
            // Uniform directions on the hemisphere (pdf 1 / 2π) integrate the pdf.
            let mut uniform = || {
                let z = rng.next_f32();
                let r = sqrt(1.0 - z * z);
                let (s, c) = sin_cos(2.0 * PI * rng.next_f32());
                Vec3::new(r * c, r * s, z)
            };
            let n = 400_000;
            let mut pairs = Vec::with_capacity(n);
            for _ in 0..n {
                let h = uniform();
                pairs.push((h, ggx_vndf_pdf(v, h, alpha) as f64 * 2.0 * PI as f64));
            }
            let mut it = pairs.iter();
            let (total, se_total) = estimate(n, || it.next().map_or(0.0, |p| p.1));
            assert!((total - 1.0).abs() < 5.0 * se_total, "alpha {alpha}: ∫pdf = {total} ± {se_total}");
            // E[h.z] under the sampler against ∫ h.z pdf(h) dω.
            let mut it = pairs.iter();
            let (want, se_want) = estimate(n, || it.next().map_or(0.0, |p| p.0.z as f64 * p.1));
            let mut rng2 = Pcg::new(4, (alpha * 100.0) as u32);
            let (got, se_got) = estimate(n, || {
                let h = ggx_sample_vndf(v, alpha, rng2.next_f32(), rng2.next_f32());
                assert!(h.z >= 0.0 && (h.length() - 1.0).abs() < 1e-3 && v.dot(h) >= -1e-4);
                h.z as f64
            });
            let se = (se_want * se_want + se_got * se_got).sqrt();
            assert!((got - want).abs() < 5.0 * se, "alpha {alpha}: E[h.z] = {got}, pdf says {want} (SE {se})");
        }
    }

    #[test]
    fn normals_follow_the_inverse_transpose() {
        // Object-to-world: scale x by 2. Its inverse scales x by 1/2; a normal (1,1,0)
        // becomes (1/2, 1, 0) normalised.
        let w2o = Matrix4x3 {
            x_axis: Vec3::new(0.5, 0.0, 0.0),
            y_axis: Vec3::new(0.0, 1.0, 0.0),
            z_axis: Vec3::new(0.0, 0.0, 1.0),
            w_axis: Vec3::ZERO,
        };
        let n = transform_normal_to_world(&w2o, Vec3::new(1.0, 1.0, 0.0));
        assert!((n - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-6 && power_heuristic(0.0, 0.0) == 0.0);
    }
}
