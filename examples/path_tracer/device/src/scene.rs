//! optixPathTracer's Cornell box: five walls, a short and a tall box and the
//! ceiling light, as 32 triangles in four material groups (white, green, red,
//! light), with its camera and its parallelogram light. Shared by the host (the
//! acceleration structure, the SBT records) and the CPU reference of the tests.

use raykit_device::glam::Vec3;

use crate::math::Light;

/// A material group: its triangles' first vertex and count in [`VERTICES`],
/// emission and diffuse reflectance.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MaterialGroup {
    /// Name, for messages.
    pub name: &'static str,
    /// First triangle of the group (index into [`VERTICES`] / 3).
    pub first_triangle: u32,
    /// Number of triangles.
    pub triangles: u32,
    /// Emitted radiance.
    pub emission: Vec3,
    /// Diffuse reflectance.
    pub albedo: Vec3,
}

const fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// The 32 triangles, three vertices each, in optixPathTracer's order — except
/// that the triangles are grouped by material (white: floor, ceiling, back wall,
/// both boxes; then green, red, light), so each group is one geometry of the GAS.
pub const VERTICES: [Vec3; 96] = [
    // Floor (white)
    v(0.0, 0.0, 0.0),
    v(0.0, 0.0, 559.2),
    v(556.0, 0.0, 559.2),
    v(0.0, 0.0, 0.0),
    v(556.0, 0.0, 559.2),
    v(556.0, 0.0, 0.0),
    // Ceiling (white)
    v(0.0, 548.8, 0.0),
    v(556.0, 548.8, 0.0),
    v(556.0, 548.8, 559.2),
    v(0.0, 548.8, 0.0),
    v(556.0, 548.8, 559.2),
    v(0.0, 548.8, 559.2),
    // Back wall (white)
    v(0.0, 0.0, 559.2),
    v(0.0, 548.8, 559.2),
    v(556.0, 548.8, 559.2),
    v(0.0, 0.0, 559.2),
    v(556.0, 548.8, 559.2),
    v(556.0, 0.0, 559.2),
    // Short block (white)
    v(130.0, 165.0, 65.0),
    v(82.0, 165.0, 225.0),
    v(242.0, 165.0, 274.0),
    v(130.0, 165.0, 65.0),
    v(242.0, 165.0, 274.0),
    v(290.0, 165.0, 114.0),
    v(290.0, 0.0, 114.0),
    v(290.0, 165.0, 114.0),
    v(240.0, 165.0, 272.0),
    v(290.0, 0.0, 114.0),
    v(240.0, 165.0, 272.0),
    v(240.0, 0.0, 272.0),
    v(130.0, 0.0, 65.0),
    v(130.0, 165.0, 65.0),
    v(290.0, 165.0, 114.0),
    v(130.0, 0.0, 65.0),
    v(290.0, 165.0, 114.0),
    v(290.0, 0.0, 114.0),
    v(82.0, 0.0, 225.0),
    v(82.0, 165.0, 225.0),
    v(130.0, 165.0, 65.0),
    v(82.0, 0.0, 225.0),
    v(130.0, 165.0, 65.0),
    v(130.0, 0.0, 65.0),
    v(240.0, 0.0, 272.0),
    v(240.0, 165.0, 272.0),
    v(82.0, 165.0, 225.0),
    v(240.0, 0.0, 272.0),
    v(82.0, 165.0, 225.0),
    v(82.0, 0.0, 225.0),
    // Tall block (white)
    v(423.0, 330.0, 247.0),
    v(265.0, 330.0, 296.0),
    v(314.0, 330.0, 455.0),
    v(423.0, 330.0, 247.0),
    v(314.0, 330.0, 455.0),
    v(472.0, 330.0, 406.0),
    v(423.0, 0.0, 247.0),
    v(423.0, 330.0, 247.0),
    v(472.0, 330.0, 406.0),
    v(423.0, 0.0, 247.0),
    v(472.0, 330.0, 406.0),
    v(472.0, 0.0, 406.0),
    v(472.0, 0.0, 406.0),
    v(472.0, 330.0, 406.0),
    v(314.0, 330.0, 456.0),
    v(472.0, 0.0, 406.0),
    v(314.0, 330.0, 456.0),
    v(314.0, 0.0, 456.0),
    v(314.0, 0.0, 456.0),
    v(314.0, 330.0, 456.0),
    v(265.0, 330.0, 296.0),
    v(314.0, 0.0, 456.0),
    v(265.0, 330.0, 296.0),
    v(265.0, 0.0, 296.0),
    v(265.0, 0.0, 296.0),
    v(265.0, 330.0, 296.0),
    v(423.0, 330.0, 247.0),
    v(265.0, 0.0, 296.0),
    v(423.0, 330.0, 247.0),
    v(423.0, 0.0, 247.0),
    // Right wall (green; x = 0 is on the image's right)
    v(0.0, 0.0, 0.0),
    v(0.0, 548.8, 0.0),
    v(0.0, 548.8, 559.2),
    v(0.0, 0.0, 0.0),
    v(0.0, 548.8, 559.2),
    v(0.0, 0.0, 559.2),
    // Left wall (red)
    v(556.0, 0.0, 0.0),
    v(556.0, 0.0, 559.2),
    v(556.0, 548.8, 559.2),
    v(556.0, 0.0, 0.0),
    v(556.0, 548.8, 559.2),
    v(556.0, 548.8, 0.0),
    // Ceiling light (emissive)
    v(343.0, 548.6, 227.0),
    v(213.0, 548.6, 227.0),
    v(213.0, 548.6, 332.0),
    v(343.0, 548.6, 227.0),
    v(213.0, 548.6, 332.0),
    v(343.0, 548.6, 332.0),
];

/// The material groups, in the order of [`VERTICES`] (and of the GAS's
/// geometries, so of the SBT's hit records).
pub const MATERIALS: [MaterialGroup; 4] = [
    MaterialGroup {
        name: "white",
        first_triangle: 0,
        triangles: 26,
        emission: Vec3::ZERO,
        albedo: v(0.80, 0.80, 0.80),
    },
    MaterialGroup {
        name: "green",
        first_triangle: 26,
        triangles: 2,
        emission: Vec3::ZERO,
        albedo: v(0.05, 0.80, 0.05),
    },
    MaterialGroup { name: "red", first_triangle: 28, triangles: 2, emission: Vec3::ZERO, albedo: v(0.80, 0.05, 0.05) },
    MaterialGroup {
        name: "light",
        first_triangle: 30,
        triangles: 2,
        emission: v(15.0, 15.0, 5.0),
        albedo: v(0.50, 0.0, 0.0),
    },
];

/// optixPathTracer's light: just below the ceiling light's quad, facing down.
pub const LIGHT: Light = Light {
    corner: v(343.0, 548.5, 227.0),
    v1: v(0.0, 0.0, 105.0),
    v2: v(-130.0, 0.0, 0.0),
    emission: v(15.0, 15.0, 5.0),
};

/// optixPathTracer's camera: eye, look-at point, up, vertical field of view (degrees).
pub const CAMERA_EYE: Vec3 = v(278.0, 273.0, -900.0);
/// The point the camera looks at.
pub const CAMERA_LOOK_AT: Vec3 = v(278.0, 273.0, 330.0);
/// The camera's up direction.
pub const CAMERA_UP: Vec3 = v(0.0, 1.0, 0.0);
/// Vertical field of view in degrees.
pub const CAMERA_FOV_Y: f32 = 35.0;

/// The safety cap on path length (bounces). Russian roulette ends paths (from
/// bounce [`crate::math::ROULETTE_AFTER`] on, surviving with probability
/// `min(max throughput, 0.95)`), so the estimate is unbiased; the cap only bounds
/// the work of one path. A path reaches it with probability below
/// 0.95^1021 ≈ 2·10⁻²³. (optixPathTracer stops every path after 8 bounces, which
/// leaves the Cornell box about 1% too dark.)
pub const MAX_DEPTH: u32 = 1024;
