//! The `materials` suite: the two material modes of `gltf_pathtracer`
//! (`MaterialMode::Callables`: one closest-hit calling direct callables by the
//! index in its record; `MaterialMode::Inlined`: one closest-hit per material in
//! its own hit group) on one generated glTF scene of 16 quads with 16 materials
//! (8 procedural material programs), side by side: primary rays per second
//! (GPU timestamps when the device has them) and pipeline link time without a
//! compile cache, each alternating between the modes, with the ratios
//! callables / inlined.

use gltf_pathtracer::{GpuScene, MaterialMode, MaterialRenderer};
use raykit::{Context, ContextOptions, LaunchTimer, PipelineCacheLocation};
use raykit_scene::gltf::GltfScene;
use raykit_scene::Camera;

use crate::stats::Summary;
use crate::trace::Options;

/// Runs the suite; returns its markdown and JSON.
pub fn run(ctx: &Context, timer: Option<&LaunchTimer>, opts: &Options) -> anyhow::Result<(String, serde_json::Value)> {
    let dir = std::env::temp_dir().join(format!("raykit-bench-materials-{}", std::process::id()));
    let path = gltf_pathtracer::demo_scene::write_grid(&dir, 16)?;
    let scene = GltfScene::load(&path)?;
    let _ = std::fs::remove_dir_all(&dir);
    let camera = Camera {
        eye: raykit::glam::Vec3::new(0.0, 0.0, 2.2),
        look_at: raykit::glam::Vec3::ZERO,
        up: raykit::glam::Vec3::Y,
        fov_y_degrees: 60.0,
    };
    let modes = [MaterialMode::Callables, MaterialMode::Inlined];
    let size = opts.primary_size;
    let rays = size.0 as f64 * size.1 as f64;

    // Link times on a context without a compile cache, so each link compiles.
    let cold = Context::new(ContextOptions {
        validation: Some(false),
        pipeline_cache: PipelineCacheLocation::Off,
        ..Default::default()
    })?;
    let cold_scene = GpuScene::new(&cold, &scene)?;
    let mut link = [Vec::new(), Vec::new()];
    for _ in 0..opts.reps.max(3) {
        for (k, &mode) in modes.iter().enumerate() {
            link[k].push(MaterialRenderer::new(&cold, &cold_scene, mode)?.link_time.as_secs_f64() * 1e3);
        }
    }

    let gpu = GpuScene::new(ctx, &scene)?;
    let renderers = [MaterialRenderer::new(ctx, &gpu, modes[0])?, MaterialRenderer::new(ctx, &gpu, modes[1])?];
    for r in &renderers {
        r.time_launch(ctx, &gpu, &camera, size, timer)?; // warm-up
    }
    let mut mrays = [Vec::new(), Vec::new()];
    for _ in 0..opts.reps.max(3) {
        for (k, r) in renderers.iter().enumerate() {
            mrays[k].push(rays / r.time_launch(ctx, &gpu, &camera, size, timer)?.as_secs_f64() / 1e6);
        }
    }
    let [lc, li] = [Summary::of(&link[0]), Summary::of(&link[1])];
    let [mc, mi] = [Summary::of(&mrays[0]), Summary::of(&mrays[1])];
    let clock = if timer.is_some() { "GPU timestamps" } else { "wall clock" };
    let md = format!(
        "## materials: callables vs inlined ({} materials, {}×{} primary rays, {clock}, median of {} alternating runs)\n\n\
         | mode | Mrays/s | pipeline link (ms, no cache) |\n| --- | --- | --- |\n\
         | callables (1 closest-hit + 8 direct callables) | {:.2} (±{:.1}%) | {:.2} |\n\
         | inlined (8 closest-hits, 8 hit groups) | {:.2} (±{:.1}%) | {:.2} |\n\
         | ratio callables / inlined | {:.3} | {:.3} |\n\n",
        scene.materials.len() - 1,
        size.0,
        size.1,
        opts.reps.max(3),
        mc.median,
        mc.spread_percent(),
        lc.median,
        mi.median,
        mi.spread_percent(),
        li.median,
        mc.median / mi.median,
        lc.median / li.median,
    );
    let json = serde_json::json!({
        "callables": { "mrays_per_s": mc.json(), "link_ms": lc.json() },
        "inlined": { "mrays_per_s": mi.json(), "link_ms": li.json() },
        "ratio_mrays_callables_over_inlined": mc.median / mi.median,
        "ratio_link_callables_over_inlined": lc.median / li.median,
        "clock": clock,
    });
    Ok((md, json))
}
