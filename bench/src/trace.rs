//! The tracing suites: Rust device programs against their GLSL and WGSL twins,
//! through the same host code, on the same acceleration structures, interleaved.
//!
//! * `primary`: one camera ray per pixel on a procedural height-field mesh
//!   (`--triangles`, default 1,000,000) at `--primary-size` (default 1920x1080),
//!   with optixTriangle's programs (`triangle-device`;
//!   `examples/triangle/glsl` through `spirv-opt -O`, in `bench/glsl/`;
//!   `examples/triangle/wgsl`, compiled by naga when the suite starts), against
//!   the independent ash baseline ([`IndependentTracer`]: its own GLSL programs,
//!   BLAS, TLAS, pipeline and SBT on its own device; `ash (independent)`, whose
//!   ratios are the `vs ash (independent)` column), and beside them the hand-written ash launch
//!   of the Rust programs' own `VkPipeline` and SBT ([`AshTracer`];
//!   `ash launch, raykit pipeline`: what raykit's launch path costs). Both ash
//!   pictures must be raykit's.
//! * `path`: the path tracer (`path-tracer-device`, `examples/path_tracer/glsl`
//!   and `examples/path_tracer/wgsl`) on the Cornell box at `--path-size`
//!   (default 512) with `--spp` paths per pixel in one launch (default 1).
//!
//! The WGSL programs are naga's SPIR-V as raykit loads it (no `spirv-opt`), as a
//! wgpu user would ship them.
//!
//! Time is the GPU time of `vkCmdTraceRaysKHR` from timestamps where the queue
//! has them, else the wall time of the whole launch (submission and wait
//! included; lavapipe has timestamps).

use std::time::{Duration, Instant};

use path_tracer::{Programs as PathPrograms, Renderer, Scene};
use raykit::glam::{UVec2, Vec3};
use raykit::{Context, Gas, Ias, LaunchTimer, LinkOptions, Module, Pipeline, ProgramGroup, Sbt, Triangles};
use triangle_device::{MissData, Params as PrimaryParams};

use anyhow::Context as _;

use crate::ash_baseline::{AshDevice, AshTracer};
use crate::ash_independent::{Camera, Difference, IndependentTracer};
use crate::stats::Summary;

/// The row of the independent ash baseline ([`IndependentTracer`]).
pub const ASH_INDEPENDENT: &str = "ash (independent)";
/// The row of the hand-written ash launch of raykit's own pipeline and SBT ([`AshTracer`]).
pub const ASH_LAUNCH: &str = "ash launch, raykit pipeline";

/// Options of the tracing suites.
pub struct Options {
    /// Repetitions of each variant.
    pub reps: usize,
    /// Triangles of the primary-ray mesh.
    pub triangles: usize,
    /// Image size of the primary-ray suite.
    pub primary_size: (u32, u32),
    /// Image side of the path-tracer suite.
    pub path_size: u32,
    /// Paths per pixel of the path-tracer suite.
    pub spp: u32,
    /// Launches per loop of the `launch-loop` suite.
    pub launches: usize,
    /// The group of the `devices` suite: `all`, or a count of contexts.
    pub devices: String,
    /// Paths per pixel of each launch of the `devices` suite's progressive renders.
    pub spp_per_launch: u32,
    /// The OptiX twin's executable (or its folder) for the `optix` suite; else
    /// `optix/raykit-optix` next to this binary.
    pub optix_bin: Option<std::path::PathBuf>,
    /// How the primary-ray scene's GAS and IAS are built.
    pub primary_gas: GasChoice,
    /// Image sizes of the `optix` suite's primary rays.
    pub optix_sizes: Vec<(u32, u32)>,
    /// Thread counts of the `cpu-scaling` suite (empty: 1, 2, 4, … up to the logical CPUs).
    pub cpu_threads: Vec<usize>,
    /// Rounds of the `optix` suite: each runs raykit's variants interleaved,
    /// then the OptiX twin (single GAS, then IAS), so that both sides see the
    /// GPU in the same states.
    pub optix_rounds: usize,
}

impl Options {
    /// The primary-ray scene at `--triangles`, `--primary-size` and `--primary-gas`.
    pub fn primary_scene(&self, ctx: &Context, coverage: Coverage) -> anyhow::Result<PrimaryScene> {
        primary_scene(ctx, self.triangles, self.primary_size, self.primary_gas, coverage)
    }
}

/// One variant's results.
pub struct Row {
    /// `primary` or `path`.
    pub suite: &'static str,
    /// `Rust`, `GLSL` or `WGSL`.
    pub variant: &'static str,
    /// What was traced.
    pub setup: String,
    /// Repetitions.
    pub reps: usize,
    /// Rays of one launch (median).
    pub rays: u64,
    /// Seconds per launch.
    pub seconds: Summary,
    /// Million rays per second.
    pub mrays: Summary,
    /// Per-repetition ratio of this variant's Mrays/s to the GLSL twin's.
    pub vs_glsl: Summary,
    /// Per-repetition ratio of this variant's Mrays/s to the independent ash
    /// baseline's, where the suite has one.
    pub vs_ash: Option<Summary>,
    /// Per-repetition ratio of this variant's Mrays/s to the hand-written ash
    /// launch of raykit's pipeline, where the suite has one.
    pub vs_ash_launch: Option<Summary>,
    /// `GPU timestamps` or `wall clock`.
    pub timing: &'static str,
}

/// A variant: a name and a launch returning its time and its rays.
pub(crate) type Variant<'a> = (&'static str, Box<dyn FnMut() -> anyhow::Result<(f64, u64)> + 'a>);

/// Runs every variant once to warm up, then `reps` rounds in rotating order;
/// returns per variant the (seconds, rays) of each round.
pub(crate) fn interleave(variants: &mut [Variant<'_>], reps: usize) -> anyhow::Result<Vec<Vec<(f64, u64)>>> {
    for (_, run) in variants.iter_mut() {
        run()?;
    }
    let n = variants.len();
    let mut results = vec![Vec::with_capacity(reps); n];
    for rep in 0..reps {
        for k in 0..n {
            let i = (rep + k) % n;
            let r = (variants[i].1)()?;
            results[i].push(r);
        }
    }
    Ok(results)
}

fn rows(
    suite: &'static str,
    setup: &str,
    timing: &'static str,
    names: &[&'static str],
    results: &[Vec<(f64, u64)>],
) -> Vec<Row> {
    let glsl = names.iter().position(|n| *n == "GLSL").unwrap_or(0);
    let mrays_of = |r: &[(f64, u64)]| -> Vec<f64> { r.iter().map(|(s, rays)| *rays as f64 / s / 1e6).collect() };
    let glsl_mrays = mrays_of(&results[glsl]);
    let ash_mrays = names.iter().position(|n| *n == ASH_INDEPENDENT).map(|i| mrays_of(&results[i]));
    let launch_mrays = names.iter().position(|n| *n == ASH_LAUNCH).map(|i| mrays_of(&results[i]));
    names
        .iter()
        .zip(results)
        .map(|(name, r)| {
            let mrays = mrays_of(r);
            let ratios: Vec<f64> = mrays.iter().zip(&glsl_mrays).map(|(a, b)| a / b).collect();
            let over = |base: &Vec<f64>| {
                let ratios: Vec<f64> = mrays.iter().zip(base).map(|(a, b)| a / b).collect();
                Summary::of(&ratios)
            };
            let vs_ash = ash_mrays.as_ref().map(over);
            let vs_ash_launch = launch_mrays.as_ref().map(over);
            let mut rays: Vec<u64> = r.iter().map(|(_, n)| *n).collect();
            rays.sort_unstable();
            Row {
                suite,
                variant: name,
                setup: setup.to_owned(),
                reps: r.len(),
                rays: rays.get(rays.len() / 2).copied().unwrap_or(0),
                seconds: Summary::of(&r.iter().map(|(s, _)| *s).collect::<Vec<_>>()),
                mrays: Summary::of(&mrays),
                vs_glsl: Summary::of(&ratios),
                vs_ash,
                vs_ash_launch,
                timing,
            }
        })
        .collect()
}

fn seconds(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// The language of a suite's device programs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Language {
    /// rust-gpu.
    Rust,
    /// glslang, then `spirv-opt -O`.
    Glsl,
    /// naga.
    Wgsl,
    /// The WGSL twin with its launch index remapped so that each run of 32
    /// consecutive invocations covers a `W`×`H` tile of pixels (`W`·`H` = 32)
    /// instead of a 32-pixel row: a study of how the driver groups
    /// invocations into warps. The same picture where the image's width is a
    /// multiple of `W` and its height of `H`.
    WgslTiled(u32, u32),
}

/// The primary-ray WGSL twin whose raygen reads its pixel from a `tile`-tiled
/// launch index (see [`Language::WgslTiled`]).
fn tiled_wgsl((tw, th): (u32, u32)) -> anyhow::Result<String> {
    let source = include_str!("../../examples/triangle/wgsl/triangle.wgsl");
    let header = "fn rg(@builtin(ray_invocation_id) id: vec3<u32>, @builtin(num_ray_invocations) dims: vec3<u32>) {";
    anyhow::ensure!(source.contains(header), "the WGSL twin's raygen signature changed");
    let tiled = format!(
        "fn rg(@builtin(ray_invocation_id) launch_id: vec3<u32>, @builtin(num_ray_invocations) dims: vec3<u32>) {{\n    \
         let linear = launch_id.x + dims.x * launch_id.y;\n    \
         let tile = linear / {lanes}u;\n    let lane = linear % {lanes}u;\n    \
         let tiles_x = dims.x / {tw}u;\n    \
         let id = vec3<u32>((tile % tiles_x) * {tw}u + lane % {tw}u, (tile / tiles_x) * {th}u + lane / {tw}u, 0u);",
        lanes = tw * th
    );
    Ok(source.replace(header, &tiled))
}

/// The primary-ray programs: Rust (`triangle-device`), the GLSL twin or the WGSL twin.
fn primary_programs(ctx: &Context, language: Language) -> anyhow::Result<[ProgramGroup; 3]> {
    if let Language::WgslTiled(tw, th) = language {
        let module = Module::from_wgsl_named(ctx, &tiled_wgsl((tw, th))?, "triangle.wgsl, tiled launch index")?;
        return Ok([
            ProgramGroup::raygen(&module, "rg")?,
            ProgramGroup::miss(&module, "ms")?,
            ProgramGroup::hit_group(&module).closest_hit("ch").build()?,
        ]);
    }
    if language == Language::Wgsl {
        let source = include_str!("../../examples/triangle/wgsl/triangle.wgsl");
        let module = Module::from_wgsl_named(ctx, source, "examples/triangle/wgsl/triangle.wgsl")?;
        return Ok([
            ProgramGroup::raygen(&module, "rg")?,
            ProgramGroup::miss(&module, "ms")?,
            ProgramGroup::hit_group(&module).closest_hit("ch").build()?,
        ]);
    }
    if language == Language::Glsl {
        let rgen = Module::new(ctx, include_bytes!("../glsl/primary.rgen.spv"))?;
        let rmiss = Module::new(ctx, include_bytes!("../glsl/primary.rmiss.spv"))?;
        let rchit = Module::new(ctx, include_bytes!("../glsl/primary.rchit.spv"))?;
        Ok([
            ProgramGroup::raygen(&rgen, "main")?,
            ProgramGroup::miss(&rmiss, "main")?,
            ProgramGroup::hit_group(&rchit).closest_hit("main").build()?,
        ])
    } else {
        let module = Module::from_device_crate(ctx, "triangle-device")?;
        Ok([
            ProgramGroup::raygen(&module, triangle_device::RG)?,
            ProgramGroup::miss(&module, triangle_device::MS)?,
            ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?,
        ])
    }
}

/// A linked primary-ray pipeline and its SBT.
pub struct PrimaryPipeline {
    /// The pipeline.
    pub pipeline: Pipeline<PrimaryParams>,
    /// Its SBT.
    pub sbt: Sbt,
}

/// Links the primary-ray programs and lays out their SBT.
pub fn primary_pipeline(ctx: &Context, language: Language) -> anyhow::Result<PrimaryPipeline> {
    let [raygen, miss, hit] = primary_programs(ctx, language)?;
    let pipeline = Pipeline::<PrimaryParams>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, MissData { bg_color: PRIMARY_BACKGROUND })
        .hit(&hit, ())
        .build()?;
    Ok(PrimaryPipeline { pipeline, sbt })
}

/// The colour of the primary-ray programs' misses (their miss record).
pub const PRIMARY_BACKGROUND: Vec3 = Vec3::new(0.3, 0.1, 0.2);

/// The primary-ray scene: the mesh's TLAS and the image, and the params.
pub struct PrimaryScene {
    /// TLAS over the mesh (kept alive while `params` names it).
    #[allow(dead_code)]
    pub ias: Ias,
    /// The RGBA8 image.
    pub image: raykit::DeviceBuffer<u32>,
    /// The launch params (camera over the mesh).
    pub params: PrimaryParams,
}

/// How much of the primary-ray picture the height field covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// Every ray hits the mesh.
    AllHits,
    /// The mesh covers a quarter of the picture (its footprint is twice as wide
    /// and twice as high as the mesh): three rays in four miss.
    QuarterHits,
}

impl Coverage {
    /// Both, in the order the suites report them.
    pub const BOTH: [Coverage; 2] = [Coverage::AllHits, Coverage::QuarterHits];

    /// How rows name the scene.
    pub fn label(self) -> &'static str {
        match self {
            Coverage::AllHits => "every ray hits",
            Coverage::QuarterHits => "25% of rays hit",
        }
    }
}

/// Builds the height field of `triangles` triangles over [0,1]² (a compacted
/// GAS for fast trace under a one-instance IAS) and a camera above it whose
/// rays hit it as `coverage` says.
pub fn primary_scene(
    ctx: &Context,
    triangles: usize,
    (width, height): (u32, u32),
    choice: GasChoice,
    coverage: Coverage,
) -> anyhow::Result<PrimaryScene> {
    let (vertices, indices) = crate::accel::grid(triangles);
    let mut options = raykit::accel::BuildOptions::default().allow_compaction(choice.compact);
    options.preference = choice.preference;
    let gas = Gas::builder()
        .triangles(Triangles::new(&vertices).indices_u32(&indices).flags(raykit::GeometryFlags::OPAQUE))
        .options(options)
        .build(ctx)?;
    let gas = if choice.compact { gas.compact()? } else { gas };
    let ias = Ias::new(ctx, &[raykit::Instance::new(&gas).flags(choice.instance_flags)])?;
    let image = ctx.buffer::<u32>(width as usize * height as usize)?;
    let aspect = width as f32 / height as f32;
    // Half the footprint's width and height on the mesh's plane (one unit along `cam_w`).
    let (half_width, half_height) = match coverage {
        Coverage::AllHits => {
            let half_height = 0.45 / aspect.max(1.0);
            (half_height * aspect, half_height)
        }
        // A footprint of area 4 with the picture's aspect, centred on the unit mesh: the mesh
        // lies inside it when 2·sqrt(aspect) ≥ 1 and 2/sqrt(aspect) ≥ 1 (aspects from 1/4 to 4).
        Coverage::QuarterHits => (aspect.sqrt(), 1.0 / aspect.sqrt()),
    };
    let params = PrimaryParams {
        image: image.handle(),
        size: UVec2::new(width, height),
        cam_eye: Vec3::new(0.5, 0.5, 1.2),
        cam_u: Vec3::new(half_width, 0.0, 0.0),
        cam_v: Vec3::new(0.0, half_height, 0.0),
        cam_w: Vec3::new(0.0, 0.0, -1.2),
        _pad: 0,
        handle: ias.handle(),
    };
    Ok(PrimaryScene { ias, image, params })
}

/// How the primary-ray scene is built (`--primary-gas`, comma-separated):
/// `fast-trace` (default), `fast-build` or `neither`; `compact` (default) or
/// `no-compact`, as the OptiX twin's GAS is compacted; the instance's flags
/// `cull-disable` and `force-opaque` (default none).
#[derive(Clone, Copy, Debug)]
pub struct GasChoice {
    /// The GAS build's preference.
    pub preference: raykit::accel::BuildPreference,
    /// Whether the GAS is compacted after its build.
    pub compact: bool,
    /// The one instance's flags.
    pub instance_flags: raykit::InstanceFlags,
}

impl Default for GasChoice {
    fn default() -> GasChoice {
        GasChoice {
            preference: raykit::accel::BuildPreference::FastTrace,
            compact: true,
            instance_flags: raykit::InstanceFlags::NONE,
        }
    }
}

impl GasChoice {
    /// Parses `--primary-gas`'s value.
    pub fn parse(value: &str) -> anyhow::Result<GasChoice> {
        let mut c = GasChoice::default();
        for token in value.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            match token {
                "fast-trace" => c.preference = raykit::accel::BuildPreference::FastTrace,
                "fast-build" => c.preference = raykit::accel::BuildPreference::FastBuild,
                "neither" => c.preference = raykit::accel::BuildPreference::Neither,
                "compact" => c.compact = true,
                "no-compact" => c.compact = false,
                "cull-disable" => c.instance_flags = c.instance_flags | raykit::InstanceFlags::DISABLE_TRIANGLE_CULLING,
                "force-opaque" => c.instance_flags = c.instance_flags | raykit::InstanceFlags::FORCE_OPAQUE,
                other => anyhow::bail!(
                    "--primary-gas: unknown `{other}` (fast-trace, fast-build, neither, compact, no-compact, \
                     cull-disable, force-opaque)"
                ),
            }
        }
        Ok(c)
    }
}

/// The `primary` suite.
pub fn primary(ctx: &Context, timer: Option<&LaunchTimer>, opts: &Options) -> anyhow::Result<Vec<Row>> {
    let (width, height) = opts.primary_size;
    let rust = primary_pipeline(ctx, Language::Rust)?;
    let glsl = primary_pipeline(ctx, Language::Glsl)?;
    let wgsl = primary_pipeline(ctx, Language::Wgsl)?;
    let words = width as usize * height as usize;
    let ash = AshTracer::new(ctx, words)?;
    // The independent baseline: its own device on raykit's GPU, its own structures
    // over the same mesh (both scenes trace it; only the camera differs).
    let device = AshDevice::new(ctx)?;
    let (vertices, indices) = crate::accel::grid(opts.triangles);
    let vertices: Vec<[f32; 3]> = vertices.iter().map(|v| v.to_array()).collect();
    let independent = IndependentTracer::new(&device, &vertices, &indices, words)?;
    drop((vertices, indices));
    let mut out = Vec::new();
    for coverage in Coverage::BOTH {
        out.extend(primary_rows(ctx, timer, opts, coverage, [&rust, &glsl, &wgsl], &ash, &independent)?);
    }
    drop(independent);
    crate::ash_independent::ensure_no_validation_messages(ctx, &device)?;
    Ok(out)
}

/// The `primary` suite's rows for one scene.
fn primary_rows(
    ctx: &Context,
    timer: Option<&LaunchTimer>,
    opts: &Options,
    coverage: Coverage,
    [rust, glsl, wgsl]: [&PrimaryPipeline; 3],
    ash: &AshTracer<'_>,
    independent: &IndependentTracer<'_>,
) -> anyhow::Result<Vec<Row>> {
    let (width, height) = opts.primary_size;
    let built = Instant::now();
    let scene = opts.primary_scene(ctx, coverage)?;
    eprintln!("primary: {} triangles built in {:.1} s", opts.triangles, built.elapsed().as_secs_f64());
    let ash_params = AshTracer::params_with_output(bytemuck::bytes_of(&scene.params));
    let camera = Camera::of(&scene.params, PRIMARY_BACKGROUND);
    let rays = width as u64 * height as u64;
    let dims = [width, height, 1];
    let launch = |p: &PrimaryPipeline| -> anyhow::Result<(f64, u64)> {
        let s = match timer {
            Some(t) => seconds(p.pipeline.launch_timed(&p.sbt, &scene.params, dims, t)?),
            None => {
                let start = Instant::now();
                p.pipeline.launch(&p.sbt, &scene.params, dims)?;
                start.elapsed().as_secs_f64()
            }
        };
        Ok((s, rays))
    };
    let mut variants: Vec<Variant<'_>> = vec![
        ("Rust", Box::new(|| launch(rust))),
        ("GLSL", Box::new(|| launch(glsl))),
        ("WGSL", Box::new(|| launch(wgsl))),
        (ASH_INDEPENDENT, Box::new(|| Ok((independent.launch(&camera, dims)?, rays)))),
        (ASH_LAUNCH, Box::new(|| Ok((ash_launch(ash, rust, &ash_params, dims)?, rays)))),
    ];
    let results = interleave(&mut variants, opts.reps)?;
    drop(variants);
    // The programs drew a picture, and both ash baselines the same one.
    rust.pipeline.launch(&rust.sbt, &scene.params, [width, height, 1])?;
    let picture = scene.image.read()?;
    anyhow::ensure!(picture.iter().any(|&p| p != picture[0]), "the primary-ray image is uniform");
    if coverage == Coverage::QuarterHits {
        // The corner pixel misses; three pixels in four are the miss colour (up to the mesh's edge pixels).
        let misses = picture.iter().filter(|&&p| p == picture[0]).count() as f64 / picture.len() as f64;
        anyhow::ensure!((misses - 0.75).abs() < 0.02, "{:.1}% of primary rays missed, not 75%", misses * 100.0);
    }
    let differing = picture.iter().zip(ash.picture()?).filter(|(a, b)| **a != *b).count();
    anyhow::ensure!(differing == 0, "the ash launch of raykit's pipeline drew {differing} pixels unlike raykit's");
    let difference = Difference::of(&picture, &independent.picture()?, triangle_device::make_color(PRIMARY_BACKGROUND));
    anyhow::ensure!(
        difference.acceptable(),
        "the independent ash baseline's picture is not raykit's ({}): {difference}",
        coverage.label()
    );
    let setup = format!("{} triangles, {}, {width}x{height}, 1 ray/pixel", opts.triangles, coverage.label());
    Ok(rows("primary", &setup, timing_name(timer), &["Rust", "GLSL", "WGSL", ASH_INDEPENDENT, ASH_LAUNCH], &results))
}

/// One launch of the Rust primary-ray pipeline `p` through the hand-written
/// ash tracer (device-local output); its seconds.
pub fn ash_launch(ash: &AshTracer<'_>, p: &PrimaryPipeline, params: &[u8], dims: [u32; 3]) -> anyhow::Result<f64> {
    let pipeline = p.pipeline.raw_pipeline().context("the ash launch needs a Vulkan context")?;
    let layout = p.pipeline.raw_layout().context("the ash launch needs a Vulkan context")?;
    let regions = p.sbt.raw_regions().context("the ash launch needs a Vulkan context")?;
    anyhow::ensure!(p.pipeline.raw_push_constant_size() as usize == params.len(), "the params are not push constants");
    ash.launch(pipeline, layout, &regions, params, dims)
}

/// The `path` suite.
pub fn path(ctx: &Context, timer: Option<&LaunchTimer>, opts: &Options) -> anyhow::Result<Vec<Row>> {
    let scene = Scene::new(ctx)?;
    let size = opts.path_size;
    let mut rust = Renderer::new(ctx, &PathPrograms::rust(ctx)?, &scene, size, size)?;
    let mut glsl = Renderer::new(ctx, &PathPrograms::glsl(ctx)?, &scene, size, size)?;
    let mut wgsl = Renderer::new(ctx, &PathPrograms::wgsl(ctx)?, &scene, size, size)?;
    let spp = opts.spp;
    let launch = |r: &mut Renderer| -> anyhow::Result<(f64, u64)> {
        r.reset();
        let s = match timer {
            Some(t) => seconds(r.launch_timed(spp, t)?),
            None => {
                let start = Instant::now();
                r.launch(spp)?;
                start.elapsed().as_secs_f64()
            }
        };
        Ok((s, r.rays()?))
    };
    let mut variants: Vec<Variant<'_>> = vec![
        ("Rust", Box::new(|| launch(&mut rust))),
        ("GLSL", Box::new(|| launch(&mut glsl))),
        ("WGSL", Box::new(|| launch(&mut wgsl))),
    ];
    let results = interleave(&mut variants, opts.reps)?;
    drop(variants);
    let setup = format!("Cornell box, {size}x{size}, {spp} spp, max depth {}", path_tracer::device::scene::MAX_DEPTH);
    Ok(rows("path", &setup, timing_name(timer), &["Rust", "GLSL", "WGSL"], &results))
}

fn timing_name(timer: Option<&LaunchTimer>) -> &'static str {
    if timer.is_some() {
        "GPU timestamps"
    } else {
        "wall clock"
    }
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "raykit's variants (Rust, GLSL, WGSL) share their host code and acceleration structures; variants interleaved in rotating order after one warm-up launch each; median (± half the interquartile range); `vs GLSL` is the median of per-repetition ratios of Mrays/s (> 1: faster than the GLSL twin).\n\n",
    );
    let with_ash = rows.iter().any(|r| r.vs_ash.is_some());
    if with_ash {
        s.push_str("`ash (independent)` is the independent hand-written Vulkan baseline (`ash_independent.rs`): its own GLSL programs with a plain descriptor set, its own BLAS (not compacted) and one-instance TLAS, pipeline and SBT on its own `VkDevice`, device-local output; `vs ash (independent)` is the median of per-repetition ratios of Mrays/s to it (the Rust row: raykit / ash (independent)). `ash launch, raykit pipeline` launches raykit's own `VkPipeline`, SBT and TLAS by hand (`ash_baseline.rs`): raykit against it is what raykit's launch path costs.\n\n");
    }
    let (ash_head, ash_rule) = if with_ash { (" vs ash (independent) (min–max) |", "---:|") } else { ("", "") };
    s.push_str(&format!(
        "| suite | setup | programs | reps | rays/launch | ms/launch | Mrays/s | vs GLSL (min–max) |{ash_head} timing |\n"
    ));
    s.push_str(&format!("|---|---|---|---:|---:|---:|---:|---:|{ash_rule}---|\n"));
    for r in rows {
        let ash = match (&r.vs_ash, with_ash) {
            (Some(a), _) => format!(" {:.3} ({:.3}–{:.3}) |", a.median, a.min, a.max),
            (None, true) => " – |".to_owned(),
            (None, false) => String::new(),
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.2} ± {:.1}% | {:.2} | {:.3} ({:.3}–{:.3}) |{ash} {} |\n",
            r.suite,
            r.setup,
            r.variant,
            r.reps,
            r.rays,
            r.seconds.median * 1e3,
            r.seconds.spread_percent(),
            r.mrays.median,
            r.vs_glsl.median,
            r.vs_glsl.min,
            r.vs_glsl.max,
            r.timing
        ));
    }
    if with_ash {
        s.push_str(&summary(rows));
    }
    s
}

/// Per scene, raykit's Rust programs against the independent ash baseline and
/// against the by-hand launch of raykit's own pipeline.
fn summary(rows: &[Row]) -> String {
    let mut s = String::from(
        "\n| setup | raykit / ash (independent) (min–max) | raykit / ash launch of raykit's pipeline (min–max) |\n|---|---:|---:|\n",
    );
    let cell = |r: &Option<Summary>| {
        r.as_ref().map_or("–".to_owned(), |a| format!("{:.3} ({:.3}–{:.3})", a.median, a.min, a.max))
    };
    for r in rows.iter().filter(|r| r.variant == "Rust" && r.vs_ash.is_some()) {
        s.push_str(&format!("| {} | {} | {} |\n", r.setup, cell(&r.vs_ash), cell(&r.vs_ash_launch)));
    }
    s
}

/// The rows as JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "suite": r.suite, "setup": r.setup, "programs": r.variant, "reps": r.reps, "rays_per_launch": r.rays,
                    "seconds": r.seconds.json(), "mrays_per_s": r.mrays.json(), "vs_glsl": r.vs_glsl.json(),
                    "vs_ash_independent": r.vs_ash.map(|a| a.json()),
                    "vs_ash_launch_raykit_pipeline": r.vs_ash_launch.map(|a| a.json()), "timing": r.timing,
                })
            })
            .collect(),
    )
}
