//! `cargo run --release -p path_tracer -- [--width W] [--height H] [--spp N] [--max-depth N] [--exr] [--output FILE.png] [--watch] [--devices all|N] [--backend vulkan|cpu|vulkan,cpu] [--denoise [--denoise-device auto|cpu|cuda] [--no-guides]]`:
//! renders optixPathTracer's Cornell box progressively, with a progress bar, to a
//! tonemapped PNG and the linear radiance as PFM next to it. With `--watch` it then
//! keeps running: each save of the device crate's sources rebuilds it, swaps the
//! pipeline and renders the picture again (a compile error is printed and the old
//! pipeline stays).
//!
//! `--view` (with the default `viewer` feature) opens the interactive viewer (`raykit-viewer`) on the box instead: a
//! window that refines the picture while the camera moves, with `--watch` swapping
//! the pipeline in the running window. `--headless --frames N [--camera ...]
//! [--spp-per-frame K]` writes what that window would show after N frames to
//! `--output` (PNG, and the radiance as EXR).
//!
//! With `--devices all` it renders on every ray-tracing GPU at once: each launch
//! is split into bands of rows by the devices' measured speeds, and the bands are
//! gathered into one picture, the same as one device's. `--devices N` makes N
//! contexts over the devices in turn (on a machine with one device, N contexts
//! share it: a way to see the split work there); `--backend vulkan,cpu` adds the
//! CPU backend to the group.
//!
//! With `--denoise` the picture is denoised by Intel Open Image Denoise
//! (`raykit-denoise`; install it with `cargo xtask setup --denoise`), guided by
//! the first-hit albedo and normals the Rust programs write in the same launches
//! (`--no-guides` leaves them out; the GLSL and WGSL twins denoise without them):
//! `--output` gets the denoised picture, and `<output>-noisy.png` the input.
//!
//! Build the shaders first (`cargo xtask build-shaders`), or run `cargo xtask demo`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use path_tracer::{GroupRenderer, Programs, Renderer, Scene};
use raykit::{Backend, Context, ContextOptions, DeviceGroup};

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
    /// Exposure applied before the tonemap (a finite number above 0).
    #[arg(long, default_value_t = 1.0, value_parser = path_tracer::parse_exposure, allow_hyphen_values = true)]
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
    /// Where the device programs run: `vulkan` (a GPU, or lavapipe), `cpu`
    /// (the Rust programs natively on this machine's CPUs), or `vulkan,cpu`
    /// (both at once: the Vulkan devices `--devices` names and the CPU backend,
    /// each launch split between them by speed). Default: the `RAYKIT_BACKEND`
    /// environment variable, else `vulkan`.
    #[arg(long, value_parser = ["vulkan", "cpu", "vulkan,cpu"], conflicts_with_all = ["glsl", "wgsl", "watch"])]
    backend: Option<String>,
    /// Render on several devices at once, each launch split into bands of rows
    /// by the devices' measured speeds: `all` (one context per ray-tracing GPU,
    /// or lavapipe where there is no GPU) or a count N (N contexts over those
    /// devices in turn; on one device, N contexts share it). Without it: one
    /// device, no split.
    #[arg(long, conflicts_with = "watch")]
    devices: Option<String>,
    /// After rendering, watch `examples/path_tracer/device` and render again
    /// after each change (hot reload), until interrupted.
    #[arg(long, conflicts_with_all = ["glsl", "wgsl"])]
    watch: bool,
    /// The device crate `--watch` rebuilds in the viewer (default:
    /// `examples/path_tracer/device`; another crate's SPIR-V goes to its `target/spirv/`).
    #[arg(long, requires = "watch")]
    device_dir: Option<PathBuf>,
    /// `--denoise`, `--denoise-device`, `--no-guides`.
    #[command(flatten)]
    denoise: raykit_denoise::DenoiseArgs,
    #[cfg(feature = "viewer")]
    #[command(flatten)]
    viewer: raykit_viewer::ViewerArgs,
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    anyhow::ensure!(cli.width > 0 && cli.height > 0, "--width and --height must be at least 1");
    anyhow::ensure!(cli.spp > 0 && cli.spp_per_launch > 0, "--spp and --spp-per-launch must be at least 1");
    anyhow::ensure!(cli.max_depth > 0, "--max-depth must be at least 1");
    #[cfg(feature = "viewer")]
    if cli.viewer.wanted() {
        return view(&cli);
    }
    if cli.devices.is_some() || cli.backend.as_deref() == Some("vulkan,cpu") {
        anyhow::ensure!(
            !cli.denoise.denoise,
            "--denoise renders on one device: drop --devices and --backend vulkan,cpu"
        );
        return render_group(&cli);
    }
    // Loaded before rendering: a missing library fails at once, naming its install command.
    anyhow::ensure!(
        !(cli.denoise.denoise && cli.watch),
        "--denoise renders one picture: drop --watch, or denoise in the viewer (--view --watch --denoise)"
    );
    let denoiser = cli.denoise.denoiser()?;
    let backend = cli.backend.as_deref().map(|b| if b == "cpu" { Backend::Cpu } else { Backend::Vulkan });
    let ctx = Context::new(ContextOptions { device_name_contains: cli.device.clone(), backend, ..Default::default() })?;
    let programs = match (cli.glsl, cli.wgsl) {
        (true, _) => Programs::glsl(&ctx)?,
        (_, true) => Programs::wgsl(&ctx)?,
        _ => Programs::rust(&ctx)?,
    };
    let scene = Scene::new(&ctx)?;
    let mut renderer = Renderer::new(&ctx, &programs, &scene, cli.width, cli.height)?;
    renderer.set_max_depth(cli.max_depth);
    let guided = cli.denoise.guides() && programs.raygen_guides.is_some();
    if guided {
        renderer.enable_guides(&ctx, &programs)?;
    } else if cli.denoise.guides() {
        println!("denoise: the GLSL and WGSL twins write no guides; denoising the colour alone");
    }

    render(&cli, &ctx, &mut renderer, denoiser.as_ref())?;
    if cli.watch {
        watch(&cli, &ctx, &mut renderer)?;
    }
    Ok(())
}

/// The contexts of the group `--devices` and `--backend` ask for.
fn group_contexts(cli: &Cli) -> anyhow::Result<Vec<Context>> {
    let spec = cli.devices.as_deref().unwrap_or("1");
    let cpu = ContextOptions { backend: Some(Backend::Cpu), ..Default::default() };
    let (vulkan, with_cpu) = match cli.backend.as_deref() {
        Some("cpu") => (false, true),
        Some("vulkan,cpu") => (true, true),
        Some(_) => (true, false),
        None => (Backend::from_env() != Some(Backend::Cpu), Backend::from_env() == Some(Backend::Cpu)),
    };
    if !vulkan {
        return path_tracer::device_contexts(spec, cpu);
    }
    let options = ContextOptions {
        backend: Some(Backend::Vulkan),
        device_name_contains: cli.device.clone(),
        ..Default::default()
    };
    let mut contexts = path_tracer::device_contexts(spec, options)?;
    if with_cpu {
        contexts.push(Context::new(cpu)?);
    }
    Ok(contexts)
}

/// Renders on a device group: each launch split across the devices.
fn render_group(cli: &Cli) -> anyhow::Result<()> {
    let group = DeviceGroup::new(group_contexts(cli)?)?;
    let names: Vec<String> = group.contexts().iter().map(|c| c.device_name().into_owned()).collect();
    println!("{} device(s): {}", names.len(), names.join(", "));
    let (glsl, wgsl) = (cli.glsl, cli.wgsl);
    let mut renderer = GroupRenderer::new(&group, cli.width, cli.height, |ctx| match (glsl, wgsl) {
        (true, _) => Programs::glsl(ctx),
        (_, true) => Programs::wgsl(ctx),
        _ => Programs::rust(ctx),
    })?;
    renderer.set_max_depth(cli.max_depth);
    let bar = progress_bar(cli.spp)?;
    let started = Instant::now();
    while renderer.samples_done() < cli.spp {
        let samples = cli.spp_per_launch.min(cli.spp - renderer.samples_done());
        renderer.launch(samples)?;
        let bands: Vec<String> = renderer.split().bands().iter().map(|b| b.row_count().to_string()).collect();
        bar.set_message(format!("rows per device {}", bands.join("/")));
        bar.set_position(renderer.samples_done() as u64);
    }
    bar.finish();
    let seconds = started.elapsed().as_secs_f64();
    let image = renderer.image()?;
    let (png, pfm) = write_pictures(cli, &image)?;
    let split = renderer.split();
    for (i, ((name, band), timing)) in names.iter().zip(split.held_bands()).zip(split.timings()).enumerate() {
        let time = timing.map_or(String::from("no rows"), |t| format!("{:.1} ms", t.seconds * 1e3));
        println!("  device {i} ({name}): rows {}..{} in the last launch, {time}", band.rows.start, band.rows.end);
    }
    println!(
        "rendered {}x{} at {} spp on {} device(s) in {seconds:.2} s ({} rays, {:.2} Mrays/s) to {} and {}",
        cli.width,
        cli.height,
        cli.spp,
        names.len(),
        image.rays,
        image.rays as f64 / seconds / 1e6,
        png.display(),
        pfm.display()
    );
    Ok(())
}

/// The progress bar of a render of `spp` paths per pixel.
fn progress_bar(spp: u32) -> anyhow::Result<ProgressBar> {
    let bar = ProgressBar::new(spp as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} spp  {msg}")
            .context("progress bar template")?,
    );
    Ok(bar)
}

/// Writes the PNG, the PFM and (with `--exr`) the EXR; returns the PNG's and the PFM's paths.
fn write_pictures(cli: &Cli, image: &path_tracer::Image) -> anyhow::Result<(PathBuf, PathBuf)> {
    if let Some(dir) = cli.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    image.write_png(&cli.output, cli.exposure)?;
    let pfm = cli.output.with_extension("pfm");
    image.write_pfm(&pfm)?;
    if cli.exr {
        image.write_exr(&cli.output.with_extension("exr"))?;
    }
    Ok((cli.output.clone(), pfm))
}

/// Renders `cli.spp` paths per pixel with a progress bar and writes the
/// pictures (denoised by `denoiser` when given).
fn render(
    cli: &Cli,
    ctx: &Context,
    renderer: &mut Renderer,
    denoiser: Option<&raykit_denoise::Denoiser>,
) -> anyhow::Result<()> {
    let bar = progress_bar(cli.spp)?;
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
    let mut image = renderer.image()?;
    if let Some(denoiser) = denoiser {
        let stem = cli.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let noisy = cli.output.with_file_name(format!("{stem}-noisy.png"));
        image.write_png(&noisy, cli.exposure)?;
        let guides = renderer.guides()?;
        let started = Instant::now();
        image = image.denoised(denoiser, guides.as_ref())?;
        println!(
            "denoised on OIDN's {} device in {:.3} s ({}); the noisy input is {}",
            denoiser.device(),
            started.elapsed().as_secs_f64(),
            if guides.is_some() { "with first-hit albedo and normal guides" } else { "without guides" },
            noisy.display()
        );
    }
    let (_, pfm) = write_pictures(cli, &image)?;
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

/// `--view` and `--headless`: the Cornell box in the viewer's window, or what the
/// window would show written to `--output`.
#[cfg(feature = "viewer")]
fn view(cli: &Cli) -> anyhow::Result<()> {
    anyhow::ensure!(!(cli.glsl || cli.wgsl), "--view and --headless run the Rust programs (drop --glsl/--wgsl)");
    anyhow::ensure!(cli.devices.is_none(), "--view and --headless render on one device (drop --devices)");
    let backend = match cli.backend.as_deref() {
        Some("cpu") => Some(Backend::Cpu),
        Some("vulkan") => Some(Backend::Vulkan),
        Some(other) => anyhow::bail!("--view and --headless take --backend vulkan or cpu, not {other}"),
        None => None,
    };
    let ctx = Context::new(ContextOptions { device_name_contains: cli.device.clone(), backend, ..Default::default() })?;
    let log = ctx.messages();
    let mut renderer = path_tracer::view::ViewRenderer::new(&ctx, cli.width, cli.height, cli.max_depth)?;
    if cli.watch {
        let target = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("..").join("target");
        let (device, out_dir, target) = match &cli.device_dir {
            // Another crate of the same name builds apart, so its SPIR-V never stands in for this one's.
            Some(dir) => (dir.clone(), dir.join("target").join("spirv"), target.join("watched-device")),
            None => {
                let spv = raykit::spirv_path("path-tracer-device");
                let out = spv.parent().context("the SPIR-V path has a directory")?.to_path_buf();
                (std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("device"), out, target)
            }
        };
        renderer.watch(&device, &out_dir, &target)?;
    }
    drop(ctx);
    let session = raykit_viewer::Session {
        title: "raykit path_tracer".into(),
        width: cli.width,
        height: cli.height,
        camera: path_tracer::CAMERA,
        exposure: cli.exposure,
        output: cli.output.clone(),
        denoise: cli.denoise.clone(),
    };
    raykit_viewer::run(renderer, &cli.viewer, session)?;
    report_validation(&log)
}

/// Prints the validation messages the viewer's context collected (with
/// `RAYKIT_VALIDATION=1`) and fails when there are any.
#[cfg(feature = "viewer")]
fn report_validation(log: &raykit::MessageLog) -> anyhow::Result<()> {
    let messages = log.snapshot();
    for message in &messages {
        eprintln!("validation: {message}");
    }
    anyhow::ensure!(messages.is_empty(), "{} validation message(s)", messages.len());
    Ok(())
}

/// Hot reload: rebuilds the device crate on each change and renders again.
fn watch(cli: &Cli, ctx: &Context, renderer: &mut Renderer) -> anyhow::Result<()> {
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
                render(cli, ctx, renderer, None)?;
            }
            Err(e) => eprintln!("keeping the previous pipeline: {e:#}"),
        }
    }
}
