//! `cargo xtask demo`: from a fresh machine to a picture, one phase after the
//! other where each needs the last, side by side where they need nothing of
//! each other, each timed.
//!
//! * The system packages (a Vulkan driver and SPIRV-Tools, through apt) download
//!   and install while the toolchain installs and rust-gpu's codegen backend
//!   builds: apt waits on the network and the disk, the backend build on the
//!   cores.
//! * The host program builds (`cargo build --release --no-default-features -p
//!   <example>`: the path tracer without its interactive viewer) while the
//!   codegen backend builds: both are compilations, but each has long stretches
//!   on one core (a big crate, a link), which the other fills.
//! * Only the example's device crate is compiled to SPIR-V; its params layout
//!   is checked when the program links its pipeline (`Pipeline::new`, the same
//!   check and message as `cargo xtask build-shaders`' build-time test, which
//!   would compile the device crate for the host a second time).
//!
//! At the end the phases' times are printed, with the wall-clock total.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};

/// One timed phase.
struct Phase {
    name: &'static str,
    took: Duration,
    note: &'static str,
}

/// Times of the demo's phases, printed at the end.
#[derive(Default)]
struct Phases(Vec<Phase>);

impl Phases {
    /// Runs `work` as phase `name`, timing it.
    fn run<T>(&mut self, name: &'static str, note: &'static str, work: impl FnOnce() -> T) -> T {
        let started = Instant::now();
        let out = work();
        self.0.push(Phase { name, took: started.elapsed(), note });
        out
    }

    fn print(&self, total: Duration) {
        println!("demo: phases (wall clock; overlapping phases ran side by side)");
        for phase in &self.0 {
            println!("  {:<18} {:>7.1} s  {}", phase.name, phase.took.as_secs_f64(), phase.note);
        }
        println!("  {:<18} {:>7.1} s", "total", total.as_secs_f64());
    }
}

/// The device crate an example's programs are in.
fn device_crate(example: &str) -> anyhow::Result<&'static str> {
    Ok(match example {
        "path_tracer" => "path-tracer-device",
        "triangle" => "triangle-device",
        other => bail!("unknown example {other:?}; the demos are path_tracer and triangle"),
    })
}

/// What `cargo xtask demo` renders, and how.
pub struct Demo {
    /// `path_tracer` or `triangle`.
    pub example: String,
    /// The picture's path.
    pub output: PathBuf,
    /// The path tracer's `WIDTHxHEIGHT`.
    pub size: String,
    /// The path tracer's paths per pixel.
    pub spp: u32,
    /// `vulkan` or `cpu`.
    pub backend: String,
    /// Denoise the path tracer's picture (`--denoise`).
    pub denoise: bool,
}

/// Runs the demo.
pub fn run(root: &Path, demo: &Demo) -> anyhow::Result<()> {
    let started = Instant::now();
    let device = device_crate(&demo.example)?;
    let mut phases = Phases::default();
    let render_args = render_args(demo)?;
    if let Some(dir) = demo.output.parent() {
        std::fs::create_dir_all(dir)?;
    }

    let host = thread::scope(|scope| -> anyhow::Result<_> {
        // The driver and SPIRV-Tools: apt, side by side with the compilations.
        let packages = scope.spawn(|| {
            let started = Instant::now();
            let result = if demo.backend == "vulkan" { crate::setup::ensure_vulkan(false) } else { Ok(()) };
            let result = result.and_then(|()| crate::setup::ensure_spirv_tools());
            (result, started.elapsed())
        });
        // The host program, side by side with the codegen backend.
        let host = scope.spawn(|| {
            let started = Instant::now();
            let mut cmd = crate::cargo();
            // Without the interactive viewer (the path tracer's default `viewer`
            // feature): the demo writes a picture.
            cmd.args(["build", "--release", "--quiet", "--no-default-features", "-p", &demo.example]);
            let result = crate::run(&mut cmd, &format!("building the {} example", demo.example));
            (result, started.elapsed())
        });
        phases.run("toolchain", "", crate::setup::ensure_toolchain)?;
        let builder = phases.run("codegen backend", "(beside system packages and host build)", || {
            raykit_builder::ShaderBuilder::ensure(raykit_builder::Report::Terminal)
        })?;
        // The backend runs SPIRV-Tools, which apt may still be installing.
        match packages.join() {
            Ok((result, took)) => {
                phases.0.push(Phase { name: "system packages", took, note: "(beside the compilations)" });
                result?;
            }
            Err(_) => bail!("the system-package installer panicked"),
        }
        phases.run("shaders", "", || crate::shaders::build_one(root, device, &builder))?;
        Ok(host.join())
    })?;
    match host {
        Ok((result, took)) => {
            phases.0.push(Phase { name: "host build", took, note: "(beside the codegen backend)" });
            result?;
        }
        Err(_) => bail!("the host build panicked"),
    }

    let binary = target_dir(root).join("release").join(&demo.example);
    phases.run("render", "", || {
        let mut cmd = Command::new(&binary);
        cmd.current_dir(root)
            .args(&render_args)
            .env("RAYKIT_SPIRV_DIR", crate::shaders::spirv_dir(root))
            .env("RAYKIT_BACKEND", &demo.backend);
        crate::run(&mut cmd, &format!("the {} example", demo.example))
    })?;
    println!("demo: wrote {}", demo.output.display());
    phases.print(started.elapsed());
    Ok(())
}

/// The example's command line.
fn render_args(demo: &Demo) -> anyhow::Result<Vec<String>> {
    let output = demo.output.display().to_string();
    Ok(match demo.example.as_str() {
        "path_tracer" => {
            let (width, height) = demo.size.split_once('x').context("--size takes WIDTHxHEIGHT, e.g. 512x512")?;
            let mut args: Vec<String> =
                ["--width", width, "--height", height, "--spp", &demo.spp.to_string(), "--output", &output]
                    .map(str::to_owned)
                    .to_vec();
            if demo.denoise {
                args.push("--denoise".to_owned());
            }
            args
        }
        _ if demo.denoise => bail!("--denoise is for the path tracer's demo; the triangle has no noise"),
        _ => vec![output],
    })
}

/// Cargo's target directory for the workspace.
fn target_dir(root: &Path) -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) => root.join(dir),
        None => root.join("target"),
    }
}
