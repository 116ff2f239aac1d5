//! The `accel` suite: GAS build throughput of raykit against the hand-written ash
//! build of the same input, in the same run, interleaved; and memory before and
//! after compaction.

use std::time::Instant;

use raykit::accel::BuildOptions;
use raykit::glam::Vec3;
use raykit::{Context, Gas, Triangles};

use crate::ash_baseline::AshDevice;
use crate::stats::Summary;

/// One mesh size's results.
pub struct Row {
    /// Triangles built.
    pub triangles: usize,
    /// Repetitions of each side.
    pub reps: usize,
    /// raykit's build times in seconds.
    pub raykit: Summary,
    /// The ash baseline's build times in seconds.
    pub ash: Summary,
    /// The ash baseline's build times with fresh structure memory each build.
    pub ash_fresh: Summary,
    /// Per-pair time ratios raykit / ash with fresh memory.
    pub ratio_fresh: Summary,
    /// Per-pair time ratios raykit / ash.
    pub ratio: Summary,
    /// GPU time of the baseline's build command alone, seconds (timestamps, in
    /// three extra builds outside the comparison).
    pub ash_gpu: Option<Summary>,
    /// raykit's structure size before compaction.
    pub raykit_size: u64,
    /// Scratch bytes of the build.
    pub scratch: u64,
    /// raykit's structure size after compaction.
    pub raykit_compacted: u64,
    /// The baseline's sizes before and after compaction.
    pub ash_size: u64,
    /// The baseline's compacted size.
    pub ash_compacted: u64,
}

/// A `triangles`-triangle height field over a square grid, indexed.
pub fn grid(triangles: usize) -> (Vec<Vec3>, Vec<u32>) {
    let quads = triangles.div_ceil(2);
    let side = (quads as f64).sqrt().ceil() as u32;
    let rows = (quads as u32).div_ceil(side);
    let mut vertices = Vec::with_capacity(((side + 1) * (rows + 1)) as usize);
    for y in 0..=rows {
        for x in 0..=side {
            let (fx, fy) = (x as f32 / side as f32, y as f32 / side as f32);
            vertices.push(Vec3::new(fx, fy, 0.05 * (fx * 37.0).sin() * (fy * 23.0).cos()));
        }
    }
    let mut indices = Vec::with_capacity(triangles * 3);
    'outer: for y in 0..rows {
        for x in 0..side {
            let i = y * (side + 1) + x;
            for tri in [[i, i + 1, i + side + 1], [i + 1, i + side + 2, i + side + 1]] {
                if indices.len() == triangles * 3 {
                    break 'outer;
                }
                indices.extend_from_slice(&tri);
            }
        }
    }
    (vertices, indices)
}

/// Runs the suite for each size.
pub fn run(ctx: &Context, ash: &AshDevice, sizes: &[usize], reps: Option<usize>) -> anyhow::Result<Vec<Row>> {
    let options = BuildOptions::default().fast_trace().allow_compaction(true);
    let mut rows = Vec::new();
    for &n in sizes {
        let (vertices, indices) = grid(n);
        let arrays: Vec<[f32; 3]> = vertices.iter().map(|v| v.to_array()).collect();
        let reps = reps.unwrap_or(if n >= 1_000_000 {
            5
        } else if n >= 100_000 {
            9
        } else {
            15
        });
        let build_raykit = || -> anyhow::Result<(f64, Gas)> {
            let t = Instant::now();
            let gas = Gas::builder()
                .triangles(Triangles::new(&vertices).indices_u32(&indices))
                .options(options)
                .build(ctx)?;
            Ok((t.elapsed().as_secs_f64(), gas))
        };
        let build_ash = |reuse: bool| -> anyhow::Result<(f64, raykit_ash::Gas)> {
            let t = Instant::now();
            let gas = ash.build_gas(&arrays, &indices, false, reuse)?;
            Ok((t.elapsed().as_secs_f64(), gas))
        };
        // Warm-up, untimed; it also gives the sizes.
        let (_, gas) = build_raykit()?;
        let raykit_size = gas.size();
        let scratch = gas.build_sizes().build_scratch;
        let compacted = gas.compact()?;
        let raykit_compacted = compacted.compaction().map_or(0, |c| c.after);
        drop(compacted);
        let (_, a) = build_ash(true)?;
        let (ash_size, ash_compacted) = (a.size, ash.compact(&a)?);
        ash.destroy(a);

        let (mut rk, mut hw, mut fresh, mut ratios, mut ratios_fresh, mut gpu) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for rep in 0..reps {
            // Rotate which side goes first; each structure is dropped before the next build.
            let mut times = [0.0f64; 3];
            for k in 0..3 {
                match (rep + k) % 3 {
                    0 => times[0] = build_raykit()?.0,
                    1 => {
                        let (t, g) = build_ash(true)?;
                        ash.destroy(g);
                        times[1] = t;
                    }
                    _ => {
                        let (t, g) = build_ash(false)?;
                        ash.destroy(g);
                        times[2] = t;
                    }
                }
            }
            rk.push(times[0]);
            hw.push(times[1]);
            fresh.push(times[2]);
            ratios.push(times[0] / times[1]);
            ratios_fresh.push(times[0] / times[2]);
        }
        // GPU time of the build command alone, in separate builds.
        for _ in 0..3 {
            let g = ash.build_gas(&arrays, &indices, true, true)?;
            if let Some(ns) = g.gpu_ns {
                gpu.push(ns * 1e-9);
            }
            ash.destroy(g);
        }
        let row = Row {
            triangles: n,
            reps,
            raykit: Summary::of(&rk),
            ash: Summary::of(&hw),
            ash_fresh: Summary::of(&fresh),
            ratio_fresh: Summary::of(&ratios_fresh),
            ratio: Summary::of(&ratios),
            ash_gpu: (!gpu.is_empty()).then(|| Summary::of(&gpu)),
            raykit_size,
            scratch,
            raykit_compacted,
            ash_size,
            ash_compacted,
        };
        eprintln!(
            "accel: {n} triangles: raykit {:.1} ms, ash {:.1} ms (median of {reps})",
            row.raykit.median * 1e3,
            row.ash.median * 1e3
        );
        rows.push(row);
    }
    Ok(rows)
}

mod raykit_ash {
    pub use crate::ash_baseline::AshGas as Gas;
}

fn mtri(n: usize, seconds: f64) -> f64 {
    n as f64 / seconds / 1e6
}

/// The Markdown table.
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s = format!(
        "GAS builds on {device}: wall time from host arrays to a built, waited-for GAS (validation for raykit, upload, size query, allocation, build with compacted-size query, scratch released); PREFER_FAST_TRACE | ALLOW_COMPACTION; u32 indices. Each repetition runs raykit, the hand-written ash build reusing a destroyed structure's memory (`ash`), and the same with a fresh vkAllocateMemory per structure (`ash fresh`), in rotating order; median (± half the interquartile range); ratios are medians of per-repetition ratios (< 1: raykit faster). raykit allocates through gpu-allocator, which suballocates blocks (256 MB device-local, 64 MB host-visible) and gives a larger structure its own fresh allocation. GPU build ms: timestamps around the ash build command alone (3 extra builds).\n\n"
    );
    s.push_str("| triangles | reps | raykit ms | ash ms | ash fresh ms | raykit Mtri/s | ash Mtri/s | raykit/ash (min–max) | raykit/ash fresh | ash GPU build ms | scratch B | size B | compacted B | B/tri before → after | ash size → compacted B |\n");
    s.push_str("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let gpu = r.ash_gpu.map_or("n/a".to_owned(), |g| format!("{:.2}", g.median * 1e3));
        s.push_str(&format!(
            "| {} | {} | {:.2} ± {:.1}% | {:.2} ± {:.1}% | {:.2} ± {:.1}% | {:.2} | {:.2} | {:.3} ({:.3}–{:.3}) | {:.3} | {} | {} | {} | {} | {:.1} → {:.1} | {} → {} |\n",
            r.triangles,
            r.reps,
            r.raykit.median * 1e3,
            r.raykit.spread_percent(),
            r.ash.median * 1e3,
            r.ash.spread_percent(),
            r.ash_fresh.median * 1e3,
            r.ash_fresh.spread_percent(),
            mtri(r.triangles, r.raykit.median),
            mtri(r.triangles, r.ash.median),
            r.ratio.median,
            r.ratio.min,
            r.ratio.max,
            r.ratio_fresh.median,
            gpu,
            r.scratch,
            r.raykit_size,
            r.raykit_compacted,
            r.raykit_size as f64 / r.triangles as f64,
            r.raykit_compacted as f64 / r.triangles as f64,
            r.ash_size,
            r.ash_compacted,
        ));
    }
    s
}

/// The JSON record.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "triangles": r.triangles,
                    "reps": r.reps,
                    "raykit_seconds": r.raykit.json(),
                    "ash_seconds": r.ash.json(),
                    "time_ratio_raykit_over_ash": r.ratio.json(),
                    "ash_fresh_memory_seconds": r.ash_fresh.json(),
                    "time_ratio_raykit_over_ash_fresh_memory": r.ratio_fresh.json(),
                    "ash_gpu_build_seconds": r.ash_gpu.map(|g| g.json()),
                    "raykit_triangles_per_second": r.triangles as f64 / r.raykit.median,
                    "ash_triangles_per_second": r.triangles as f64 / r.ash.median,
                    "raykit_bytes": r.raykit_size,
                    "build_scratch_bytes": r.scratch,
                    "raykit_compacted_bytes": r.raykit_compacted,
                    "ash_bytes": r.ash_size,
                    "ash_compacted_bytes": r.ash_compacted,
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn grids_have_exactly_the_triangles_asked_for() {
        for n in [1, 2, 3, 10_000, 10_001, 99_999] {
            let (v, i) = super::grid(n);
            assert_eq!(i.len(), 3 * n);
            assert!(i.iter().all(|&x| (x as usize) < v.len()));
        }
    }
}
