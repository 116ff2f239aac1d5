//! `raykit-bench [SUITE...] [options]`: raykit's benchmarks.
//!
//! Suites (all when none is named): `accel` — GAS build throughput, raykit
//! against a hand-written ash build, and memory before/after compaction;
//! `stack` — per-group stack sizes and each stack-size estimate, with the
//! driver default, for the example and test pipelines (no timing);
//! `primary` and `path` — Rust device programs against their GLSL and WGSL twins (primary
//! rays on a ≥ 1M-triangle mesh, the path tracer); the primary rays also against an
//! independent hand-written ash program (see `ash_independent.rs`); `launch` — raykit's launch
//! path and pipeline + SBT creation against hand-written ash; `shaders` — SPIR-V
//! sizes (and build times measured by `cargo xtask bench`). `pipeline` — pipeline creation with the compile
//! cache off, cold and warm. See `bench/README.md`.
//!
//! `soak` — 10,000 launches (`--soak-launches N`) with SBT updates, GAS refits and
//! IAS updates, host and device memory sampled. `launch-loop` — `--launches N`
//! (default 1000) 1×1 launches in a row through raykit, then through hand-written
//! ash, per launch; each loop is one function (`raykit_loop`, `ash_loop`) for
//! callgrind's `--toggle-collect`.
//!
//! `cpu` — the CPU backend against the Vulkan device, primary rays and the path
//! tracer (16 spp), with the same Rust programs (see `cpu.rs`). `cpu-scaling` —
//! the CPU backend's primary rays beside Embree's at each `--threads N,N,..`
//! (default 1, 2, 4, … up to the logical CPUs; see `cpu_scaling.rs`). Not run
//! unless named.
//!
//! `devices` — the path tracer on one device against the same progressive render
//! split across a device group (`--devices all`, every ray-tracing GPU, or a
//! count), with the speed-up (see `devices.rs`). Not run unless named.
//!
//! `optix` — raykit's primary rays (at each `--optix-sizes`) and path tracer
//! against their OptiX twin (`bench/optix`, a separate CUDA program that
//! `--optix-bin` names), with the GLSL twin and the two hand-written ash
//! baselines beside them, and checks that the pictures agree (see `optix.rs`). Not run
//! unless named.
//!
//! `denoise` — Open Image Denoise's RT filter (`raykit-denoise`) at 512×512 and
//! 1920×1080, the colour alone and with albedo and normal guides, on the device
//! OIDN's `Auto` picks (see `denoise.rs`). Not run unless named; `cargo xtask
//! bench denoise` installs the library.
//!
//! Options:
//! * `--spirv-dir DIR` — where the device crates' `.spv` files are (else
//!   `$RAYKIT_SPIRV_DIR`); suites that trace need them, `accel` does not.
//! * `--out DIR` — where the JSON and Markdown reports go (default `target/bench`).
//! * `--sizes 10000,100000,1000000` — triangle counts of `accel`.
//! * `--reps N` — repetitions per size (default: 15, 9, 5 by size).
//! * `--device NAME` — use the first ray-tracing device whose name contains NAME.
//! * `--triangles N`, `--primary-size WxH`, `--path-size N`, `--spp N`, `--launches N` — sizes of
//!   the tracing suites (defaults 1000000, 1920x1080, 512, 1, 1000).
//! * `--devices all|N`, `--spp-per-launch N` — the `devices` suite's group (default `all`) and
//!   launches (default 16 paths per pixel each; `--spp` 1 means 64 in all there).
//! * `--optix-bin PATH`, `--optix-sizes WxH,WxH`, `--optix-rounds N` — the `optix` suite's
//!   OptiX executable (default `optix/raykit-optix` next to this binary), primary-ray sizes
//!   (default 1920x1080,3840x2160) and rounds (default 3: raykit's variants, then OptiX's, in turn).
//!
//! The binary needs only the Vulkan loader (and the SPIR-V files for suites that
//! trace): build it here with `cargo build --release -p raykit-bench` and copy
//! `target/release/raykit-bench` to a GPU machine without Rust.

mod accel;
mod ash_baseline;
mod ash_independent;
mod ash_launcher;
mod cpu;
mod cpu_scaling;
mod denoise;
mod devices;
mod embree;
mod launch;
mod materials;
mod optix;
mod pipeline;
mod shaders;
mod soak;
mod stack;
mod stats;
mod suites;
mod trace;

use std::path::PathBuf;

use anyhow::{bail, Context as _};
use raykit::{Context, ContextOptions};

const SUITES: [&str; 15] = [
    "accel",
    "stack",
    "pipeline",
    "primary",
    "path",
    "launch",
    "launch-loop",
    "shaders",
    "soak",
    "cpu",
    "cpu-scaling",
    "materials",
    "devices",
    "optix",
    "denoise",
];

/// Suites run only when named: `cpu-scaling` runs the CPU backend and Embree at
/// several thread counts; `devices` splits work across every GPU of the host;
/// `optix` needs the OptiX twin built beside the binary; `denoise` needs Open
/// Image Denoise (`cargo xtask bench denoise` installs it).
const ONLY_WHEN_NAMED: [&str; 4] = ["devices", "optix", "denoise", "cpu-scaling"];

struct Args {
    suites: Vec<String>,
    out: PathBuf,
    sizes: Vec<usize>,
    reps: Option<usize>,
    device: Option<String>,
    trace: trace::Options,
    /// Launches of the `soak` suite.
    soak_launches: usize,
}

fn parse() -> anyhow::Result<Args> {
    let mut args = Args {
        suites: Vec::new(),
        out: PathBuf::from("target/bench"),
        sizes: vec![10_000, 100_000, 1_000_000],
        reps: None,
        device: None,
        trace: suites::default_options(),
        soak_launches: 10_000,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().with_context(|| format!("{name} needs a value"));
        match a.as_str() {
            "--spirv-dir" => {
                let dir = value("--spirv-dir")?;
                // raykit reads the directory from the environment (`Module::from_device_crate`).
                std::env::set_var("RAYKIT_SPIRV_DIR", dir);
            }
            "--out" => args.out = PathBuf::from(value("--out")?),
            "--sizes" => {
                args.sizes = value("--sizes")?
                    .split(',')
                    .map(|s| s.trim().replace('_', "").parse::<usize>())
                    .collect::<Result<_, _>>()
                    .context("--sizes takes comma-separated triangle counts")?;
            }
            "--soak-launches" => {
                args.soak_launches = value("--soak-launches")?.parse().context("--soak-launches takes a number")?
            }
            "--reps" => args.reps = Some(value("--reps")?.parse().context("--reps takes a number")?),
            "--device" => args.device = Some(value("--device")?),
            s if suites::parse_option(&mut args.trace, s, &mut || value(s))? => {}
            "-h" | "--help" => {
                println!("raykit-bench [SUITE...] [--spirv-dir DIR] [--out DIR] [--sizes N,N,..] [--reps N] [--device NAME]\nsuites: {}", SUITES.join(", "));
                std::process::exit(0);
            }
            s if s.starts_with('-') => bail!("unknown option {s}; see --help"),
            s if SUITES.contains(&s) => args.suites.push(s.to_owned()),
            s => bail!("unknown suite {s:?}; suites: {}", SUITES.join(", ")),
        }
    }
    if let Some(reps) = args.reps {
        args.trace.reps = reps;
    }
    if args.suites.is_empty() {
        args.suites = SUITES.iter().filter(|s| !ONLY_WHEN_NAMED.contains(s)).map(|s| s.to_string()).collect();
    }
    Ok(args)
}

fn main() -> anyhow::Result<()> {
    let args = parse()?;
    // With `RAYKIT_VALIDATION=1` the Khronos validation layer checks raykit's calls
    // and the hand-written ash baselines' (their `AshDevice` follows the same
    // variable); timings taken so are not the device's.
    let validation = ash_baseline::validation_requested();
    if validation {
        eprintln!("RAYKIT_VALIDATION=1: the validation layer is on; timings are not representative");
    }
    let ctx = Context::new(ContextOptions {
        validation: Some(validation),
        device_name_contains: args.device.clone(),
        ..Default::default()
    })?;
    let device = ctx.device_name().into_owned();
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut report = serde_json::json!({ "device": device, "suites": {} });
    let mut markdown = format!("# raykit benchmarks on {device}\n\n");
    for suite in &args.suites {
        if suite == "accel" {
            let ash = ash_baseline::AshDevice::new(&ctx)?;
            eprintln!("accel: GPU timestamps {}", if ash.has_timestamps() { "available" } else { "not available" });
            let rows = accel::run(&ctx, &ash, &args.sizes, args.reps)?;
            let table = accel::markdown(&rows, &device);
            println!("{table}");
            markdown.push_str("## accel\n\n");
            markdown.push_str(&table);
            report["suites"]["accel"] = accel::json(&rows);
        } else if suite == "stack" {
            let rows = stack::run(&ctx)?;
            let table = stack::markdown(&rows, &device);
            println!("{table}");
            markdown.push_str("## stack\n\n");
            markdown.push_str(&table);
            report["suites"]["stack"] = stack::json(&rows);
        } else if suite == "soak" {
            let samples = soak::run(&ctx, args.soak_launches)?;
            let table = soak::markdown(&samples, &device);
            println!("{table}");
            markdown.push_str("## soak\n\n");
            markdown.push_str(&table);
            report["suites"]["soak"] = soak::json(&samples);
        } else if suite == "cpu" {
            let rows = cpu::run(&ctx, &args.trace)?;
            let table = cpu::markdown(&rows);
            println!("## cpu\n\n{table}");
            markdown.push_str("## cpu\n\n");
            markdown.push_str(&table);
            report["suites"]["cpu"] = cpu::json(&rows);
        } else if suite == "cpu-scaling" {
            let rows = cpu_scaling::run(&args.trace, &args.trace.cpu_threads)?;
            let table = cpu_scaling::markdown(&rows, &args.trace);
            println!("## cpu-scaling\n\n{table}");
            markdown.push_str("## cpu-scaling\n\n");
            markdown.push_str(&table);
            report["suites"]["cpu-scaling"] = cpu_scaling::json(&rows);
        } else if suite == "devices" {
            let results = devices::run(&args.trace, args.device.as_deref())?;
            let table = devices::markdown(&results);
            println!("## devices\n\n{table}");
            markdown.push_str("## devices\n\n");
            markdown.push_str(&table);
            report["suites"]["devices"] = devices::json(&results);
        } else if suite == "denoise" {
            let rows = denoise::run(args.reps.unwrap_or(5))?;
            let table = denoise::markdown(&rows);
            println!("## denoise\n\n{table}");
            markdown.push_str("## denoise\n\n");
            markdown.push_str(&table);
            report["suites"]["denoise"] = denoise::json(&rows);
        } else if suite == "pipeline" {
            let rows = pipeline::run(args.device.as_deref(), args.reps)?;
            let table = pipeline::markdown(&rows, &device);
            println!("{table}");
            markdown.push_str("## pipeline\n\n");
            markdown.push_str(&table);
            report["suites"]["pipeline"] = pipeline::json(&rows);
        } else {
            let (table, json) = suites::run(suite, &ctx, &args.trace, &args.out)?;
            println!("## {suite}\n\n{table}");
            markdown.push_str(&format!("## {suite}\n\n{table}\n"));
            report["suites"][suite.as_str()] = json;
        }
    }
    let json_path = args.out.join("bench.json");
    let md_path = args.out.join("bench.md");
    std::fs::write(&json_path, serde_json::to_string_pretty(&report)?)?;
    std::fs::write(&md_path, markdown)?;
    eprintln!("wrote {} and {}", json_path.display(), md_path.display());
    Ok(())
}
