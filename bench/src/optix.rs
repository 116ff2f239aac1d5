//! The `optix` suite: raykit against its OptiX twin (`bench/optix`), in one run.
//!
//! * Primary rays, at each `--optix-sizes` (default 1920x1080 and 3840x2160):
//!   the `primary` suite's height field and camera. raykit's Rust programs, their
//!   GLSL twin, the independent ash baseline (its own programs, structures,
//!   pipeline and SBT on its own device, see [`crate::ash_independent`]; its
//!   picture is checked against raykit's before anything is timed) and the
//!   hand-written ash launch of raykit's own pipeline (see
//!   [`crate::ash_baseline::AshTracer`]) run interleaved as in `primary`; then the
//!   scene (vertices, indices, camera, background, size) is written to a file and
//!   the OptiX program (`raykit-optix primary`) builds its own compacted GAS from
//!   it and launches `--reps` times after warm-up launches, each timed by CUDA
//!   events around `optixLaunch`, tracing the GAS alone (`OptiX`) and then a
//!   one-instance IAS over it (`OptiX (IAS)`: the two levels a Vulkan trace always
//!   has). The pictures are compared pixel by pixel. All of this repeats for
//!   `--optix-rounds` rounds (default 3), so that both sides meet the GPU in the
//!   same states; launch times are pooled.
//! * The path tracer on the Cornell box at `--path-size` with `--spp` paths per
//!   pixel in one launch: Rust and GLSL interleaved, then `raykit-optix path`
//!   (the same programs ported line for line: the same random numbers, so the
//!   same paths up to floating-point differences). The check: the same mean
//!   radiance within its standard error, and the rays each traced.
//!
//! Mrays/s are rays per launch over the median launch time; `raykit / X` is the
//! Rust programs' Mrays/s over X's (> 1: raykit faster): the median of
//! per-repetition ratios for the interleaved variants, the ratio of medians
//! against OptiX (a separate process).
//!
//! The OptiX executable is `--optix-bin PATH` (the executable or its folder), or
//! `optix/raykit-optix` next to this binary; `bench/optix/build.sh` builds it
//! (with `OPTIX_INCLUDE` set). Without it the suite says why and runs nothing.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context as _;
use path_tracer::device::scene::{self, MATERIALS, VERTICES};
use path_tracer::{Programs as PathPrograms, Renderer, Scene};
use raykit::glam::Vec3;
use raykit::{Context, LaunchTimer};
use serde_json::{json, Value};

use crate::ash_baseline::{AshDevice, AshTracer};
use crate::ash_independent::{Camera, Difference, IndependentTracer};
use crate::stats::Summary;
use crate::trace::{interleave, Language, Options, Variant, ASH_INDEPENDENT, ASH_LAUNCH};

/// The scene files' magic (`ROPT`) and version; `bench/optix/main.cpp` reads them.
const MAGIC: u32 = 0x5450_4f52;
const VERSION: u32 = 1;
/// The primary suite's background colour (the miss record).
const BACKGROUND: Vec3 = Vec3::new(0.3, 0.1, 0.2);

/// Where the OptiX twin is, or why it is not there.
enum Twin {
    Ready(PathBuf),
    Missing(String),
}

/// Finds the OptiX executable: `--optix-bin` (a file, or a folder holding
/// `raykit-optix`), else `optix/raykit-optix` next to this binary.
fn locate(opts: &Options) -> Twin {
    let (dir, bin) = match &opts.optix_bin {
        Some(p) if p.is_dir() => (p.clone(), p.join("raykit-optix")),
        Some(p) => (p.parent().map(Path::to_path_buf).unwrap_or_default(), p.clone()),
        None => {
            let dir = match std::env::current_exe() {
                Ok(exe) => exe.parent().map(|d| d.join("optix")).unwrap_or_else(|| PathBuf::from("optix")),
                Err(e) => return Twin::Missing(format!("cannot locate this binary ({e}); pass --optix-bin")),
            };
            (dir.clone(), dir.join("raykit-optix"))
        }
    };
    // build.sh leaves its reason here when it could not build.
    if let Ok(reason) = std::fs::read_to_string(dir.join("NOT_BUILT")) {
        return Twin::Missing(format!("the OptiX twin in {} was not built: {}", dir.display(), reason.trim()));
    }
    if !bin.is_file() {
        return Twin::Missing(format!(
            "no OptiX twin at {}: build it with `OPTIX_INCLUDE=/path/to/optix/include bench/optix/build.sh DIR` \
             (the OptiX 9.0 headers, github.com/NVIDIA/optix-dev tag v9.0.0) and pass `--optix-bin DIR`",
            bin.display()
        ));
    }
    for program in ["primary", "path"] {
        if !dir.join(format!("{program}.optixir")).is_file() && !dir.join(format!("{program}.ptx")).is_file() {
            return Twin::Missing(format!("{} has no {program}.optixir (or .ptx) beside it", bin.display()));
        }
    }
    Twin::Ready(bin)
}

/// What the OptiX twin traces: its GAS alone (`ALLOW_SINGLE_GAS`, as the OptiX
/// SDK's samples), or a one-instance IAS over it, as every Vulkan trace does.
#[derive(Clone, Copy)]
enum Traversable {
    Gas,
    Ias,
}

impl Traversable {
    const BOTH: [Traversable; 2] = [Traversable::Gas, Traversable::Ias];

    fn row_name(self) -> &'static str {
        match self {
            Traversable::Gas => "OptiX",
            Traversable::Ias => "OptiX (IAS)",
        }
    }

    fn file_suffix(self) -> &'static str {
        match self {
            Traversable::Gas => "",
            Traversable::Ias => "_ias",
        }
    }
}

/// The OptiX runs of every round, per traversable: their launch times pooled,
/// the last run's report and image.
struct TwinRuns {
    runs: Vec<(Traversable, OptixRun, Vec<u8>)>,
}

impl TwinRuns {
    fn new() -> TwinRuns {
        TwinRuns { runs: Vec::new() }
    }

    /// Adds one run, pooling its launch times with earlier runs of `traversable`.
    fn add(&mut self, traversable: Traversable, run: OptixRun, image: Vec<u8>) {
        let index = traversable as usize;
        match self.runs.iter_mut().find(|(t, _, _)| *t as usize == index) {
            Some((_, pooled, last)) => {
                pooled.seconds.extend(run.seconds);
                pooled.rays = run.rays;
                pooled.report = run.report;
                *last = image;
            }
            None => self.runs.push((traversable, run, image)),
        }
    }

    fn get(&self, traversable: Traversable) -> Option<(&OptixRun, &[u8])> {
        self.runs.iter().find(|(t, _, _)| *t as usize == traversable as usize).map(|(_, r, i)| (r, i.as_slice()))
    }

    fn reports(&self) -> Value {
        Value::Object(
            self.runs
                .iter()
                .map(|(t, r, _)| (t.row_name().to_owned(), r.report.clone()))
                .collect::<serde_json::Map<_, _>>(),
        )
    }
}

/// What one run of the OptiX program reported.
struct OptixRun {
    /// Seconds of each timed launch.
    seconds: Vec<f64>,
    /// Rays of one launch.
    rays: u64,
    /// Its report, as written.
    report: Value,
}

/// Runs `raykit-optix SUITE SCENE OUT`; returns its report and its image's bytes.
fn run_twin(
    bin: &Path,
    suite: &str,
    scene: &Path,
    out: &Path,
    launches: usize,
    traversable: Traversable,
    preference: raykit::accel::BuildPreference,
) -> anyhow::Result<(OptixRun, Vec<u8>)> {
    let build = match preference {
        raykit::accel::BuildPreference::FastTrace => "fast-trace",
        raykit::accel::BuildPreference::FastBuild => "fast-build",
        raykit::accel::BuildPreference::Neither => "neither",
    };
    let ias = match traversable {
        Traversable::Gas => "0",
        Traversable::Ias => "1",
    };
    let output = Command::new(bin)
        .arg(suite)
        .arg(scene)
        .arg(out)
        .args(["--launches", &launches.to_string(), "--warmup", "3", "--ias", ias, "--gas-build", build])
        .output()
        .with_context(|| format!("starting {}", bin.display()))?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !stderr.trim().is_empty() {
        eprintln!("{}", stderr.trim_end());
    }
    anyhow::ensure!(output.status.success(), "{} {suite} failed ({}): {}", bin.display(), output.status, stderr.trim());
    let json_path = out.with_extension("json");
    let text = std::fs::read_to_string(&json_path).with_context(|| format!("reading {}", json_path.display()))?;
    let report: Value = serde_json::from_str(&text).with_context(|| format!("parsing {}", json_path.display()))?;
    let seconds: Vec<f64> = report["launch_ms"]
        .as_array()
        .context("the OptiX report has no launch_ms")?
        .iter()
        .filter_map(Value::as_f64)
        .map(|ms| ms * 1e-3)
        .collect();
    anyhow::ensure!(!seconds.is_empty(), "the OptiX report has no launch times");
    let rays = report["rays_per_launch"].as_f64().context("the OptiX report has no rays_per_launch")? as u64;
    let img_path = out.with_extension("img");
    let image = std::fs::read(&img_path).with_context(|| format!("reading {}", img_path.display()))?;
    Ok((OptixRun { seconds, rays, report }, image))
}

/// Little-endian scene-file writer.
#[derive(Default)]
struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn vec3(&mut self, v: Vec3) -> &mut Self {
        self.f32(v.x).f32(v.y).f32(v.z)
    }
    fn header(kind: u32) -> Writer {
        let mut w = Writer::default();
        w.u32(MAGIC).u32(VERSION).u32(kind);
        w
    }
}

/// One variant's row.
struct VariantRow {
    programs: &'static str,
    launches: usize,
    rays: u64,
    seconds: Summary,
    mrays: Summary,
    /// raykit (Rust) Mrays/s over this variant's.
    raykit_over: Summary,
    timing: &'static str,
}

/// One comparison: its setup, variant rows and picture check.
struct Section {
    suite: &'static str,
    setup: String,
    rows: Vec<VariantRow>,
    /// The picture check's words, and whether it passed (`None`: OptiX not run).
    check: String,
    passed: Option<bool>,
    optix: Option<Value>,
}

fn mrays_of(results: &[(f64, u64)]) -> Vec<f64> {
    results.iter().map(|(s, rays)| *rays as f64 / s / 1e6).collect()
}

/// Rows of interleaved variants (`names[0]` is raykit's Rust programs).
fn interleaved_rows(names: &[&'static str], results: &[Vec<(f64, u64)>], timing: &'static str) -> Vec<VariantRow> {
    let rust = mrays_of(&results[0]);
    names
        .iter()
        .zip(results)
        .map(|(name, r)| {
            let mrays = mrays_of(r);
            let over: Vec<f64> = rust.iter().zip(&mrays).map(|(a, b)| a / b).collect();
            let mut rays: Vec<u64> = r.iter().map(|(_, n)| *n).collect();
            rays.sort_unstable();
            VariantRow {
                programs: name,
                launches: r.len(),
                rays: rays.get(rays.len() / 2).copied().unwrap_or(0),
                seconds: Summary::of(&r.iter().map(|(s, _)| *s).collect::<Vec<_>>()),
                mrays: Summary::of(&mrays),
                raykit_over: Summary::of(&over),
                timing,
            }
        })
        .collect()
}

/// The OptiX row, against the Rust row's median.
fn optix_row(programs: &'static str, run: &OptixRun, rust: &VariantRow) -> VariantRow {
    let mrays: Vec<f64> = run.seconds.iter().map(|s| run.rays as f64 / s / 1e6).collect();
    let mrays = Summary::of(&mrays);
    let over = rust.mrays.median / mrays.median;
    VariantRow {
        programs,
        launches: run.seconds.len(),
        rays: run.rays,
        seconds: Summary::of(&run.seconds),
        mrays,
        raykit_over: Summary { median: over, min: over, max: over, p25: over, p75: over },
        timing: "CUDA events",
    }
}

fn timing_name(timer: Option<&LaunchTimer>) -> &'static str {
    if timer.is_some() {
        "GPU timestamps"
    } else {
        "wall clock"
    }
}

/// The primary-ray comparison at `size` on the scene of `coverage`; `device`
/// is the independent ash baseline's.
#[allow(clippy::too_many_arguments)]
fn primary(
    ctx: &Context,
    device: &AshDevice,
    timer: Option<&LaunchTimer>,
    opts: &Options,
    twin: &Twin,
    dir: &Path,
    (width, height): (u32, u32),
    coverage: crate::trace::Coverage,
) -> anyhow::Result<Section> {
    let scene = crate::trace::primary_scene(ctx, opts.triangles, (width, height), opts.primary_gas, coverage)?;
    // Files of this size and scene.
    let name = match coverage {
        crate::trace::Coverage::AllHits => format!("primary_{width}x{height}"),
        crate::trace::Coverage::QuarterHits => format!("primary_quarter_{width}x{height}"),
    };
    let rust = crate::trace::primary_pipeline(ctx, Language::Rust)?;
    let glsl = crate::trace::primary_pipeline(ctx, Language::Glsl)?;
    let ash = AshTracer::new(ctx, width as usize * height as usize)?;
    let ash_params = AshTracer::params_with_output(bytemuck::bytes_of(&scene.params));
    let (vertices, indices) = crate::accel::grid(opts.triangles);
    let arrays: Vec<[f32; 3]> = vertices.iter().map(|v| v.to_array()).collect();
    let independent = IndependentTracer::new(device, &arrays, &indices, width as usize * height as usize)?;
    drop(arrays);
    let camera = Camera::of(&scene.params, BACKGROUND);
    let rays = width as u64 * height as u64;
    let dims = [width, height, 1];
    // The independent baseline must draw raykit's picture: checked before anything is timed.
    rust.pipeline.launch(&rust.sbt, &scene.params, dims)?;
    independent.launch(&camera, dims)?;
    let independent_difference =
        Difference::of(&scene.image.read()?, &independent.picture()?, triangle_device::make_color(BACKGROUND));
    anyhow::ensure!(
        independent_difference.acceptable(),
        "the independent ash baseline's picture is not raykit's ({width}x{height}): {independent_difference}"
    );
    let launch = |p: &crate::trace::PrimaryPipeline| -> anyhow::Result<(f64, u64)> {
        let s = match timer {
            Some(t) => p.pipeline.launch_timed(&p.sbt, &scene.params, dims, t)?.as_secs_f64(),
            None => {
                let start = std::time::Instant::now();
                p.pipeline.launch(&p.sbt, &scene.params, dims)?;
                start.elapsed().as_secs_f64()
            }
        };
        Ok((s, rays))
    };
    let setup = format!("{} triangles, {}, {width}x{height}, 1 ray/pixel", opts.triangles, coverage.label());
    // The scene as raykit traces it, for the twin.
    let scene_path = dir.join(format!("{name}.scene"));
    if let Twin::Ready(_) = twin {
        let p = &scene.params;
        let mut w = Writer::header(1);
        w.u32(width).u32(height).u32(vertices.len() as u32).u32(indices.len() as u32);
        w.vec3(p.cam_eye).vec3(p.cam_u).vec3(p.cam_v).vec3(p.cam_w).vec3(BACKGROUND);
        for v in &vertices {
            w.vec3(*v);
        }
        for &i in &indices {
            w.u32(i);
        }
        std::fs::write(&scene_path, &w.0).with_context(|| format!("writing {}", scene_path.display()))?;
    }
    // The WGSL twin as it is and with tiled launch indices (see
    // `Language::WgslTiled`), where the image divides into the tiles.
    let wgsl = crate::trace::primary_pipeline(ctx, Language::Wgsl)?;
    let tiles: Vec<(&'static str, crate::trace::PrimaryPipeline)> = [("WGSL 8x4", (8, 4)), ("WGSL 4x8", (4, 8))]
        .into_iter()
        .filter(|(_, (tw, th))| width % tw == 0 && height % th == 0)
        .map(|(name, tile)| Ok((name, crate::trace::primary_pipeline(ctx, Language::WgslTiled(tile.0, tile.1))?)))
        .collect::<anyhow::Result<_>>()?;
    let mut names = vec!["Rust", "GLSL", ASH_INDEPENDENT, ASH_LAUNCH, "WGSL"];
    names.extend(tiles.iter().map(|(name, _)| *name));
    let mut variants: Vec<Variant<'_>> = vec![
        ("Rust", Box::new(|| launch(&rust))),
        ("GLSL", Box::new(|| launch(&glsl))),
        (ASH_INDEPENDENT, Box::new(|| Ok((independent.launch(&camera, dims)?, rays)))),
        (ASH_LAUNCH, Box::new(|| Ok((crate::trace::ash_launch(&ash, &rust, &ash_params, dims)?, rays)))),
        ("WGSL", Box::new(|| launch(&wgsl))),
    ];
    for (name, pipeline) in &tiles {
        variants.push((name, Box::new(|| launch(pipeline))));
    }
    let out = dir.join(&name);
    let (results, runs) = rounds(&mut variants, opts, twin, |bin, traversable| {
        let out = out.with_file_name(format!("{name}{}", traversable.file_suffix()));
        run_twin(bin, "primary", &scene_path, &out, opts.reps, traversable, opts.primary_gas.preference)
    })?;
    drop(variants);
    let mut rows = interleaved_rows(&names, &results, timing_name(timer));
    // raykit's picture, from a last launch of the Rust programs.
    rust.pipeline.launch(&rust.sbt, &scene.params, dims)?;
    let picture = scene.image.read()?;
    let ash_differs = picture.iter().zip(ash.picture()?).filter(|(a, b)| **a != *b).count();
    let independent_differs =
        Difference::of(&picture, &independent.picture()?, triangle_device::make_color(BACKGROUND));
    let ash_check =
        format!("{ASH_INDEPENDENT}: {independent_differs}; {ASH_LAUNCH}: {ash_differs} pixels differ from raykit's");
    let ash_same = ash_differs == 0 && independent_differs.acceptable();
    // The tiled WGSL programs must draw the plain WGSL picture.
    wgsl.pipeline.launch(&wgsl.sbt, &scene.params, dims)?;
    let wgsl_picture = scene.image.read()?;
    let mut tiled_differs = 0;
    for (_, pipeline) in &tiles {
        pipeline.pipeline.launch(&pipeline.sbt, &scene.params, dims)?;
        tiled_differs += scene.image.read()?.iter().zip(&wgsl_picture).filter(|(a, b)| a != b).count();
    }

    if runs.runs.is_empty() {
        return Ok(Section {
            suite: "primary",
            setup,
            rows,
            check: format!("{ash_check}; OptiX not run"),
            passed: Some(ash_same),
            optix: None,
        });
    }
    let mut checks = Vec::new();
    let mut all_same = ash_same;
    for traversable in Traversable::BOTH {
        let Some((run, image)) = runs.get(traversable) else { continue };
        let (check, same) = compare_primary(&picture, image, traversable.row_name())?;
        checks.push(check);
        all_same &= same;
        let row = optix_row(traversable.row_name(), run, &rows[0]);
        rows.push(row);
    }
    // The tiled programs are a timing study: NVIDIA compiles them apart from the
    // plain WGSL ones, and a few pixels round the other way; counted, not failed.
    let check = format!(
        "{}; {ash_check}; the tiled WGSL programs: {tiled_differs} pixels differ from the plain WGSL's",
        checks.join("; ")
    );
    // raykit's picture, for a closer look beside the twin's.
    let ours_path = dir.join(format!("{name}.raykit.img"));
    let bytes: Vec<u8> = picture.iter().flat_map(|p| p.to_le_bytes()).collect();
    std::fs::write(&ours_path, bytes).with_context(|| format!("writing {}", ours_path.display()))?;
    eprintln!("optix: primary {width}x{height}, {}: {check}", coverage.label());
    Ok(Section { suite: "primary", setup, rows, check, passed: Some(all_same), optix: Some(runs.reports()) })
}

/// One variant's (seconds, rays) per launch.
type VariantResults = Vec<(f64, u64)>;

/// `opts.optix_rounds` rounds: raykit's `variants` interleaved (`opts.reps`
/// each), then, where the twin is built, `twin_run` for its GAS and its IAS.
/// Returns raykit's results and the twin's runs, each pooled over the rounds.
fn rounds(
    variants: &mut [Variant<'_>],
    opts: &Options,
    twin: &Twin,
    mut twin_run: impl FnMut(&Path, Traversable) -> anyhow::Result<(OptixRun, Vec<u8>)>,
) -> anyhow::Result<(Vec<VariantResults>, TwinRuns)> {
    let mut results: Vec<VariantResults> = vec![Vec::new(); variants.len()];
    let mut runs = TwinRuns::new();
    for _ in 0..opts.optix_rounds.max(1) {
        for (pooled, round) in results.iter_mut().zip(interleave(variants, opts.reps)?) {
            pooled.extend(round);
        }
        if let Twin::Ready(bin) = twin {
            for traversable in Traversable::BOTH {
                let (run, image) = twin_run(bin, traversable)?;
                runs.add(traversable, run, image);
            }
        }
    }
    Ok((results, runs))
}

/// Compares raykit's primary-ray `picture` with the twin's `image` (RGBA8 as
/// little-endian u32); returns the check's text and whether they are equal.
fn compare_primary(picture: &[u32], image: &[u8], name: &str) -> anyhow::Result<(String, bool)> {
    anyhow::ensure!(
        image.len() == picture.len() * 4,
        "the {name} picture has {} bytes, not {}",
        image.len(),
        picture.len() * 4
    );
    let theirs: Vec<u32> = image.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let background = triangle_device::make_color(BACKGROUND);
    let (mut differ, mut hit_miss, mut off_by_one, mut max_channel) = (0usize, 0usize, 0usize, 0u32);
    for (&a, &b) in picture.iter().zip(&theirs) {
        if a != b {
            differ += 1;
            if (a == background) != (b == background) {
                hit_miss += 1;
            }
            let largest = [0, 8, 16, 24].iter().map(|s| ((a >> s) & 255).abs_diff((b >> s) & 255)).max().unwrap_or(0);
            if largest <= 1 {
                off_by_one += 1;
            }
            max_channel = max_channel.max(largest);
        }
    }
    let total = picture.len();
    let check = format!(
        "{name}: {differ} of {total} pixels differ ({:.4}%): {off_by_one} by 1 in a channel at most (the colour rounded the other way), {} by more (another triangle or other barycentrics; largest channel difference {max_channel}), {hit_miss} hit on one side and missed on the other",
        100.0 * differ as f64 / total as f64,
        differ - off_by_one
    );
    Ok((check, differ == 0))
}

/// Mean of per-pixel values and its standard error (pixel spread / √n).
fn mean_and_se(values: &[f64]) -> (f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

/// The path-tracer comparison.
fn path(
    ctx: &Context,
    timer: Option<&LaunchTimer>,
    opts: &Options,
    twin: &Twin,
    dir: &Path,
) -> anyhow::Result<Section> {
    let scene_gpu = Scene::new(ctx)?;
    let size = opts.path_size;
    let spp = opts.spp;
    let mut rust = Renderer::new(ctx, &PathPrograms::rust(ctx)?, &scene_gpu, size, size)?;
    let mut glsl = Renderer::new(ctx, &PathPrograms::glsl(ctx)?, &scene_gpu, size, size)?;
    let setup = format!("Cornell box, {size}x{size}, {spp} spp, max depth {}", scene::MAX_DEPTH);
    // The scene for the twin.
    let scene_path = dir.join(format!("path_{size}.scene"));
    if let Twin::Ready(_) = twin {
        let camera = path_tracer::camera_frame(1.0);
        let light = scene::LIGHT;
        let mut w = Writer::header(2);
        w.u32(size).u32(size).u32(spp).u32(scene::MAX_DEPTH);
        w.u32(MATERIALS.len() as u32).u32((VERTICES.len() / 3) as u32);
        w.vec3(camera.eye).vec3(camera.u).vec3(camera.v).vec3(camera.w);
        w.vec3(light.corner).vec3(light.v1).vec3(light.v2).vec3(light.emission);
        for group in MATERIALS {
            w.u32(group.first_triangle).u32(group.triangles).vec3(group.emission).vec3(group.albedo);
        }
        for v in VERTICES {
            w.vec3(v);
        }
        for n in path_tracer::triangle_normals() {
            w.vec3(n);
        }
        std::fs::write(&scene_path, &w.0).with_context(|| format!("writing {}", scene_path.display()))?;
    }
    let launch = |r: &mut Renderer| -> anyhow::Result<(f64, u64)> {
        r.reset();
        let s = match timer {
            Some(t) => r.launch_timed(spp, t)?.as_secs_f64(),
            None => {
                let start = std::time::Instant::now();
                r.launch(spp)?;
                start.elapsed().as_secs_f64()
            }
        };
        Ok((s, r.rays()?))
    };
    let names = ["Rust", "GLSL"];
    let mut variants: Vec<Variant<'_>> =
        vec![("Rust", Box::new(|| launch(&mut rust))), ("GLSL", Box::new(|| launch(&mut glsl)))];
    let (results, runs) = rounds(&mut variants, opts, twin, |bin, traversable| {
        let out = dir.join(format!("path_{size}{}", traversable.file_suffix()));
        run_twin(bin, "path", &scene_path, &out, opts.reps, traversable, raykit::accel::BuildPreference::FastTrace)
    })?;
    drop(variants);
    let mut rows = interleaved_rows(&names, &results, timing_name(timer));
    if runs.runs.is_empty() {
        return Ok(Section {
            suite: "path",
            setup,
            rows,
            check: "OptiX not run".to_owned(),
            passed: None,
            optix: None,
        });
    }
    // raykit's picture, from a last launch of the Rust programs.
    rust.reset();
    rust.launch(spp)?;
    let ours = rust.accumulation()?;
    let ours_path = dir.join(format!("path_{size}.raykit.img"));
    let bytes: Vec<u8> = ours.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
    std::fs::write(&ours_path, bytes).with_context(|| format!("writing {}", ours_path.display()))?;
    let mut checks = Vec::new();
    let mut passed = true;
    for traversable in Traversable::BOTH {
        let Some((run, image)) = runs.get(traversable) else { continue };
        let (check, same) = compare_path(&ours, image, spp, run.rays, traversable.row_name())?;
        checks.push(check);
        passed &= same;
        let row = optix_row(traversable.row_name(), run, &rows[0]);
        rows.push(row);
    }
    let check = checks.join("; ");
    eprintln!("optix: path: {check}");
    Ok(Section { suite: "path", setup, rows, check, passed: Some(passed), optix: Some(runs.reports()) })
}

/// Compares raykit's accumulation `ours` (`spp` paths per pixel) with the twin's
/// `image` (4 × f32 per pixel, `their_rays` rays); returns the check's text and
/// whether the mean radiances agree within their standard error.
fn compare_path(
    ours: &[raykit::glam::Vec4],
    image: &[u8],
    spp: u32,
    their_rays: u64,
    name: &str,
) -> anyhow::Result<(String, bool)> {
    anyhow::ensure!(
        image.len() == ours.len() * 16,
        "the {name} accumulation has {} bytes, not {}",
        image.len(),
        ours.len() * 16
    );
    let theirs: Vec<[f32; 4]> = image
        .chunks_exact(16)
        .map(|c| std::array::from_fn(|i| f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])))
        .collect();
    // Mean radiance per pixel (the channels' average), over the paths per pixel.
    let n = spp.max(1) as f64;
    let our_pixels: Vec<f64> = ours.iter().map(|a| (a.x + a.y + a.z) as f64 / 3.0 / n).collect();
    let their_pixels: Vec<f64> = theirs.iter().map(|a| (a[0] + a[1] + a[2]) as f64 / 3.0 / n).collect();
    let (our_mean, our_se) = mean_and_se(&our_pixels);
    let (their_mean, their_se) = mean_and_se(&their_pixels);
    let se = (our_se * our_se + their_se * their_se).sqrt();
    let delta = their_mean - our_mean;
    // The same seeds: the per-pixel differences give a paired test as well.
    let differences: Vec<f64> = our_pixels.iter().zip(&their_pixels).map(|(a, b)| b - a).collect();
    let (_, paired_se) = mean_and_se(&differences);
    let same = ours.iter().zip(&theirs).filter(|(a, b)| a.x == b[0] && a.y == b[1] && a.z == b[2]).count();
    let our_rays: f64 = ours.iter().map(|a| a.w as f64).sum();
    let channel = |k: usize| -> (f64, f64) {
        let a = ours.iter().map(|p| p.to_array()[k] as f64).sum::<f64>() / ours.len() as f64 / n;
        let b = theirs.iter().map(|p| p[k] as f64).sum::<f64>() / theirs.len() as f64 / n;
        (a, b)
    };
    let (r, g, b) = (channel(0), channel(1), channel(2));
    let passed = delta.abs() <= se;
    let check = format!(
        "{name}: mean radiance raykit {our_mean:.5} ± {our_se:.5}, {name} {their_mean:.5} ± {their_se:.5} (RGB raykit {:.4} {:.4} {:.4}, {name} {:.4} {:.4} {:.4}): Δ = {delta:.2e} = {:.3} standard errors ({}; paired: {:.2} SE of the per-pixel differences); {same} of {} pixels equal bit for bit; rays raykit {our_rays:.0}, {name} {their_rays}",
        r.0,
        g.0,
        b.0,
        r.1,
        g.1,
        b.1,
        delta / se,
        if passed { "within" } else { "NOT within" },
        if paired_se > 0.0 { delta / paired_se } else { 0.0 },
        ours.len(),
    );
    Ok((check, passed))
}

/// Runs the suite; returns its Markdown section and JSON.
pub fn run(
    ctx: &Context,
    timer: Option<&LaunchTimer>,
    opts: &Options,
    out: &Path,
) -> anyhow::Result<(String, serde_json::Value)> {
    let twin = locate(opts);
    match &twin {
        Twin::Ready(bin) => eprintln!("optix: the OptiX twin is {}", bin.display()),
        Twin::Missing(why) => eprintln!("optix: OptiX not available: {why}"),
    }
    let dir = out.join("optix");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    // The independent ash baseline's device, on raykit's GPU.
    let device = AshDevice::new(ctx)?;
    let mut sections = Vec::new();
    for &size in &opts.optix_sizes {
        for coverage in crate::trace::Coverage::BOTH {
            sections.push(primary(ctx, &device, timer, opts, &twin, &dir, size, coverage)?);
        }
    }
    sections.push(path(ctx, timer, opts, &twin, &dir)?);
    crate::ash_independent::ensure_no_validation_messages(ctx, &device)?;
    Ok((markdown(&sections, &twin), json(&sections, &twin)))
}

fn markdown(sections: &[Section], twin: &Twin) -> String {
    let mut s = String::from(
        "raykit's Rust programs against their GLSL twin, the independent ash baseline (`ash (independent)`: its own GLSL programs with a plain descriptor set, its own BLAS (fast trace, not compacted), one-instance TLAS, pipeline and SBT on its own `VkDevice`, device-local output), the hand-written ash launch of raykit's own pipeline, SBT and TLAS (`ash launch, raykit pipeline`: what raykit's launch path costs) and the OptiX twin (`bench/optix`, CUDA events around `optixLaunch`, compacted GAS, fast trace). In each of `--optix-rounds` rounds, raykit's variants and the ash baselines run interleaved after a warm-up launch each, then OptiX in its own process after 3 warm-up launches, tracing its GAS alone (`OptiX`, as the SDK's samples) and a one-instance IAS over it (`OptiX (IAS)`, the two levels every Vulkan trace has); launch times are pooled over the rounds. Median (± half the interquartile range); `raykit / X` is raykit's Mrays/s over X's (> 1: raykit faster): median of per-repetition ratios, against OptiX the ratio of medians.\n\n",
    );
    if let Twin::Missing(why) = twin {
        s.push_str(&format!("**OptiX not run**: {why}\n\n"));
    }
    s.push_str("| suite | setup | programs | launches | rays/launch | ms/launch | Mrays/s | raykit / programs (min–max) | timing |\n");
    s.push_str("|---|---|---|---:|---:|---:|---:|---:|---|\n");
    for sec in sections {
        for r in &sec.rows {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {:.3} ± {:.1}% | {:.1} | {:.3} ({:.3}–{:.3}) | {} |\n",
                sec.suite,
                sec.setup,
                r.programs,
                r.launches,
                r.rays,
                r.seconds.median * 1e3,
                r.seconds.spread_percent(),
                r.mrays.median,
                r.raykit_over.median,
                r.raykit_over.min,
                r.raykit_over.max,
                r.timing
            ));
        }
    }
    s.push_str(
        "\n| suite | setup | raykit / GLSL | raykit / ash (independent) | raykit / ash launch of raykit's pipeline | raykit / OptiX | raykit / OptiX (IAS) |\n|---|---|---:|---:|---:|---:|---:|\n",
    );
    for sec in sections {
        let ratio = |name: &str| {
            sec.rows
                .iter()
                .find(|r| r.programs == name)
                .map_or("–".to_owned(), |r| format!("{:.3}", r.raykit_over.median))
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            sec.suite,
            sec.setup,
            ratio("GLSL"),
            ratio(ASH_INDEPENDENT),
            ratio(ASH_LAUNCH),
            ratio("OptiX"),
            ratio("OptiX (IAS)")
        ));
    }
    s.push_str("\nPicture checks:\n\n");
    for sec in sections {
        s.push_str(&format!(
            "* {} {}: {} — {}\n",
            sec.suite,
            sec.setup,
            match sec.passed {
                Some(true) => "ok",
                Some(false) => "MISMATCH",
                None => "not checked",
            },
            sec.check
        ));
    }
    s
}

fn json(sections: &[Section], twin: &Twin) -> serde_json::Value {
    let sections: Vec<Value> = sections
        .iter()
        .map(|sec| {
            let rows: Vec<Value> = sec
                .rows
                .iter()
                .map(|r| {
                    json!({
                        "programs": r.programs, "launches": r.launches, "rays_per_launch": r.rays,
                        "seconds": r.seconds.json(), "mrays_per_s": r.mrays.json(),
                        "raykit_over": r.raykit_over.json(), "timing": r.timing,
                    })
                })
                .collect();
            json!({
                "suite": sec.suite, "setup": sec.setup, "rows": rows, "check": sec.check,
                "passed": sec.passed, "optix_report": sec.optix,
            })
        })
        .collect();
    json!({
        "optix": match twin { Twin::Ready(bin) => json!(bin.display().to_string()), Twin::Missing(_) => Value::Null },
        "optix_missing": match twin { Twin::Missing(why) => json!(why), Twin::Ready(_) => Value::Null },
        "sections": sections,
    })
}
