//! `denoise`: Open Image Denoise's RT filter (`raykit-denoise`) at 512×512 and
//! 1920×1080, the colour alone and with albedo and normal guides, on OIDN's CPU
//! device (every core) and, where one works, its CUDA device.
//! The input is a deterministic noisy gradient: the filter's cost does not
//! depend on the picture. One untimed run warms the filter up; then the median
//! of `--reps` wall-clock runs (upload, filter, read-back). Needs OIDN: `cargo
//! xtask bench denoise` installs it.

use std::time::Instant;

use raykit_denoise::{DenoiseDevice, Denoiser, Input};

use crate::stats::Summary;

/// One size and input set.
pub struct Row {
    width: u32,
    height: u32,
    guides: bool,
    device: String,
    seconds: Summary,
}

/// The sizes measured.
const SIZES: [(u32, u32); 2] = [(512, 512), (1920, 1080)];

/// Times the filter at [`SIZES`], with and without guides, `reps` times each, on
/// OIDN's CPU device and, where it works, its CUDA device (side by side in one run).
pub fn run(reps: usize) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::new();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    rows.extend(run_on(&Denoiser::new(DenoiseDevice::Cpu)?, &format!("OIDN CPU ({threads} threads)"), reps)?);
    match Denoiser::new(DenoiseDevice::Cuda) {
        Ok(cuda) => rows.extend(run_on(&cuda, "OIDN CUDA", reps)?),
        Err(e) => eprintln!("denoise: no CUDA row: {e}"),
    }
    Ok(rows)
}

/// The rows of one device.
fn run_on(denoiser: &Denoiser, device: &str, reps: usize) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::new();
    for (width, height) in SIZES {
        let pixels = width as usize * height as usize;
        let mut state = 0x9e37_79b9u32;
        let color: Vec<[f32; 3]> = (0..pixels)
            .map(|i| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let noise = (state >> 8) as f32 / (1u32 << 24) as f32;
                let x = (i % width as usize) as f32 / width as f32;
                [x * 2.0 * noise, 0.5 * noise, (1.0 - x) * noise]
            })
            .collect();
        let albedo = vec![[0.8f32, 0.8, 0.8]; pixels];
        let normal = vec![[0.0f32, 0.0, 1.0]; pixels];
        for guides in [false, true] {
            let mut input = Input::new(width, height, &color);
            if guides {
                input = input.with_guides(&albedo, &normal);
            }
            denoiser.denoise(&input)?;
            let mut times = Vec::with_capacity(reps);
            for _ in 0..reps.max(1) {
                let started = Instant::now();
                let out = denoiser.denoise(&input)?;
                times.push(started.elapsed().as_secs_f64());
                anyhow::ensure!(out.len() == pixels, "OIDN returned {} pixels of {pixels}", out.len());
            }
            let seconds = Summary::of(&times);
            eprintln!("denoise: {device} {width}x{height} guides={guides}: {:.1} ms", seconds.median * 1e3);
            rows.push(Row { width, height, guides, device: device.to_owned(), seconds });
        }
    }
    Ok(rows)
}

/// The suite's Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut out =
        String::from("| size | inputs | device | median ms | Mpixels/s | spread |\n|---|---|---|---:|---:|---:|\n");
    for r in rows {
        let inputs = if r.guides { "colour + albedo + normal" } else { "colour" };
        let mpix = r.width as f64 * r.height as f64 / r.seconds.median / 1e6;
        out.push_str(&format!(
            "| {}×{} | {inputs} | {} | {:.1} | {mpix:.2} | ±{:.1}% |\n",
            r.width,
            r.height,
            r.device,
            r.seconds.median * 1e3,
            r.seconds.spread_percent()
        ));
    }
    out
}

/// The suite's JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    rows.iter()
        .map(|r| {
            serde_json::json!({
                "width": r.width, "height": r.height, "guides": r.guides, "device": r.device,
                "seconds": r.seconds.json(),
            })
        })
        .collect()
}
