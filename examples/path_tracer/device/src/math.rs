//! The path tracer's math, shared by the device programs and the host (the CPU
//! reference of the tests): the Lambertian BRDF, the area light, the camera ray,
//! and one path's state machine ([`PathState`]). Random numbers (optixPathTracer's
//! `tea` seeds and `lcg` stream), the orthonormal basis and cosine-weighted
//! hemisphere sampling come from [`raykit_device::sampling`], the sRGB transfer
//! from [`raykit_device::color`].
//!
//! Everything here compiles for SPIR-V (rust-gpu) and for the host. Integer
//! arithmetic wraps explicitly, so the host's debug builds compute the same bits
//! as the device.

pub use raykit_device::color::linear_to_srgb;
use raykit_device::glam::{UVec2, Vec3};
pub use raykit_device::sampling::{cosine_sample_hemisphere, tea4, Lcg, Onb, PI};

/// `t_min` of every ray and the gap left before the light on shadow rays
/// (optixPathTracer's 0.01, in the scene's millimetres).
pub const RAY_EPSILON: f32 = 0.01;

/// Bounces after which Russian roulette may end a path. Roulette alone ends
/// paths (an unbiased estimate); [`crate::scene::MAX_DEPTH`] is only a safety cap.
pub const ROULETTE_AFTER: u32 = 2;

/// The largest survival probability of Russian roulette.
pub const ROULETTE_MAX_SURVIVAL: f32 = 0.95;

/// The random stream of pixel `pixel` (linear index) in launch `subframe`
/// (optixPathTracer: `tea<4>(idx.y * w + idx.x, subframe_index)` seeding `lcg`).
pub fn pixel_seed(pixel: u32, subframe: u32) -> Lcg {
    Lcg::new(tea4(pixel, subframe))
}

/// The Lambertian BRDF, `albedo / π`.
pub fn lambert_brdf(albedo: Vec3) -> Vec3 {
    albedo * (1.0 / PI)
}

/// `n` flipped to face against the incoming direction `d`.
pub fn face_forward(n: Vec3, d: Vec3) -> Vec3 {
    if n.dot(d) > 0.0 {
        -n
    } else {
        n
    }
}

/// The parallelogram light: `corner + u·v1 + v·v2`, emitting `emission` from
/// the side of `v1 × v2` (optixPathTracer's `ParallelogramLight`).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Light {
    /// One corner.
    pub corner: Vec3,
    /// First edge.
    pub v1: Vec3,
    /// Second edge.
    pub v2: Vec3,
    /// Emitted radiance.
    pub emission: Vec3,
}

impl Light {
    /// The point at `(u, v) ∈ [0,1)²`.
    pub fn point(&self, u: f32, v: f32) -> Vec3 {
        self.corner + u * self.v1 + v * self.v2
    }
    /// The emitting side's unit normal.
    pub fn normal(&self) -> Vec3 {
        self.v1.cross(self.v2).normalize()
    }
    /// The area.
    pub fn area(&self) -> f32 {
        self.v1.cross(self.v2).length()
    }
}

/// A pinhole camera: the eye and the image-plane basis (`u`, `v` scaled to half
/// the plane, `w` from the eye to its centre), as sutil's `Camera::UVWFrame`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraFrame {
    /// Eye position.
    pub eye: Vec3,
    /// Right, scaled to half the image-plane width.
    pub u: Vec3,
    /// Up, scaled to half the image-plane height.
    pub v: Vec3,
    /// Forward, to the image-plane centre.
    pub w: Vec3,
}

impl CameraFrame {
    /// The ray through pixel `index` of a `dims` image, jittered by `jitter ∈
    /// [0,1)²` inside the pixel; row 0 is the top row. Returns the direction
    /// (normalised); the origin is the eye.
    pub fn direction(&self, index: UVec2, dims: UVec2, jx: f32, jy: f32) -> Vec3 {
        let dx = 2.0 * (index.x as f32 + jx) / dims.x as f32 - 1.0;
        let dy = 1.0 - 2.0 * (index.y as f32 + jy) / dims.y as f32;
        (dx * self.u + dy * self.v + self.w).normalize()
    }
}

/// What the closest-hit program tells raygen about a hit (the radiance ray's
/// payload): `t < 0` is a miss.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct HitInfo {
    /// Unit geometric normal, facing the incoming ray.
    pub normal: Vec3,
    /// Hit distance; negative for a miss.
    pub t: f32,
    /// Emitted radiance of the surface.
    pub emission: Vec3,
    /// Diffuse reflectance.
    pub albedo: Vec3,
}

impl HitInfo {
    /// The miss value.
    pub const MISS: HitInfo = HitInfo { normal: Vec3::ZERO, t: -1.0, emission: Vec3::ZERO, albedo: Vec3::ZERO };
}

/// A shadow ray that [`PathState::shade`] asks for, and what its path gains
/// when the light is visible.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ShadowRay {
    /// Origin (the shaded point).
    pub origin: Vec3,
    /// Unit direction to the light sample.
    pub direction: Vec3,
    /// Distance to the light sample, less [`RAY_EPSILON`].
    pub t_max: f32,
    /// Radiance added when the sample is visible; the ray is only traced when this
    /// is non-zero (the light faces the point and the point faces the light).
    pub contribution: Vec3,
}

/// One path, written as a state machine so the device (tracing with
/// `OpTraceRayKHR` from raygen) and the CPU reference (tracing with its own
/// intersection) run the same code between traces:
///
/// ```text
/// state = PathState::camera(...)
/// while !state.done {
///     hit = trace(state.origin, state.direction)         // radiance ray
///     shadow = state.shade(hit, light, seed, max_depth)  // emission, NEE, bounce, roulette
///     if shadow.contribution != 0 && visible(shadow) { state.radiance += shadow.contribution }
/// }
/// ```
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PathState {
    /// Origin of the next ray.
    pub origin: Vec3,
    /// Unit direction of the next ray.
    pub direction: Vec3,
    /// Product of the BRDF · cos / pdf factors so far.
    pub throughput: Vec3,
    /// Radiance gathered so far.
    pub radiance: Vec3,
    /// Bounces so far (0 for the camera ray).
    pub depth: u32,
    /// Whether the path has ended.
    pub done: bool,
}

impl PathState {
    /// The camera ray of pixel `index`, jittered with two numbers from `seed`.
    pub fn camera(camera: &CameraFrame, index: UVec2, dims: UVec2, seed: &mut Lcg) -> PathState {
        let jx = seed.next_f32();
        let jy = seed.next_f32();
        PathState {
            origin: camera.eye,
            direction: camera.direction(index, dims, jx, jy),
            throughput: Vec3::ONE,
            radiance: Vec3::ZERO,
            depth: 0,
            done: false,
        }
    }

    /// Handles the radiance ray's result: counts emission seen by the camera ray,
    /// samples the light (next-event estimation, returned as a shadow ray to
    /// trace), picks the next direction (cosine-weighted) and plays Russian
    /// roulette. Uses five numbers from `seed` per hit.
    pub fn shade(&mut self, hit: &HitInfo, light: &Light, seed: &mut Lcg, max_depth: u32) -> ShadowRay {
        let mut shadow = ShadowRay { origin: Vec3::ZERO, direction: Vec3::Z, t_max: 0.0, contribution: Vec3::ZERO };
        if hit.t < 0.0 {
            self.done = true;
            return shadow;
        }
        let p = self.origin + hit.t * self.direction;
        let n = hit.normal;
        if self.depth == 0 {
            // Light reached directly from the camera; later bounces count the light
            // through next-event estimation only.
            self.radiance += self.throughput * hit.emission;
        }

        // Next-event estimation: one point on the light.
        let light_point = light.point(seed.next_f32(), seed.next_f32());
        let to_light = light_point - p;
        let distance = to_light.length();
        let l = to_light / distance;
        let n_dot_l = n.dot(l);
        let ln_dot_l = -light.normal().dot(l);
        shadow.origin = p;
        shadow.direction = l;
        shadow.t_max = distance - RAY_EPSILON;
        if n_dot_l > 0.0 && ln_dot_l > 0.0 {
            // BRDF · Le · cos θ · cos θ' / d² / pdf(area) with pdf = 1 / area.
            let geometry = n_dot_l * ln_dot_l * light.area() / (distance * distance);
            shadow.contribution = self.throughput * lambert_brdf(hit.albedo) * light.emission * geometry;
        }

        // Bounce: cosine-weighted sampling makes BRDF · cos / pdf = albedo.
        let local = cosine_sample_hemisphere(seed.next_f32(), seed.next_f32());
        self.origin = p;
        self.direction = Onb::new(n).to_world(local);
        self.throughput *= hit.albedo;
        self.depth += 1;

        let survive = seed.next_f32();
        if self.depth >= max_depth {
            self.done = true;
        } else if self.depth > ROULETTE_AFTER {
            let q = self.throughput.max_element().min(ROULETTE_MAX_SURVIVAL);
            if survive >= q {
                self.done = true;
            } else {
                self.throughput /= q;
            }
        }
        shadow
    }
}

/// The tonemap of the PNG: exposure, Reinhard on each channel, sRGB, 8 bits,
/// packed as RGBA8 (red in the lowest byte).
pub fn tonemap(c: Vec3, exposure: f32) -> u32 {
    let q = |v: f32| -> u32 {
        let v = (v * exposure).max(0.0);
        raykit_device::color::srgb8(v / (1.0 + v))
    };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn pixel_streams_are_deterministic_and_spread() {
        assert_eq!(pixel_seed(12, 3), pixel_seed(12, 3));
        assert_ne!(pixel_seed(12, 3), pixel_seed(13, 3));
        assert_ne!(pixel_seed(12, 3), pixel_seed(12, 4));
        let mut seed = pixel_seed(5, 0);
        let mean = (0..10_000).map(|_| seed.next_f32() as f64).sum::<f64>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
    }

    #[test]
    fn a_miss_ends_the_path_without_light() {
        let mut state = PathState {
            origin: Vec3::ZERO,
            direction: Vec3::Z,
            throughput: Vec3::ONE,
            radiance: Vec3::ZERO,
            depth: 0,
            done: false,
        };
        let light = Light { corner: Vec3::Y, v1: Vec3::X, v2: Vec3::Z, emission: Vec3::ONE };
        let mut seed = Lcg::new(1);
        let shadow = state.shade(&HitInfo::MISS, &light, &mut seed, 8);
        assert!(state.done && state.radiance == Vec3::ZERO && shadow.contribution == Vec3::ZERO);
    }
}
