//! Dispatch of the suites added after `accel`: `primary`, `path`, `launch`,
//! `shaders`, and their options.

use std::path::Path;

use anyhow::Context as _;
use raykit::{Context, LaunchTimer};

use crate::trace::Options;

/// Defaults of the options these suites add.
pub fn default_options() -> Options {
    Options {
        reps: 5,
        triangles: 1_000_000,
        primary_size: (1920, 1080),
        path_size: 512,
        spp: 1,
        launches: 1000,
        devices: "all".to_owned(),
        spp_per_launch: 16,
        optix_bin: None,
        optix_sizes: vec![(1920, 1080), (3840, 2160)],
        optix_rounds: 3,
        cpu_threads: Vec::new(),
        primary_gas: crate::trace::GasChoice::default(),
    }
}

/// Parses one option of these suites (`--triangles`, `--primary-size WxH`,
/// `--path-size N`, `--spp N`, `--launches N`, `--devices all|N`,
/// `--spp-per-launch N`, `--optix-bin PATH`, `--optix-sizes WxH,WxH`,
/// `--optix-rounds N`, `--primary-gas LIST`, `--threads N,N`); returns
/// false when `name` is not one.
pub fn parse_option(
    opts: &mut Options,
    name: &str,
    value: &mut dyn FnMut() -> anyhow::Result<String>,
) -> anyhow::Result<bool> {
    match name {
        "--triangles" => opts.triangles = value()?.replace('_', "").parse().context("--triangles takes a number")?,
        "--primary-size" => {
            let v = value()?;
            let (w, h) = v.split_once('x').context("--primary-size takes WIDTHxHEIGHT")?;
            opts.primary_size = (w.parse()?, h.parse()?);
        }
        "--path-size" => opts.path_size = value()?.parse().context("--path-size takes a number")?,
        "--spp" => opts.spp = value()?.parse().context("--spp takes a number")?,
        "--launches" => opts.launches = value()?.parse().context("--launches takes a number")?,
        "--devices" => opts.devices = value()?,
        "--spp-per-launch" => {
            opts.spp_per_launch = value()?.parse().context("--spp-per-launch takes a number")?;
            anyhow::ensure!(opts.spp_per_launch > 0, "--spp-per-launch must be at least 1");
        }
        "--optix-bin" => opts.optix_bin = Some(value()?.into()),
        "--primary-gas" => opts.primary_gas = crate::trace::GasChoice::parse(&value()?)?,
        "--optix-rounds" => {
            opts.optix_rounds = value()?.parse().context("--optix-rounds takes a number")?;
            anyhow::ensure!(opts.optix_rounds > 0, "--optix-rounds must be at least 1");
        }
        "--threads" => {
            opts.cpu_threads = value()?
                .split(',')
                .map(|n| n.trim().parse::<usize>().context("--threads takes thread counts, N,N,..."))
                .collect::<anyhow::Result<_>>()?;
            anyhow::ensure!(opts.cpu_threads.iter().all(|&n| n > 0), "--threads counts must be at least 1");
        }
        "--optix-sizes" => {
            opts.optix_sizes = value()?
                .split(',')
                .map(|size| {
                    let (w, h) = size.trim().split_once('x').context("--optix-sizes takes WIDTHxHEIGHT,...")?;
                    Ok((w.parse()?, h.parse()?))
                })
                .collect::<anyhow::Result<_>>()?;
            anyhow::ensure!(!opts.optix_sizes.is_empty(), "--optix-sizes needs at least one size");
        }
        _ => return Ok(false),
    }
    Ok(true)
}

/// Runs `suite`; returns its Markdown section and JSON.
pub fn run(suite: &str, ctx: &Context, opts: &Options, out: &Path) -> anyhow::Result<(String, serde_json::Value)> {
    let timer = LaunchTimer::new(ctx)?;
    eprintln!("{suite}: GPU timestamps {}", if timer.is_some() { "available" } else { "not available (wall clock)" });
    Ok(match suite {
        "primary" => {
            let rows = crate::trace::primary(ctx, timer.as_ref(), opts)?;
            (crate::trace::markdown(&rows), crate::trace::json(&rows))
        }
        "path" => {
            let rows = crate::trace::path(ctx, timer.as_ref(), opts)?;
            (crate::trace::markdown(&rows), crate::trace::json(&rows))
        }
        "launch" => {
            let scene = opts.primary_scene(ctx, crate::trace::Coverage::AllHits)?;
            let mut rows = crate::launch::launches(ctx, &scene, opts.primary_size, opts.reps)?;
            rows.extend(crate::launch::creation(ctx, opts.reps * 4)?);
            (crate::launch::markdown(&rows), crate::launch::json(&rows))
        }
        "launch-loop" => {
            let scene = opts.primary_scene(ctx, crate::trace::Coverage::AllHits)?;
            let rows = crate::launch::launch_loop(ctx, &scene, opts.launches, opts.reps)?;
            (crate::launch::markdown(&rows), crate::launch::json(&rows))
        }
        "shaders" => crate::shaders::markdown(&crate::shaders::sizes()?, out),
        "materials" => crate::materials::run(ctx, timer.as_ref(), opts)?,
        "optix" => crate::optix::run(ctx, timer.as_ref(), opts, out)?,
        other => anyhow::bail!("unknown suite {other}"),
    })
}
