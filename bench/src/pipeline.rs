//! The `pipeline` suite: pipeline creation (`Pipeline::new`, i.e.
//! `vkCreateRayTracingPipelinesKHR` plus raykit's checks) with the compile cache
//! off, cold (an empty cache directory) and warm (the file the cold run saved,
//! loaded by a fresh context). Each sample uses a fresh context, so no in-memory
//! cache carries over; modules and groups are made outside the timed part.
//!
//! Pipeline libraries (monolithic vs linked) are not measured yet: raykit has no
//! `VK_KHR_pipeline_library` support so far.

use std::path::{Path, PathBuf};
use std::time::Instant;

use raykit::{CacheLoad, Context, ContextOptions, LinkOptions, Module, Pipeline, PipelineCacheLocation, ProgramGroup};

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
}

const PIPELINES: [&str; 2] = ["triangle (3 groups)", "program-model spheres (4 groups, intersection)"];

/// Makes pipeline `which` in `ctx`; returns the milliseconds `Pipeline::new` took.
fn create_ms(ctx: &Context, which: usize) -> anyhow::Result<f64> {
    if which == 0 {
        let module = Module::from_device_crate(ctx, "triangle-device")?;
        let rg = ProgramGroup::raygen(&module, triangle_device::RG)?;
        let ms = ProgramGroup::miss(&module, triangle_device::MS)?;
        let ch = ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?;
        let start = Instant::now();
        let _p = Pipeline::<triangle_device::Params>::new(ctx, &[&rg, &ms, &ch], LinkOptions { max_trace_depth: 1 })?;
        return Ok(start.elapsed().as_secs_f64() * 1e3);
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
    let start = Instant::now();
    let _p = Pipeline::<program_model_device::Params>::new(ctx, &[&rg, &ms, &sphere, &cutout], LinkOptions { max_trace_depth: 1 })?;
    Ok(start.elapsed().as_secs_f64() * 1e3)
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
                let CacheLoad::Loaded { bytes } = load else { anyhow::bail!("{name}: the warm cache was not loaded: {load:?}") };
                cache_bytes = bytes;
                warm.push(create_ms(&ctx, which)?);
            }
            rows.push(Row { name, off: Summary::of(&off), cold: Summary::of(&cold), warm: Summary::of(&warm), cache_bytes });
        }
        Ok(rows)
    })();
    let _ = std::fs::remove_dir_all(&root);
    result
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s = format!("Pipeline creation on {device}, milliseconds (median [p25–p75]), fresh context per sample.\n\n");
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
                })
            })
            .collect(),
    )
}
