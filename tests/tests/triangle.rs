//! optixTriangle rendered on the device against a CPU reference of the same scene.

use raykit::glam::{UVec2, Vec2, Vec3};
use raykit_tests::{channel_distance, with_context};
use triangle::{BG_COLOR, VERTICES};
use triangle_device::{barycentric_color, camera_ray, make_color, Params};

/// `(t, (u, v))` of the hit of the ray with triangle `tri`.
fn intersect(origin: Vec3, dir: Vec3, tri: [Vec3; 3]) -> Option<(f32, Vec2)> {
    raykit_tests::ray_triangle(origin, dir, tri, 0.0, f32::INFINITY)
}

/// Distance of barycentrics `(u, v)` from the triangle's edges (negative outside).
fn edge_margin(origin: Vec3, dir: Vec3, tri: [Vec3; 3]) -> f32 {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    let s = origin - tri[0];
    let u = s.dot(p) / det;
    let v = dir.dot(s.cross(e1)) / det;
    u.min(v).min(1.0 - u - v)
}

#[test]
fn triangle_matches_the_cpu_reference() -> anyhow::Result<()> {
    with_context("triangle_matches_the_cpu_reference", |ctx| {
        let (width, height) = (320u32, 240u32);
        let pixels = triangle::render(ctx, width, height)?;
        assert_matches_the_cpu_reference(&pixels, width, height);
        Ok(())
    })
}

/// Every pixel against the CPU reference: the barycentric colour inside the
/// triangle (99.5% within 2/255), the miss record's colour outside.
fn assert_matches_the_cpu_reference(pixels: &[u32], width: u32, height: u32) {
    assert_eq!(pixels.len(), (width * height) as usize);

    let params: Params =
        triangle::params(width, height, raykit::Buffer::from_table_index(0), raykit::Traversable::NULL);
    let bg = make_color(BG_COLOR);
    let (mut bg_pixels, mut tri_pixels, mut tri_close) = (0usize, 0usize, 0usize);
    let mut bg_wrong = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let got = pixels[(y * width + x) as usize];
            let (origin, dir) = camera_ray(UVec2::new(x, y), UVec2::new(width, height), &params);
            match intersect(origin, dir, VERTICES) {
                Some((_, bary)) => {
                    tri_pixels += 1;
                    if channel_distance(got, make_color(barycentric_color(bary))) <= 2 {
                        tri_close += 1;
                    }
                }
                None => {
                    // Rays grazing an edge may legitimately go either way.
                    if edge_margin(origin, dir, VERTICES) < -1e-3 {
                        bg_pixels += 1;
                        if got != bg {
                            bg_wrong.push((x, y, got));
                        }
                    }
                }
            }
        }
    }
    let total = (width * height) as usize;
    assert!(tri_pixels > total / 10, "the triangle covers only {tri_pixels} of {total} pixels");
    assert!(bg_pixels > total / 10, "only {bg_pixels} background pixels");
    assert!(
        bg_wrong.is_empty(),
        "{} background pixels differ from bg_color {bg:#010x}, e.g. {:?}",
        bg_wrong.len(),
        &bg_wrong[..bg_wrong.len().min(5)]
    );
    let ratio = tri_close as f64 / tri_pixels as f64;
    assert!(ratio >= 0.995, "only {tri_close} of {tri_pixels} triangle pixels ({:.3}%) within 2/255", ratio * 100.0);
}

#[test]
fn wgsl_twin_matches_the_cpu_reference() -> anyhow::Result<()> {
    with_context("wgsl_twin_matches_the_cpu_reference", |ctx| {
        let (width, height) = (320u32, 240u32);
        let pixels = triangle::render_with(ctx, &triangle::Programs::wgsl(ctx)?, width, height)?;
        assert_matches_the_cpu_reference(&pixels, width, height);
        Ok(())
    })
}

/// A WGSL raygen program linked with the Rust miss and closest-hit programs.
#[test]
fn wgsl_raygen_with_rust_miss_and_closest_hit_matches_the_cpu_reference() -> anyhow::Result<()> {
    with_context("wgsl_raygen_with_rust_miss_and_closest_hit_matches_the_cpu_reference", |ctx| {
        let (width, height) = (160u32, 120u32);
        let wgsl = triangle::Programs::wgsl(ctx)?;
        let rust = triangle::Programs::rust(ctx)?;
        let mixed = triangle::Programs { raygen: wgsl.raygen, miss: rust.miss, hit: rust.hit };
        let pixels = triangle::render_with(ctx, &mixed, width, height)?;
        assert_matches_the_cpu_reference(&pixels, width, height);
        Ok(())
    })
}

#[test]
fn background_is_the_miss_records_colour_after_srgb_quantisation() {
    // (0.3, 0.1, 0.2) linear → sRGB 8-bit (149, 89, 124).
    assert_eq!(raykit_tests::rgba(make_color(BG_COLOR)), [149, 89, 124, 255]);
}

#[test]
fn glsl_twin_draws_the_same_picture() -> anyhow::Result<()> {
    with_context("glsl_twin_draws_the_same_picture", |ctx| {
        let (width, height) = (160u32, 120u32);
        let glsl = triangle::render_with(ctx, &triangle::Programs::glsl(ctx)?, width, height)?;
        let rust = triangle::render(ctx, width, height)?;
        let differing = glsl.iter().zip(&rust).filter(|(a, b)| channel_distance(**a, **b) > 1).count();
        assert!(
            differing <= (width * height / 1000) as usize,
            "{differing} pixels differ between the GLSL and Rust programs"
        );
        assert!(glsl.iter().any(|&p| p != make_color(BG_COLOR)), "the GLSL picture is all background");
        Ok(())
    })
}

#[test]
fn glsl_twin_alone_matches_background() -> anyhow::Result<()> {
    with_context("glsl_twin_alone_matches_background", |ctx| {
        let pixels = triangle::render_with(ctx, &triangle::Programs::glsl(ctx)?, 64, 48)?;
        // The corners are background.
        for p in [pixels[0], pixels[63], pixels[64 * 47]] {
            assert_eq!(p, make_color(BG_COLOR));
        }
        // The centre column just above the bottom edge is inside the triangle.
        let centre = pixels[(30 * 64 + 32) as usize];
        assert_ne!(centre, make_color(BG_COLOR));
        Ok(())
    })
}
