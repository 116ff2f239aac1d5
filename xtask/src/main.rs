//! `cargo xtask <command>`: raykit's developer commands.
//!
//! * `build-shaders`: compile every device crate of the workspace to SPIR-V under
//!   `target/spirv/`, installing the pinned nightly when missing.
//! * `demo`: render the path tracer's Cornell box to a PNG (and PFM) with a
//!   progress bar; `--example triangle` renders optixTriangle instead.
//! * `lint`: the gates (rustfmt, clippy with `-D warnings`, rustdoc with `-D warnings`,
//!   doctests, the book, no undocumented binaries in git); see `lint.rs`.
//! * `setup [--denoise]`: install what is missing; `--denoise` also installs Intel
//!   Open Image Denoise for `raykit-denoise` (see `oidn.rs`).
//! * `test`: set up what is missing (nightly, lavapipe, validation layers, glslang,
//!   Open Image Denoise),
//!   run `lint` (stopping at the first gate that fails), build the shaders and run
//!   every test with validation on.
//! * `new-project PATH`: write a new project that uses raykit (see the book's
//!   "Use raykit in your own project", `docs/book/src/own-project.md`).
//! * `bench`: build `raykit-bench` in release and run it (suites such as `accel`);
//!   it writes `target/bench/bench.json` and `bench.md`. The binary needs only the
//!   Vulkan loader and the SPIR-V files, so it can be copied to a GPU machine
//!   without Rust.
//!
//! Shader builds go through the `raykit-builder` library, as in any project using
//! raykit; xtask never links rust-gpu's codegen backend: raykit-builder builds its
//! small `shader-builder` program with the pinned nightly into a per-user cache
//! and runs it.

mod book;
mod demo;
mod display;
mod layers;
mod lint;
mod oidn;
mod refusals;
mod setup;
mod shaders;

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context as _};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "cargo xtask", about = "raykit's developer commands")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Build every device crate of the workspace to SPIR-V (target/spirv/).
    BuildShaders {
        /// Rebuild even crates that did not change.
        #[arg(long)]
        force: bool,
        /// Post-optimise every module with `spirv-opt -O` (as the GLSL twins
        /// are) and check it with `spirv-val`; also `RAYKIT_SPIRV_OPT=1`.
        #[arg(long)]
        spirv_opt: bool,
    },
    /// Render the Cornell box (path_tracer example) to a PNG and print where.
    Demo {
        /// Which example: `path_tracer` (the Cornell box) or `triangle`.
        #[arg(long, default_value = "path_tracer")]
        example: String,
        /// Output file (default: target/demo/<example>.png).
        #[arg(long)]
        output: Option<PathBuf>,
        /// Image size of the path tracer, `WIDTHxHEIGHT`.
        #[arg(long, default_value = "512x512")]
        size: String,
        /// Paths per pixel of the path tracer.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Where the device programs run: `vulkan` (a GPU, or lavapipe) or `cpu`
        /// (natively on this machine's CPUs, with no Vulkan driver needed).
        #[arg(long, default_value = "vulkan", value_parser = ["vulkan", "cpu"])]
        backend: String,
        /// Denoise the picture with Open Image Denoise (first-hit albedo and
        /// normal guides), installing the library first when it is missing.
        #[arg(long)]
        denoise: bool,
    },
    /// Check formatting, clippy, rustdoc, doctests, the book and committed binaries (each must pass).
    Lint,
    /// Run `lint`, build the shaders and run the whole test suite with validation on.
    Test {
        /// Extra arguments for `cargo test` (after `--`).
        #[arg(last = true)]
        cargo_args: Vec<String>,
    },
    /// Only install what is missing (toolchain, Vulkan driver, validation layers).
    Setup {
        /// Also install Intel Open Image Denoise 2.5.1 (raykit-denoise's library,
        /// from PyPI's `pyoidn` wheel) into raykit's cache folder.
        #[arg(long)]
        denoise: bool,
    },
    /// Write a new project that uses raykit (a host binary whose build.rs builds
    /// its device crate through raykit-builder) into PATH, missing or empty.
    NewProject {
        /// Where to write it.
        path: PathBuf,
    },
    /// Run the bad-input catalogue and print which backends each refusal (each
    /// error variant) is provoked on (target/refusals/refusals.md).
    Refusals,
    /// Build and run the benchmarks (target/bench/bench.{json,md}).
    Bench {
        /// Build the shaders first (suites that trace need them; `accel` does not),
        /// and measure shader build times (Rust against the GLSL twins) for the
        /// `shaders` suite.
        #[arg(long)]
        shaders: bool,
        /// Arguments of raykit-bench: suites (`accel`) and options
        /// (`--sizes 10000,100000`, `--reps N`, `--device NAME`).
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
}

/// The workspace root.
pub fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."))
}

/// The stable cargo that runs xtask.
pub fn cargo() -> Command {
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.current_dir(project_root());
    cmd
}

/// Runs `cmd`, failing with its description when it fails.
pub fn run(cmd: &mut Command, what: &str) -> anyhow::Result<()> {
    let status = cmd.status().with_context(|| format!("starting {what}"))?;
    if !status.success() {
        bail!("{what} failed ({status})");
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let root = project_root();
    match cli.command {
        Cmd::BuildShaders { force, spirv_opt } => {
            setup::ensure_toolchain()?;
            setup::ensure_spirv_tools()?;
            if spirv_opt {
                shaders::SPIRV_OPT.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            shaders::build_all(&root, force)?;
        }
        Cmd::Demo { example, output, size, spp, backend, denoise } => {
            if denoise {
                oidn::ensure_oidn()?;
            }
            let output = output.unwrap_or_else(|| PathBuf::from(format!("target/demo/{example}.png")));
            let output = if output.is_absolute() { output } else { root.join(output) };
            demo::run(&root, &demo::Demo { example, output, size, spp, backend, denoise })?;
        }
        Cmd::Lint => lint::run_all(&root)?,
        Cmd::Test { cargo_args } => {
            setup::ensure_toolchain()?;
            setup::ensure_vulkan(true)?;
            setup::ensure_glsl_tools()?;
            display::ensure_xvfb()?;
            // raykit-denoise's tests and the path tracer's denoising tests load it.
            oidn::ensure_oidn()?;
            lint::run_all(&root)?;
            shaders::build_all(&root, false)?;
            let mut cmd = cargo();
            // The doctests ran in `lint`.
            cmd.args(["test", "--workspace", "--lib", "--bins", "--tests"]).args(&cargo_args);
            // The tools are installed above: the rebuild check of the committed SPIR-V
            // must run, not skip.
            cmd.env("RAYKIT_REQUIRE_GLSLANG", "1");
            cmd.env("RAYKIT_SPIRV_DIR", shaders::spirv_dir(&root));
            cmd.env("RAYKIT_VALIDATION", "1");
            if std::env::var_os("RAYKIT_REQUIRE_DEVICE").is_none() {
                // `cargo xtask test` installed a driver above: a test that finds no
                // device is a failure, not a skip.
                cmd.env("RAYKIT_REQUIRE_DEVICE", "1");
            }
            // The viewer's window tests open windows on a virtual display.
            let xvfb = display::VirtualDisplay::start()?;
            cmd.env("DISPLAY", &xvfb.display);
            cmd.env("RAYKIT_REQUIRE_DISPLAY", "1");
            run(&mut cmd, "cargo test")?;
            drop(xvfb);
        }
        Cmd::Refusals => {
            setup::ensure_toolchain()?;
            setup::ensure_vulkan(true)?;
            shaders::build_all(&root, false)?;
            refusals::run(&root, &shaders::spirv_dir(&root))?;
        }
        Cmd::Bench { shaders, args } => {
            setup::ensure_vulkan(false)?;
            if shaders {
                setup::ensure_toolchain()?;
                setup::ensure_spirv_tools()?;
                shaders::build_all(&root, false)?;
                let mut times = Vec::new();
                for (programs, krate, script) in [
                    ("primary rays (triangle)", "triangle-device", "bench/glsl/build.sh"),
                    ("path tracer", "path-tracer-device", "examples/path_tracer/glsl/build.sh"),
                ] {
                    let rust_s = shaders::time_rebuild(&root, krate)?;
                    let started = std::time::Instant::now();
                    run(&mut Command::new(root.join(script)), script)?;
                    let glsl_s = started.elapsed().as_secs_f64();
                    times.push(serde_json::json!({"programs": programs, "rust_s": rust_s, "glsl_s": glsl_s}));
                }
                let out = root.join("target").join("bench");
                std::fs::create_dir_all(&out)?;
                std::fs::write(out.join("shader_build.json"), serde_json::to_string_pretty(&times)?)?;
            }
            if args.iter().any(|a| a == "denoise") {
                oidn::ensure_oidn()?;
            }
            if args.iter().any(|a| a == "cpu" || a == "cpu-scaling") {
                setup::ensure_embree()?;
            }
            run(cargo().args(["build", "--release", "--quiet", "-p", "raykit-bench"]), "building raykit-bench")?;
            let binary = root.join("target").join("release").join("raykit-bench");
            run(
                std::process::Command::new(&binary)
                    .current_dir(&root)
                    .args(&args)
                    .arg("--out")
                    .arg(root.join("target").join("bench"))
                    .arg("--spirv-dir")
                    .arg(shaders::spirv_dir(&root)),
                "raykit-bench",
            )?;
        }
        Cmd::Setup { denoise } => {
            setup::ensure_toolchain()?;
            setup::ensure_spirv_tools()?;
            setup::ensure_vulkan(true)?;
            if denoise {
                oidn::ensure_oidn()?;
            }
        }
        Cmd::NewProject { path } => {
            let files = raykit_builder::write_new_project(&path, &root)?;
            for file in files {
                println!("new-project: wrote {}", file.display());
            }
            let name = raykit_builder::project_name(&path)?;
            println!("new-project: package `{name}`, device crate `{name}-device`");
            println!("new-project: now `cd {} && cargo run --release`", path.display());
        }
    }
    Ok(())
}
