//! optixTriangle rendered on the device against a CPU reference of the same scene.

use raykit_tests::{channel_distance, with_context, with_each_backend};
use triangle::BG_COLOR;
use triangle_device::make_color;

#[test]
fn triangle_matches_the_cpu_reference() -> anyhow::Result<()> {
    with_each_backend("triangle_matches_the_cpu_reference", |ctx, _| {
        let (width, height) = (320u32, 240u32);
        let pixels = triangle::render(ctx, width, height)?;
        assert_matches_the_cpu_reference(&pixels, width, height);
        Ok(())
    })
}

/// Every pixel against the CPU reference (see [`raykit_tests::check_triangle_picture`]).
fn assert_matches_the_cpu_reference(pixels: &[u32], width: u32, height: u32) {
    if let Err(e) = raykit_tests::check_triangle_picture(pixels, width, height) {
        panic!("{e}");
    }
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
