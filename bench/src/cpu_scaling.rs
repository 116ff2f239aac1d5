//! The `cpu-scaling` suite: the CPU backend's primary rays at each thread count
//! of `--threads` (default 1, 2, 4, … up to the logical CPUs), beside Embree 3
//! on the same mesh, rays and thread count, one ray at a time
//! (`rtcIntersect1`) and in 16-wide packets (`rtcIntersect16`).
//!
//! Per thread count and scene (every ray hits; 25% of rays hit), a CPU
//! context of that many threads and the two Embree variants are timed by the
//! wall clock of whole launches, after one warm-up each, in an order that
//! rotates every repetition; ratios are medians of per-repetition ratios. The
//! pictures are checked as the `cpu` suite checks them. Not run unless named.

use std::time::Instant;

use raykit::{Backend, Context, ContextOptions};

use crate::stats::Summary;
use crate::trace::{primary_pipeline, Coverage, Language, Options};

/// One thread count on one scene.
pub struct Row {
    threads: usize,
    scene: &'static str,
    /// Mrays/s of the CPU backend, `rtcIntersect1` and `rtcIntersect16`.
    mrays: [Summary; 3],
    /// Per-repetition CPU backend / `rtcIntersect1` and / `rtcIntersect16`.
    over_embree: [Summary; 2],
    /// The CPU backend's median Mrays/s over its median at the first thread count.
    speed_up: f64,
}

/// The default thread counts: powers of two below the logical CPUs, then their count.
fn default_threads() -> Vec<usize> {
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut counts: Vec<usize> = std::iter::successors(Some(1), |n| Some(n * 2)).take_while(|&n| n < cpus).collect();
    counts.push(cpus);
    counts
}

/// Runs the suite; `threads` is `--threads` (empty: the default counts).
pub fn run(opts: &Options, threads: &[usize]) -> anyhow::Result<Vec<Row>> {
    let threads = if threads.is_empty() { default_threads() } else { threads.to_vec() };
    let (vertices, indices) = crate::accel::grid(opts.triangles);
    let embree = crate::embree::Scene::new(&vertices, &indices)
        .map_err(|e| anyhow::anyhow!("the cpu-scaling suite needs Embree 3: {e}"))?;
    let (width, height) = opts.primary_size;
    let rays = u64::from(width) * u64::from(height);
    let mut rows: Vec<Row> = Vec::new();
    for &count in &threads {
        let cpu = Context::new(ContextOptions {
            backend: Some(Backend::Cpu),
            cpu_threads: Some(count),
            ..Default::default()
        })?;
        let pipeline = primary_pipeline(&cpu, Language::Rust)?;
        for coverage in Coverage::BOTH {
            let scene = opts.primary_scene(&cpu, coverage)?;
            let mut images = [vec![0u32; rays as usize], vec![0u32; rays as usize]];
            let mut launch = |variant: usize| -> anyhow::Result<f64> {
                let start = Instant::now();
                match variant {
                    0 => pipeline.pipeline.launch(&pipeline.sbt, &scene.params, [width, height, 1])?,
                    v => embree.trace(&scene.params, opts.primary_size, count, v == 2, &mut images[v - 1]),
                }
                Ok(start.elapsed().as_secs_f64())
            };
            for variant in 0..3 {
                launch(variant)?;
            }
            let mut seconds: [Vec<f64>; 3] = Default::default();
            for rep in 0..opts.reps {
                for k in 0..3 {
                    let variant = (rep + k) % 3;
                    seconds[variant].push(launch(variant)?);
                }
            }
            let ours = scene.image.read()?;
            for (image, name) in images.iter().zip(["rtcIntersect1", "rtcIntersect16"]) {
                let differing = crate::cpu::differing_pixels(image, &ours);
                anyhow::ensure!(
                    differing <= ours.len() / 1000,
                    "{differing} pixels differ between Embree's {name} and the CPU backend ({count} threads)"
                );
            }
            let mrays = |s: &[f64]| -> Vec<f64> { s.iter().map(|s| rays as f64 / s / 1e6).collect() };
            let per_rep = |other: usize| -> Summary {
                let ratios: Vec<f64> = seconds[other].iter().zip(&seconds[0]).map(|(o, c)| o / c).collect();
                Summary::of(&ratios)
            };
            let mrays_summaries = [0, 1, 2].map(|v| Summary::of(&mrays(&seconds[v])));
            let first = rows.iter().find(|r| r.scene == coverage.label()).map(|r| r.mrays[0].median);
            rows.push(Row {
                threads: count,
                scene: coverage.label(),
                speed_up: first.map_or(1.0, |f| mrays_summaries[0].median / f),
                mrays: mrays_summaries,
                over_embree: [per_rep(1), per_rep(2)],
            });
        }
    }
    Ok(rows)
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row], opts: &Options) -> String {
    let (width, height) = opts.primary_size;
    let mut s = format!(
        "Primary rays, {} triangles, {width}x{height}, 1 ray/pixel; the same mesh and rays through Embree 3 on as many threads; wall clock of whole launches, median Mrays/s; `CPU / Embree` is the median of per-repetition ratios (min–max); speed-up is over the first thread count's CPU-backend row.\n\n",
        opts.triangles
    );
    s.push_str("| threads | scene | CPU backend | rtcIntersect1 | rtcIntersect16 | CPU / rtcIntersect1 | CPU / rtcIntersect16 | CPU speed-up |\n");
    s.push_str("|---:|---|---:|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let ratio = |x: &Summary| format!("{:.2} ({:.2}–{:.2})", x.median, x.min, x.max);
        s.push_str(&format!(
            "| {} | {} | {:.1} | {:.1} | {:.1} | {} | {} | {:.2}× |\n",
            r.threads,
            r.scene,
            r.mrays[0].median,
            r.mrays[1].median,
            r.mrays[2].median,
            ratio(&r.over_embree[0]),
            ratio(&r.over_embree[1]),
            r.speed_up
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
                    "threads": r.threads, "scene": r.scene,
                    "mrays_per_s": { "cpu": r.mrays[0].json(), "embree1": r.mrays[1].json(), "embree16": r.mrays[2].json() },
                    "cpu_over_embree1": r.over_embree[0].json(), "cpu_over_embree16": r.over_embree[1].json(),
                    "cpu_speed_up": r.speed_up,
                })
            })
            .collect(),
    )
}
