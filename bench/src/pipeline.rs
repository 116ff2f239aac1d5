//! The `pipeline` suite: pipeline creation (`Pipeline::new`, i.e.
//! `vkCreateRayTracingPipelinesKHR` plus raykit's checks) with the compile cache
//! off, cold (an empty cache directory) and warm (the file the cold run saved,
//! loaded by a fresh context). Each sample uses a fresh context, so no in-memory
//! cache carries over; modules and groups are made outside the timed part.
//!
//! The second table compares, with the cache off, one `Pipeline::new` of all
//! groups (monolithic) with the same pipeline made from two pipeline libraries
//! (the raygen group, and the other groups) and `Pipeline::link`: the libraries
//! and the link together, and the link alone (the cost of one more pipeline
//! when its libraries already exist, OptiX's groups reused across pipelines).

use std::path::{Path, PathBuf};
use std::time::Instant;

use raykit::{
    CacheLoad, Context, ContextOptions, LaunchParams, LibraryOptions, LinkOptions, Module, Pipeline,
    PipelineCacheLocation, PipelineLibrary, ProgramGroup,
};

use crate::stats::Summary;

/// One pipeline's creation times, in milliseconds.
pub struct Row {
    /// What the pipeline is.
    pub name: &'static str,
    /// Cache off.
    pub off: Summary,
    /// Empty cache.
    pub cold: Summary,
    /// Cache loaded from disk.
    pub warm: Summary,
    /// Bytes of the saved cache file's data, as the warm context loaded it.
    pub cache_bytes: usize,
    /// Cache off: `Pipeline::new` of all groups.
    pub monolithic: Summary,
    /// Cache off: two libraries and `Pipeline::link`.
    pub libraries_and_link: Summary,
    /// Cache off: `Pipeline::link` of existing libraries.
    pub link_only: Summary,
}

const PIPELINES: [&str; 2] = ["triangle (3 groups)", "program-model spheres (4 groups, intersection)"];

/// Creation times of one pipeline made three ways, in milliseconds.
#[derive(Copy, Clone, Debug)]
struct Linking {
    /// `Pipeline::new` of all groups.
    monolithic: f64,
    /// Both libraries and the link.
    libraries_and_link: f64,
    /// The link alone.
    link: f64,
}

/// The groups of pipeline `which` (raygen first), made in `ctx`, given to `f`
/// with the pipeline's params type.
fn with_groups<R>(ctx: &Context, which: usize, f: impl GroupsFn<R>) -> anyhow::Result<R> {
    if which == 0 {
        let module = Module::from_device_crate(ctx, "triangle-device")?;
        let rg = ProgramGroup::raygen(&module, triangle_device::RG)?;
        let ms = ProgramGroup::miss(&module, triangle_device::MS)?;
        let ch = ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?;
        return f.call::<triangle_device::Params>(ctx, &[&rg, &ms, &ch]);
    }
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let rg = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let ms = ProgramGroup::miss(&module, program_model_device::MS)?;
    let sphere = ProgramGroup::hit_group(&module)
        .intersection(program_model_device::SPHERE)
        .closest_hit(program_model_device::SPHERE_SHADE)
        .build()?;
    let cutout = ProgramGroup::hit_group(&module)
        .any_hit(program_model_device::CUTOUT)
        .closest_hit(program_model_device::CUTOUT_SHADE)
        .build()?;
    f.call::<program_model_device::Params>(ctx, &[&rg, &ms, &sphere, &cutout])
}

/// A function of a pipeline's groups, generic over its params type.
trait GroupsFn<R> {
    fn call<P: LaunchParams>(self, ctx: &Context, groups: &[&ProgramGroup]) -> anyhow::Result<R>;
}

/// Times `Pipeline::new`.
struct Monolithic;
impl GroupsFn<f64> for Monolithic {
    fn call<P: LaunchParams>(self, ctx: &Context, groups: &[&ProgramGroup]) -> anyhow::Result<f64> {
        let start = Instant::now();
        let _p = Pipeline::<P>::new(ctx, groups, LinkOptions { max_trace_depth: 1 })?;
        Ok(start.elapsed().as_secs_f64() * 1e3)
    }
}

/// Times the libraries and two links of them: `(libraries and link, link)`.
struct FromLibraries;
impl GroupsFn<(f64, f64)> for FromLibraries {
    fn call<P: LaunchParams>(self, ctx: &Context, groups: &[&ProgramGroup]) -> anyhow::Result<(f64, f64)> {
        let options =
            LibraryOptions { max_trace_depth: 1, interface: Some(PipelineLibrary::<P>::interface_for(groups)) };
        let link = LinkOptions { max_trace_depth: 1 };
        let start = Instant::now();
        let raygen = PipelineLibrary::<P>::new(ctx, &groups[..1], options)?;
        let rest = PipelineLibrary::<P>::new(ctx, &groups[1..], options)?;
        let _first = Pipeline::<P>::link(ctx, &[&raygen, &rest], link)?;
        let libraries_and_link = start.elapsed().as_secs_f64() * 1e3;
        let start = Instant::now();
        let _second = Pipeline::<P>::link(ctx, &[&raygen, &rest], link)?;
        Ok((libraries_and_link, start.elapsed().as_secs_f64() * 1e3))
    }
}

/// Makes pipeline `which` in `ctx`; returns the milliseconds `Pipeline::new` took.
fn create_ms(ctx: &Context, which: usize) -> anyhow::Result<f64> {
    with_groups(ctx, which, Monolithic)
}

fn context(device: Option<&str>, cache: PipelineCacheLocation) -> anyhow::Result<Context> {
    Ok(Context::new(ContextOptions {
        validation: Some(false),
        device_name_contains: device.map(str::to_owned),
        pipeline_cache: cache,
        ..Default::default()
    })?)
}

fn fresh_dir(root: &Path, name: String) -> anyhow::Result<PathBuf> {
    let dir = root.join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// Runs the suite with `reps` samples per pipeline and cache state (default 5).
pub fn run(device: Option<&str>, reps: Option<usize>) -> anyhow::Result<Vec<Row>> {
    let reps = reps.unwrap_or(5).max(1);
    let root = std::env::temp_dir().join(format!("raykit-bench-pipeline-{}", std::process::id()));
    let result = (|| {
        let mut rows = Vec::new();
        for (which, name) in PIPELINES.iter().enumerate() {
            let (mut off, mut cold, mut warm) = (Vec::new(), Vec::new(), Vec::new());
            let mut cache_bytes = 0;
            for rep in 0..reps {
                off.push(create_ms(&context(device, PipelineCacheLocation::Off)?, which)?);
                let dir = fresh_dir(&root, format!("{which}-{rep}"))?;
                {
                    let ctx = context(device, PipelineCacheLocation::Dir(dir.clone()))?;
                    cold.push(create_ms(&ctx, which)?);
                    ctx.save_pipeline_cache()?;
                }
                let ctx = context(device, PipelineCacheLocation::Dir(dir))?;
                let load = ctx.pipeline_cache_info().load;
                let CacheLoad::Loaded { bytes } = load else {
                    anyhow::bail!("{name}: the warm cache was not loaded: {load:?}")
                };
                cache_bytes = bytes;
                warm.push(create_ms(&ctx, which)?);
            }
            let mut linking = Vec::new();
            for rep in 0..reps {
                // Each way in its own fresh context, so neither reuses what the
                // other compiled; which goes first alternates.
                let monolithic_ctx = || -> anyhow::Result<f64> {
                    with_groups(&context(device, PipelineCacheLocation::Off)?, which, Monolithic)
                };
                let libraries_ctx = || -> anyhow::Result<(f64, f64)> {
                    let ctx = context(device, PipelineCacheLocation::Off)?;
                    if !ctx.supports_pipeline_libraries() {
                        anyhow::bail!("{} lacks VK_KHR_pipeline_library", ctx.device_name());
                    }
                    with_groups(&ctx, which, FromLibraries)
                };
                let (monolithic, (libraries_and_link, link)) = if rep % 2 == 0 {
                    let m = monolithic_ctx()?;
                    (m, libraries_ctx()?)
                } else {
                    let l = libraries_ctx()?;
                    (monolithic_ctx()?, l)
                };
                linking.push(Linking { monolithic, libraries_and_link, link });
            }
            let of = |f: fn(&Linking) -> f64| Summary::of(&linking.iter().map(f).collect::<Vec<_>>());
            rows.push(Row {
                name,
                off: Summary::of(&off),
                cold: Summary::of(&cold),
                warm: Summary::of(&warm),
                cache_bytes,
                monolithic: of(|l| l.monolithic),
                libraries_and_link: of(|l| l.libraries_and_link),
                link_only: of(|l| l.link),
            });
        }
        Ok(rows)
    })();
    let _ = std::fs::remove_dir_all(&root);
    result
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s =
        format!("Pipeline creation on {device}, milliseconds (median [p25–p75]), fresh context per sample.\n\n");
    s.push_str("| pipeline | cache off | cold cache | warm cache | warm / cold | cache data |\n|---|---:|---:|---:|---:|---:|\n");
    let f = |x: &Summary| format!("{:.2} [{:.2}–{:.2}]", x.median, x.p25, x.p75);
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {} B |\n",
            r.name,
            f(&r.off),
            f(&r.cold),
            f(&r.warm),
            r.warm.median / r.cold.median,
            r.cache_bytes
        ));
    }
    s.push_str("\nMonolithic pipeline against pipeline libraries (raygen | other groups) and `Pipeline::link`, cache off, milliseconds (median [p25–p75]).\n\n");
    s.push_str("| pipeline | monolithic | libraries + link | link only | (libraries + link) / monolithic | link / monolithic |\n|---|---:|---:|---:|---:|---:|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} |\n",
            r.name,
            f(&r.monolithic),
            f(&r.libraries_and_link),
            f(&r.link_only),
            r.libraries_and_link.median / r.monolithic.median,
            r.link_only.median / r.monolithic.median
        ));
    }
    s.push('\n');
    s
}

/// The rows as JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "pipeline": r.name, "off_ms": r.off.json(), "cold_ms": r.cold.json(),
                    "warm_ms": r.warm.json(), "cache_bytes": r.cache_bytes,
                    "monolithic_ms": r.monolithic.json(), "libraries_and_link_ms": r.libraries_and_link.json(),
                    "link_only_ms": r.link_only.json(),
                })
            })
            .collect(),
    )
}
