//! `cargo run --release -p path_tracer -- [--width W] [--height H] [--spp N] [--max-depth N] [--exr] [--output FILE.png] [--watch]`:
//! renders optixPathTracer's Cornell box progressively, with a progress bar, to a
//! tonemapped PNG and the linear radiance as PFM next to it. With `--watch` it then
//! keeps running: each save of the device crate's sources rebuilds it, swaps the
//! pipeline and renders the picture again (a compile error is printed and the old
//! pipeline stays).
//!
//! Build the shaders first (`cargo xtask build-shaders`), or run `cargo xtask demo`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use path_tracer::{Programs, Renderer, Scene};

/// Renders the Cornell box with raykit's path tracer.
#[derive(Parser)]
#[command(name = "path_tracer", about = "optixPathTracer's Cornell box on raykit")]
struct Cli {
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Paths per pixel in all.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Paths per pixel per launch (the progress bar moves once per launch).
    #[arg(long, default_value_t = 4)]
    spp_per_launch: u32,
    /// The tonemapped PNG; the linear radiance goes to the same path with `.pfm`.
    #[arg(long, short, default_value = "path_tracer.png")]
    output: PathBuf,
    /// Safety cap on path length in bounces (Russian roulette ends paths; a
    /// small cap darkens the picture).
    #[arg(long, default_value_t = path_tracer::device::scene::MAX_DEPTH)]
    max_depth: u32,
    /// Also write the linear radiance as OpenEXR, to the output path with `.exr`.
    #[arg(long)]
    exr: bool,
    /// Exposure applied before the tonemap.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Use the GLSL twin of the device programs instead of the Rust ones.
    #[arg(long, conflicts_with = "wgsl")]
    glsl: bool,
    /// Use the WGSL twin of the device programs (compiled by naga at build time).
    #[arg(long)]
    wgsl: bool,
    /// Use the first ray-tracing device whose name contains this.
    #[arg(long)]
    device: Option<String>,
    /// Where the device programs run: `vulkan` (a GPU, or lavapipe) or `cpu`
    /// (the Rust programs natively on this machine's CPUs). Default: the
    /// `RAYKIT_BACKEND` environment variable, else `vulkan`.
    #[arg(long, value_parser = ["vulkan", "cpu"], conflicts_with_all = ["glsl", "wgsl", "watch"])]
    backend: Option<String>,
    /// After rendering, watch `examples/path_tracer/device` and render again
    /// after each change (hot reload), until interrupted.
    #[arg(long, conflicts_with_all = ["glsl", "wgsl"])]
    watch: bool,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    anyhow::ensure!(cli.width > 0 && cli.height > 0, "--width and --height must be at least 1");
    anyhow::ensure!(cli.spp > 0 && cli.spp_per_launch > 0, "--spp and --spp-per-launch must be at least 1");
    let backend =
        cli.backend.as_deref().map(|b| if b == "cpu" { raykit::Backend::Cpu } else { raykit::Backend::Vulkan });
    let ctx = raykit::Context::new(raykit::ContextOptions {
        device_name_contains: cli.device.clone(),
        backend,
        ..Default::default()
    })?;
    let programs = match (cli.glsl, cli.wgsl) {
        (true, _) => Programs::glsl(&ctx)?,
        (_, true) => Programs::wgsl(&ctx)?,
        _ => Programs::rust(&ctx)?,
    };
    let scene = Scene::new(&ctx)?;
    let mut renderer = Renderer::new(&ctx, &programs, &scene, cli.width, cli.height)?;
    anyhow::ensure!(cli.max_depth > 0, "--max-depth must be at least 1");
    renderer.set_max_depth(cli.max_depth);

    render(&cli, &ctx, &mut renderer)?;
    if cli.watch {
        watch(&cli, &ctx, &mut renderer)?;
    }
    Ok(())
}

/// Renders `cli.spp` paths per pixel with a progress bar and writes the pictures.
fn render(cli: &Cli, ctx: &raykit::Context, renderer: &mut Renderer) -> anyhow::Result<()> {
    let bar = ProgressBar::new(cli.spp as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} spp  {msg}")
            .context("progress bar template")?,
    );
    let started = Instant::now();
    while renderer.samples_done() < cli.spp {
        let samples = cli.spp_per_launch.min(cli.spp - renderer.samples_done());
        renderer.launch(samples)?;
        let rays = renderer.rays()?;
        let seconds = started.elapsed().as_secs_f64();
        bar.set_message(format!("{:.2} Mrays/s", rays as f64 / seconds / 1e6));
        bar.set_position(renderer.samples_done() as u64);
    }
    bar.finish();
    let seconds = started.elapsed().as_secs_f64();
    let image = renderer.image()?;
    if let Some(dir) = cli.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    image.write_png(&cli.output, cli.exposure)?;
    let pfm = cli.output.with_extension("pfm");
    image.write_pfm(&pfm)?;
    if cli.exr {
        image.write_exr(&cli.output.with_extension("exr"))?;
    }
    println!(
        "rendered {}x{} at {} spp on {} in {seconds:.2} s ({} rays, {:.2} Mrays/s, {} programs) to {} and {}",
        cli.width,
        cli.height,
        cli.spp,
        ctx.device_name(),
        image.rays,
        image.rays as f64 / seconds / 1e6,
        match (cli.glsl, cli.wgsl) {
            (true, _) => "GLSL",
            (_, true) => "WGSL",
            _ => "Rust",
        },
        cli.output.display(),
        pfm.display()
    );
    Ok(())
}

/// Hot reload: rebuilds the device crate on each change and renders again.
fn watch(cli: &Cli, ctx: &raykit::Context, renderer: &mut Renderer) -> anyhow::Result<()> {
    let device = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("device");
    let spv = raykit::spirv_path("path-tracer-device");
    let out_dir = spv.parent().context("the SPIR-V path has a directory")?.to_path_buf();
    let target = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("..").join("target");
    let build = raykit_builder::DeviceBuild::new(&device)
        .name("path-tracer-device")
        .out_dir(out_dir)
        .target_dir(target)
        .check_params(false)
        .report(raykit_builder::Report::Quiet);
    let watcher = raykit_builder::DeviceWatcher::new(build, std::time::Duration::from_millis(100))?;
    println!("watching {} (Ctrl-C to stop)", device.display());
    loop {
        let Some(rebuild) = watcher.next_timeout(std::time::Duration::from_secs(3600)) else { continue };
        let reloaded = rebuild.result.map_err(anyhow::Error::from).and_then(|built| {
            let module = raykit::Module::from_file(ctx, &built.spv)?;
            renderer.swap_programs(ctx, &Programs::rust_from(&module)?)?;
            Ok(())
        });
        match reloaded {
            Ok(()) => {
                println!("reloaded in {:.2} s", rebuild.changed_at.elapsed().as_secs_f64());
                render(cli, ctx, renderer)?;
            }
            Err(e) => eprintln!("keeping the previous pipeline: {e:#}"),
        }
    }
}
