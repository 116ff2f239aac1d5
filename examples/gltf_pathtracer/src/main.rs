//! `cargo run --release -p gltf_pathtracer -- --scene FILE.gltf [--env FILE.exr] [--width W] [--height H]
//! [--spp N] [--max-depth N] [--no-light-sampling] [--materials callables|inlined] [--backend vulkan|cpu]
//! [--denoise [--denoise-device auto|cpu|cuda] [--no-guides]] [-o FILE.png]`: path-traces a glTF scene lit by its emissive triangles and an environment map (an
//! OpenEXR equirectangular map, or a procedural sky), progressively with a progress bar, to a tonemapped
//! PNG and the linear radiance as OpenEXR beside it. `--view` opens the interactive viewer on the scene
//! instead (`raykit-viewer`), and `--headless --frames N [--camera ...]` writes what its window would show.
//!
//! Build the shaders first (`cargo xtask build-shaders`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use clap::Parser;
use gltf_pathtracer::{default_sky, framing_camera, GpuScene, MaterialMode, MaterialRenderer, PathTracer};
use indicatif::{ProgressBar, ProgressStyle};
use raykit::glam::Vec3;
use raykit_scene::gltf::GltfScene;
use raykit_scene::EnvironmentMap;

/// Path-traces a glTF scene with raykit.
#[derive(Parser)]
#[command(name = "gltf_pathtracer", about = "glTF 2.0 path tracer on raykit")]
struct Cli {
    /// The glTF file (.gltf with its buffers and images, or .glb).
    #[arg(long)]
    scene: PathBuf,
    /// An equirectangular OpenEXR environment map (default: a procedural sky).
    #[arg(long)]
    env: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Paths per pixel in all.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Paths per pixel per launch.
    #[arg(long, default_value_t = 4)]
    spp_per_launch: u32,
    /// Safety cap on bounces (Russian roulette ends paths).
    #[arg(long, default_value_t = 1024)]
    max_depth: u32,
    /// Find emissive surfaces by BSDF sampling alone (no light sampling of emissive triangles).
    #[arg(long)]
    no_light_sampling: bool,
    /// Instead of path tracing, render the eight procedural materials (glTF material `m` shaded by
    /// material `m % 8`) at the primary hits, as direct callables or inlined closest-hit programs.
    #[arg(long, value_parser = ["callables", "inlined"])]
    materials: Option<String>,
    /// The tonemapped PNG; the linear radiance goes to the same path with `.exr`.
    #[arg(long, short, default_value = "gltf.png")]
    output: PathBuf,
    /// Where the device programs run: `vulkan` (a GPU, or lavapipe) or `cpu`
    /// (the Rust programs natively on this machine's CPUs). Default: the
    /// `RAYKIT_BACKEND` environment variable, else `vulkan`.
    #[arg(long, value_parser = ["vulkan", "cpu"])]
    backend: Option<String>,
    /// `--denoise`, `--denoise-device`, `--no-guides`.
    #[command(flatten)]
    denoise: raykit_denoise::DenoiseArgs,
    #[command(flatten)]
    viewer: raykit_viewer::ViewerArgs,
}

fn load_env(path: &std::path::Path) -> anyhow::Result<EnvironmentMap> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .with_context(|| format!("reading {}", path.display()))?;
    let size = image.layer_data.size;
    let (_, radiance) = image.layer_data.channel_data.pixels;
    Ok(EnvironmentMap::new(size.width() as u32, size.height() as u32, radiance)?)
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    anyhow::ensure!(cli.width > 0 && cli.height > 0, "--width and --height must be at least 1");
    anyhow::ensure!(cli.spp > 0 && cli.spp_per_launch > 0, "--spp and --spp-per-launch must be at least 1");
    let scene = GltfScene::load(&cli.scene)?;
    let env = match &cli.env {
        Some(path) => load_env(path)?,
        None => default_sky(256, 128)?,
    };
    let backend =
        cli.backend.as_deref().map(|b| if b == "cpu" { raykit::Backend::Cpu } else { raykit::Backend::Vulkan });
    let ctx = raykit::Context::new(raykit::ContextOptions { backend, ..Default::default() })?;
    let camera = framing_camera(&scene);
    if cli.viewer.wanted() {
        return view(&cli, &ctx, &scene, &env, camera);
    }
    let gpu = GpuScene::new(&ctx, &scene)?;
    if let Some(mode) = &cli.materials {
        let mode = if mode == "callables" { MaterialMode::Callables } else { MaterialMode::Inlined };
        let renderer = MaterialRenderer::new(&ctx, &gpu, mode)?;
        let (_, colors) = renderer.render(&ctx, &gpu, &camera, cli.width, cli.height)?;
        let pixels: Vec<u32> = colors.iter().map(|c| raykit::device::color::pack_srgb8(c.truncate())).collect();
        raykit_scene::write_png_rgba8(&cli.output, cli.width, cli.height, &pixels)?;
        println!("{mode:?}: linked in {:?}, wrote {}", renderer.link_time, cli.output.display());
        return Ok(());
    }
    anyhow::ensure!(
        cli.materials.is_none() || !cli.denoise.denoise,
        "--denoise is for the path tracer: drop --materials"
    );
    // Loaded before rendering: a missing library fails at once, naming its install command.
    let denoiser = cli.denoise.denoiser()?;
    let mut tracer = PathTracer::new(&ctx, &gpu, &env, &camera, cli.width, cli.height)?;
    tracer.set_max_depth(cli.max_depth);
    tracer.set_light_sampling(!cli.no_light_sampling);
    if cli.denoise.guides() {
        tracer.enable_guides(&ctx)?;
    }
    let bar = ProgressBar::new(cli.spp as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} spp  {msg}")
            .context("progress bar template")?,
    );
    let started = Instant::now();
    while tracer.samples_done() < cli.spp {
        tracer.launch(cli.spp_per_launch.min(cli.spp - tracer.samples_done()))?;
        let (_, rays) = tracer.image()?;
        bar.set_message(format!("{:.2} Mrays/s", rays as f64 / started.elapsed().as_secs_f64() / 1e6));
        bar.set_position(tracer.samples_done() as u64);
    }
    bar.finish();
    let seconds = started.elapsed().as_secs_f64();
    let (mut radiance, rays) = tracer.image()?;
    if let Some(denoiser) = &denoiser {
        radiance = denoise(&cli, denoiser, &tracer, radiance)?;
    }
    let pixels: Vec<u32> = radiance.iter().map(|&c| path_tracer_tonemap(c)).collect();
    raykit_scene::write_png_rgba8(&cli.output, cli.width, cli.height, &pixels)?;
    let exr = cli.output.with_extension("exr");
    raykit_scene::write_exr(&exr, cli.width, cli.height, &radiance)?;
    println!(
        "rendered {}x{} at {} spp on {} in {seconds:.2} s ({rays} rays, {:.2} Mrays/s) to {} and {}",
        cli.width,
        cli.height,
        cli.spp,
        ctx.device_name(),
        rays as f64 / seconds / 1e6,
        cli.output.display(),
        exr.display()
    );
    Ok(())
}

/// Writes `radiance` to `<output>-noisy.png` and returns it denoised by
/// `denoiser`, guided by the tracer's guides when it wrote them.
fn denoise(
    cli: &Cli,
    denoiser: &raykit_denoise::Denoiser,
    tracer: &PathTracer,
    radiance: Vec<Vec3>,
) -> anyhow::Result<Vec<Vec3>> {
    let stem = cli.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let noisy = cli.output.with_file_name(format!("{stem}-noisy.png"));
    let pixels: Vec<u32> = radiance.iter().map(|&c| path_tracer_tonemap(c)).collect();
    raykit_scene::write_png_rgba8(&noisy, cli.width, cli.height, &pixels)?;
    let rgb = |v: &[Vec3]| v.iter().map(|c| c.to_array()).collect::<Vec<_>>();
    let color = rgb(&radiance);
    let guides = tracer.guides()?.map(|g| (rgb(&g.albedo), rgb(&g.normal)));
    let mut input = raykit_denoise::Input::new(cli.width, cli.height, &color);
    if let Some((albedo, normal)) = &guides {
        input = input.with_guides(albedo, normal);
    }
    let started = Instant::now();
    let denoised = denoiser.denoise(&input)?;
    println!(
        "denoised on OIDN's {} device in {:.3} s ({}); the noisy input is {}",
        denoiser.device(),
        started.elapsed().as_secs_f64(),
        if guides.is_some() { "with first-hit albedo and normal guides" } else { "without guides" },
        noisy.display()
    );
    Ok(denoised.into_iter().map(Vec3::from_array).collect())
}

/// `--view` and `--headless`: the scene in the viewer's window, or what the window
/// would show written to `--output`.
fn view(
    cli: &Cli,
    ctx: &raykit::Context,
    scene: &GltfScene,
    env: &EnvironmentMap,
    camera: raykit_scene::Camera,
) -> anyhow::Result<()> {
    let mut renderer = gltf_pathtracer::view::ViewRenderer::new(ctx, scene, env, &camera)?;
    renderer.tracer_mut().set_max_depth(cli.max_depth);
    renderer.tracer_mut().set_light_sampling(!cli.no_light_sampling);
    let session = raykit_viewer::Session {
        title: format!("raykit gltf_pathtracer: {}", cli.scene.display()),
        width: cli.width,
        height: cli.height,
        camera,
        exposure: 1.0,
        output: cli.output.clone(),
        denoise: cli.denoise.clone(),
    };
    raykit_viewer::run(renderer, &cli.viewer, session)?;
    Ok(())
}

/// Reinhard per channel, then sRGB, packed as RGBA8.
fn path_tracer_tonemap(c: Vec3) -> u32 {
    let c = c.max(Vec3::ZERO);
    raykit::device::color::pack_srgb8(c / (Vec3::ONE + c))
}
