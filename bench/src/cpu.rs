//! The `cpu` suite: the CPU backend against the Vulkan device in use (lavapipe on
//! a machine without a GPU), side by side in one run, with the same Rust device
//! programs, scenes and host code.
//!
//! * primary rays: the `primary` suite's mesh (`--triangles`, default 1,000,000)
//!   at `--primary-size` (default 1920x1080), optixTriangle's programs;
//! * the path tracer: the Cornell box at `--path-size` (default 512) with 16
//!   paths per pixel in one launch (`--spp N` for another count).
//!
//! On the primary-ray scenes the CPU backend is also measured against Embree 3
//! (`crate::embree`: the same mesh and rays, on as many threads, one ray at a
//! time and in 16-wide packets), when `libembree3-3` is installed.
//!
//! Each pair is timed by the wall clock of the whole launch (submission and
//! wait included), interleaved after one warm-up launch each; the ratio is the
//! median of per-repetition ratios of Mrays/s, CPU backend over the pair's
//! baseline (Vulkan, or Embree).

use std::time::Instant;

use path_tracer::{Programs as PathPrograms, Renderer, Scene};
use raykit::{Backend, Context, ContextOptions};

use crate::stats::Summary;
use crate::trace::{primary_pipeline, Coverage, Language, Options};

/// One measurement: a backend on one workload.
pub struct Row {
    workload: String,
    backend: String,
    reps: usize,
    rays: u64,
    seconds: Summary,
    mrays: Summary,
    /// Per-repetition ratio of the CPU backend's Mrays/s to its baseline's (Vulkan's or Embree's).
    cpu_over_baseline: Summary,
}

/// Runs `vulkan` and `cpu` once each to warm up, then `reps` rounds in
/// alternating order; returns per backend the (seconds, rays) of each round.
fn interleave(
    reps: usize,
    mut vulkan: impl FnMut() -> anyhow::Result<(f64, u64)>,
    mut cpu: impl FnMut() -> anyhow::Result<(f64, u64)>,
) -> anyhow::Result<[Vec<(f64, u64)>; 2]> {
    vulkan()?;
    cpu()?;
    let (mut v, mut c) = (Vec::new(), Vec::new());
    for rep in 0..reps {
        let (a, b) = crate::launch::pair(rep, &mut vulkan, &mut cpu)?;
        v.push(a);
        c.push(b);
    }
    Ok([v, c])
}

fn rows(workload: &str, names: [&str; 2], results: &[Vec<(f64, u64)>; 2]) -> Vec<Row> {
    let mrays = |r: &[(f64, u64)]| -> Vec<f64> { r.iter().map(|(s, n)| *n as f64 / s / 1e6).collect() };
    let (v, c) = (mrays(&results[0]), mrays(&results[1]));
    let ratio: Vec<f64> = c.iter().zip(&v).map(|(c, v)| c / v).collect();
    names
        .iter()
        .zip(results)
        .map(|(name, r)| Row {
            workload: workload.to_owned(),
            backend: (*name).to_owned(),
            reps: r.len(),
            rays: r.first().map_or(0, |x| x.1),
            seconds: Summary::of(&r.iter().map(|x| x.0).collect::<Vec<_>>()),
            mrays: Summary::of(&mrays(r)),
            cpu_over_baseline: Summary::of(&ratio),
        })
        .collect()
}

/// The `cpu` suite on the Vulkan context `vulkan` and a CPU context made here.
pub fn run(vulkan: &Context, opts: &Options) -> anyhow::Result<Vec<Row>> {
    let cpu = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?;
    let names = [format!("Vulkan ({})", vulkan.device_name()), format!("CPU backend ({})", cpu.device_name())];
    let names = [names[0].as_str(), names[1].as_str()];
    let mut out = Vec::new();

    // Primary rays, on the scene every ray hits and on the one most rays miss.
    let embree = {
        let (vertices, indices) = crate::accel::grid(opts.triangles);
        crate::embree::Scene::new(&vertices, &indices)
    };
    let (pv, pc) = (primary_pipeline(vulkan, Language::Rust)?, primary_pipeline(&cpu, Language::Rust)?);
    for coverage in Coverage::BOTH {
        let (width, height) = opts.primary_size;
        let dims = [width, height, 1];
        let rays = u64::from(width) * u64::from(height);
        let built = Instant::now();
        let scene_v = opts.primary_scene(vulkan, coverage)?;
        let vulkan_build = built.elapsed().as_secs_f64();
        let built = Instant::now();
        let scene_c = opts.primary_scene(&cpu, coverage)?;
        let cpu_build = built.elapsed().as_secs_f64();
        eprintln!("cpu: {} triangles built in {vulkan_build:.2} s (Vulkan) and {cpu_build:.2} s (CPU)", opts.triangles);
        let launch_cpu = || timed(rays, || Ok(pc.pipeline.launch(&pc.sbt, &scene_c.params, dims)?));
        let launch_vulkan = || timed(rays, || Ok(pv.pipeline.launch(&pv.sbt, &scene_v.params, dims)?));
        let results = interleave(opts.reps, launch_vulkan, launch_cpu)?;
        // Both backends drew the same picture (barycentric colours, within rounding).
        let (a, b) = (scene_v.image.read()?, scene_c.image.read()?);
        let differing = differing_pixels(&a, &b);
        anyhow::ensure!(differing <= a.len() / 1000, "{differing} primary-ray pixels differ between the backends");
        let workload =
            format!("primary: {} triangles, {}, {width}x{height}, 1 ray/pixel", opts.triangles, coverage.label());
        out.extend(rows(&workload, names, &results));

        // The same mesh and rays through Embree, single rays and 16-wide packets.
        let embree = match &embree {
            Ok(scene) => scene,
            Err(e) => {
                eprintln!("cpu: no Embree rows: {e}");
                continue;
            }
        };
        let threads = cpu_threads();
        for (packets, name) in [(false, "Embree 3 rtcIntersect1"), (true, "Embree 3 rtcIntersect16")] {
            let mut image = vec![0u32; rays as usize];
            let launch_embree = || {
                timed(rays, || {
                    embree.trace(&scene_c.params, opts.primary_size, threads, packets, &mut image);
                    Ok(())
                })
            };
            let results = interleave(opts.reps, launch_embree, launch_cpu)?;
            // The same hits: the same barycentric colours and misses, within rounding.
            let differing = differing_pixels(&image, &b);
            anyhow::ensure!(
                differing <= b.len() / 1000,
                "{differing} pixels differ between {name} and the CPU backend"
            );
            let name = format!("{name} ({threads} threads)");
            out.extend(rows(&workload, [name.as_str(), names[1]], &results));
        }
    }

    // Built-in spheres, hit through an intersection program.
    let (width, height) = (opts.primary_size.0 / 2, opts.primary_size.1 / 2);
    let (sv, sc) = (SphereScene::new(vulkan, width, height)?, SphereScene::new(&cpu, width, height)?);
    let results = interleave(opts.reps, || sv.launch(), || sc.launch())?;
    let (hv, hc) = (sv.hits()?, sc.hits()?);
    let differing = hv.iter().zip(&hc).filter(|(a, b)| a != b).count();
    anyhow::ensure!(differing <= hv.len() / 1000, "{differing} sphere rays hit differently on the two backends");
    let hit = hv.iter().filter(|h| h.0 != spheres_test_device::MISS).count();
    let workload = format!(
        "spheres: {} built-in spheres (intersection program), {width}x{height}, 1 ray/pixel, {:.0}% hit",
        SPHERES * SPHERES,
        100.0 * hit as f64 / hv.len() as f64
    );
    out.extend(rows(&workload, names, &results));

    // The path tracer.
    let size = opts.path_size;
    let spp = if opts.spp == 1 { 16 } else { opts.spp };
    let (scene_v, scene_c) = (Scene::new(vulkan)?, Scene::new(&cpu)?);
    let mut rv = Renderer::new(vulkan, &PathPrograms::rust(vulkan)?, &scene_v, size, size)?;
    let mut rc = Renderer::new(&cpu, &PathPrograms::rust(&cpu)?, &scene_c, size, size)?;
    let launch = |r: &mut Renderer| -> anyhow::Result<(f64, u64)> {
        r.reset();
        let start = Instant::now();
        r.launch(spp)?;
        let seconds = start.elapsed().as_secs_f64();
        Ok((seconds, r.rays()?))
    };
    let results = interleave(opts.reps, || launch(&mut rv), || launch(&mut rc))?;
    // The same paths: the programs and their random numbers are the same.
    let (nv, nc) = (results[0][0].1, results[1][0].1);
    anyhow::ensure!(nv.abs_diff(nc) * 100 <= nv, "the path tracer traced {nv} rays on Vulkan and {nc} on the CPU");
    let workload = format!("path tracer: Cornell box, {size}x{size}, {spp} spp");
    out.extend(rows(&workload, names, &results));
    Ok(out)
}

/// Spheres per side of the sphere scene's grid.
const SPHERES: usize = 100;

/// A grid of `SPHERES²` built-in spheres (radius 0.4 to 0.5, one unit apart,
/// heights varying) seen from above by one camera ray per pixel, through
/// `spheres-test-device`'s programs (the library's sphere test and a
/// closest-hit program recording the hit).
struct SphereScene {
    pipeline: raykit::Pipeline<spheres_test_device::Params>,
    sbt: raykit::Sbt,
    params: spheres_test_device::Params,
    rays: usize,
    hits: raykit::DeviceBuffer<raykit::glam::Vec4>,
    _inputs: (raykit::Ias, raykit::DeviceBuffer<raykit::glam::Vec4>),
}

impl SphereScene {
    fn new(ctx: &Context, width: u32, height: u32) -> anyhow::Result<SphereScene> {
        use raykit::glam::{Vec3, Vec4};
        use raykit::{Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
        use spheres_test_device as programs;
        let n = SPHERES as f32;
        let (mut centres, mut radii) = (Vec::new(), Vec::new());
        for (i, j) in (0..SPHERES).flat_map(|i| (0..SPHERES).map(move |j| (i, j))) {
            let (x, y) = (i as f32, j as f32);
            centres.push(Vec3::new(x, y, 0.5 * ((0.3 * x).sin() + (0.2 * y).cos())));
            radii.push(0.4 + 0.1 * ((x * 7.0 + y * 3.0) % 5.0) / 5.0);
        }
        let gas = Gas::spheres(ctx, &centres, &radii)?;
        let record =
            programs::SphereRecord { spheres: gas.sphere_buffer().ok_or_else(|| anyhow::anyhow!("no spheres"))? };
        let scene = Ias::single(ctx, &gas)?;
        let module = Module::from_device_crate(ctx, "spheres-test-device")?;
        let raygen = ProgramGroup::raygen(&module, programs::RG)?;
        let miss = ProgramGroup::miss(&module, programs::MS)?;
        let hit = ProgramGroup::hit_group(&module)
            .intersection(programs::IS_SPHERE)
            .closest_hit(programs::CH_SPHERE)
            .build()?;
        let pipeline =
            Pipeline::<programs::Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, record).build()?;
        // From above the grid's centre, seeing only the grid: most rays hit a sphere, some pass between.
        let eye = Vec3::new(n / 2.0, n / 2.0, 0.55 * n);
        let mut words = Vec::with_capacity(width as usize * height as usize * programs::RAY_WORDS as usize);
        for (y, x) in (0..height).flat_map(|y| (0..width).map(move |x| (y, x))) {
            let s = (x as f32 + 0.5) / width as f32 - 0.5;
            let t = (y as f32 + 0.5) / height as f32 - 0.5;
            let direction = Vec3::new(s * width as f32 / height as f32, t, -1.0).normalize();
            words.extend([eye.extend(0.0), direction.extend(1e16), Vec4::ZERO]);
        }
        let rays = words.len() / programs::RAY_WORDS as usize;
        let input = ctx.buffer_from(&words)?;
        let hits = ctx.buffer::<Vec4>(rays * programs::HIT_WORDS as usize)?;
        let params = programs::Params { rays: input.handle(), hits: hits.handle(), scene: scene.handle() };
        Ok(SphereScene { pipeline, sbt, params, rays, hits, _inputs: (scene, input) })
    }

    fn launch(&self) -> anyhow::Result<(f64, u64)> {
        timed(self.rays as u64, || Ok(self.pipeline.launch(&self.sbt, &self.params, [self.rays as u32, 1, 1])?))
    }

    /// Per ray: the hit kind (or `MISS`) and the sphere.
    fn hits(&self) -> anyhow::Result<Vec<(u32, u32)>> {
        let words = self.hits.read()?;
        Ok(words.chunks(spheres_test_device::HIT_WORDS as usize).map(|w| (w[0].y as u32, w[0].z as u32)).collect())
    }
}

/// The CPU backend's thread count, by the rule its context follows:
/// `RAYKIT_CPU_THREADS`, else one per logical CPU.
fn cpu_threads() -> usize {
    std::env::var("RAYKIT_CPU_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n: &usize| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// The wall-clock seconds of `launch`, and the rays it traces.
fn timed(rays: u64, launch: impl FnOnce() -> anyhow::Result<()>) -> anyhow::Result<(f64, u64)> {
    let start = Instant::now();
    launch()?;
    Ok((start.elapsed().as_secs_f64(), rays))
}

/// How many RGBA8 pixels of two pictures differ by more than two steps in a channel.
pub(crate) fn differing_pixels(a: &[u32], b: &[u32]) -> usize {
    a.iter().zip(b).filter(|(x, y)| channel_distance(**x, **y) > 2).count()
}

fn channel_distance(a: u32, b: u32) -> u8 {
    a.to_le_bytes().iter().zip(b.to_le_bytes()).map(|(x, y)| x.abs_diff(y)).max().unwrap_or(0)
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "Same Rust device programs, scenes and host code on both backends; wall clock of whole launches, alternating after one warm-up each; median (± half the interquartile range); `CPU / baseline` is the median of per-repetition ratios of Mrays/s, the CPU backend over the other row of its pair (Vulkan, or Embree on the same mesh, rays and thread count).\n\n",
    );
    s.push_str("| workload | backend | reps | rays/launch | ms/launch | Mrays/s | CPU / baseline (min–max) |\n");
    s.push_str("|---|---|---:|---:|---:|---:|---:|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.1} ± {:.1}% | {:.2} | {:.2} ({:.2}–{:.2}) |\n",
            r.workload,
            r.backend,
            r.reps,
            r.rays,
            r.seconds.median * 1e3,
            r.seconds.spread_percent(),
            r.mrays.median,
            r.cpu_over_baseline.median,
            r.cpu_over_baseline.min,
            r.cpu_over_baseline.max,
        ));
    }
    s
}

/// The rows as JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "workload": r.workload, "backend": r.backend, "reps": r.reps, "rays_per_launch": r.rays,
                    "seconds": r.seconds.json(), "mrays_per_s": r.mrays.json(), "cpu_over_baseline": r.cpu_over_baseline.json(),
                })
            })
            .collect(),
    )
}
