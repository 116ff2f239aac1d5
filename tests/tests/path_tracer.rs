//! The path tracer against a CPU reference.
//!
//! The reference runs the same shared code as the device programs
//! (`path_tracer_device::math`: random numbers, camera, next-event estimation,
//! bounce, Russian roulette) with a CPU ray–scene intersection (Möller–Trumbore
//! over the Cornell box's 32 triangles), and the same per-pixel random sequences
//! (seeded by pixel and launch index). Most paths are then identical; paths that
//! part ways — a ray grazing an edge, float differences between the driver's
//! intersection and ours — are what the tolerance is for: each 8×8 block's mean
//! radiance, per channel, must lie within 3 standard errors of the reference's,
//! the standard error estimated from the reference's per-pixel sample variance
//! as for two independent estimates. Being seeded alike, the test is
//! deterministic, not a coin toss over 192 comparisons.

use path_tracer::device::math::{face_forward, HitInfo, PathState, RAY_EPSILON};
use path_tracer::device::scene::{self, MATERIALS, VERTICES};
use path_tracer::{camera_frame, triangle_normals, Image, Programs, Renderer, Scene};
use raykit::glam::{UVec2, Vec3};
use raykit::{Backend, Context};
use raykit_tests::with_each_backend;

const SIZE: u32 = 64;
const BLOCK: u32 = 8;
/// Paths per pixel, and per launch (so the accumulation over launches is tested too).
const SPP: u32 = 64;
const SPP_PER_LAUNCH: u32 = 16;

/// The distance to triangle `tri` along the ray, if in `(t_min, t_max)`.
fn hit_triangle(origin: Vec3, dir: Vec3, tri: &[Vec3], t_min: f32, t_max: f32) -> Option<f32> {
    raykit_tests::ray_triangle(origin, dir, [tri[0], tri[1], tri[2]], t_min, t_max).map(|(t, _)| t)
}

/// The CPU scene: closest hit (what closest-hit + miss report) and visibility.
struct CpuScene {
    normals: Vec<Vec3>,
    material_of: Vec<usize>,
}

impl CpuScene {
    fn new() -> CpuScene {
        let mut material_of = Vec::new();
        for (m, group) in MATERIALS.iter().enumerate() {
            material_of.extend(std::iter::repeat_n(m, group.triangles as usize));
        }
        CpuScene { normals: triangle_normals(), material_of }
    }

    fn closest(&self, origin: Vec3, dir: Vec3) -> HitInfo {
        let mut best: Option<(f32, usize)> = None;
        for (i, tri) in VERTICES.chunks_exact(3).enumerate() {
            let t_max = best.map_or(1e16, |(t, _)| t);
            if let Some(t) = hit_triangle(origin, dir, tri, RAY_EPSILON, t_max) {
                best = Some((t, i));
            }
        }
        match best {
            None => HitInfo::MISS,
            Some((t, i)) => {
                let m = MATERIALS[self.material_of[i]];
                HitInfo { normal: face_forward(self.normals[i], dir), t, emission: m.emission, albedo: m.albedo }
            }
        }
    }

    fn visible(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        !VERTICES.chunks_exact(3).any(|tri| hit_triangle(origin, dir, tri, RAY_EPSILON, t_max).is_some())
    }
}

/// The reference: per pixel, the mean radiance and the sample variance of one
/// path's radiance; and the rays traced.
struct Reference {
    mean: Vec<Vec3>,
    variance: Vec<Vec3>,
    rays: u64,
}

fn cpu_reference() -> Reference {
    let scene = CpuScene::new();
    let camera = camera_frame(1.0);
    let light = scene::LIGHT;
    let dims = UVec2::splat(SIZE);
    let (mut mean, mut variance, mut rays) = (Vec::new(), Vec::new(), 0u64);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let pixel = y * SIZE + x;
            let (mut sum, mut sum_sq) = (Vec3::ZERO, Vec3::ZERO);
            for launch in 0..SPP / SPP_PER_LAUNCH {
                let mut seed = path_tracer::device::math::pixel_seed(pixel, launch);
                for _ in 0..SPP_PER_LAUNCH {
                    let mut state = PathState::camera(&camera, UVec2::new(x, y), dims, &mut seed);
                    while !state.done {
                        let hit = scene.closest(state.origin, state.direction);
                        rays += 1;
                        let shadow = state.shade(&hit, &light, &mut seed, scene::MAX_DEPTH);
                        if shadow.contribution != Vec3::ZERO {
                            rays += 1;
                            if scene.visible(shadow.origin, shadow.direction, shadow.t_max) {
                                state.radiance += shadow.contribution;
                            }
                        }
                    }
                    sum += state.radiance;
                    sum_sq += state.radiance * state.radiance;
                }
            }
            let n = SPP as f32;
            let m = sum / n;
            mean.push(m);
            variance.push(((sum_sq / n - m * m) * n / (n - 1.0)).max(Vec3::ZERO));
        }
    }
    Reference { mean, variance, rays }
}

/// Renders with `programs`; checks finiteness and every block against `reference`.
fn render_and_compare(ctx: &Context, programs: &Programs, reference: &Reference, what: &str) -> anyhow::Result<()> {
    let scene = Scene::new(ctx)?;
    let mut renderer = Renderer::new(ctx, programs, &scene, SIZE, SIZE)?;
    for _ in 0..SPP / SPP_PER_LAUNCH {
        renderer.launch(SPP_PER_LAUNCH)?;
    }
    let image: Image = renderer.image()?;
    let bad = image.radiance.iter().filter(|c| !c.is_finite()).count();
    anyhow::ensure!(bad == 0, "{what}: {bad} pixels are NaN or infinite");

    let mut failures = Vec::new();
    let mut worst = 0.0f32;
    let pixels = (BLOCK * BLOCK) as f32;
    for by in 0..SIZE / BLOCK {
        for bx in 0..SIZE / BLOCK {
            let (mut got, mut want, mut var) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for y in by * BLOCK..(by + 1) * BLOCK {
                for x in bx * BLOCK..(bx + 1) * BLOCK {
                    let i = (y * SIZE + x) as usize;
                    got += image.radiance[i];
                    want += reference.mean[i];
                    var += reference.variance[i];
                }
            }
            got /= pixels;
            want /= pixels;
            // Two estimates of SPP paths per pixel each: Var(mean_gpu - mean_cpu).
            let se = (var * (2.0 / SPP as f32) / (pixels * pixels)).powf(0.5);
            for (channel, (g, w, s)) in
                [(got.x, want.x, se.x), (got.y, want.y, se.y), (got.z, want.z, se.z)].into_iter().enumerate()
            {
                let allowed = 3.0 * s + 1e-6 * w.abs().max(1.0);
                let z = (g - w).abs() / allowed * 3.0;
                worst = worst.max(z);
                if (g - w).abs() > allowed {
                    failures.push(format!(
                        "block ({bx}, {by}) channel {channel}: {g} vs reference {w} (3 SE = {})",
                        3.0 * s
                    ));
                }
            }
        }
    }
    anyhow::ensure!(
        failures.is_empty(),
        "{what}: {} block means off the reference:\n{}",
        failures.len(),
        failures.join("\n")
    );
    // The image is not trivially black: the box is lit.
    let mean = image.radiance.iter().copied().sum::<Vec3>() / image.radiance.len() as f32;
    anyhow::ensure!(mean.min_element() > 0.02, "{what}: the image is too dark (mean {mean})");
    // The same paths: about as many rays.
    let ratio = image.rays as f64 / reference.rays as f64;
    anyhow::ensure!((ratio - 1.0).abs() < 0.02, "{what}: {} rays traced, the reference {}", image.rays, reference.rays);
    eprintln!("{what}: worst block {worst:.2} standard errors; {} rays (reference {})", image.rays, reference.rays);
    Ok(())
}

#[test]
fn the_path_tracer_matches_its_cpu_reference_block_by_block() -> anyhow::Result<()> {
    let reference = cpu_reference();
    with_each_backend("the_path_tracer_matches_its_cpu_reference_block_by_block", |ctx, backend| {
        render_and_compare(ctx, &Programs::rust(ctx)?, &reference, "Rust programs")?;
        // The twins are SPIR-V: Vulkan only.
        if backend == Backend::Vulkan {
            render_and_compare(ctx, &Programs::glsl(ctx)?, &reference, "GLSL twin")?;
            render_and_compare(ctx, &Programs::wgsl(ctx)?, &reference, "WGSL twin")?;
        }
        Ok(())
    })
}
