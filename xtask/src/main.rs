//! `cargo xtask <command>`: raykit's developer commands.
//!
//! * `build-shaders`: compile every device crate of the workspace to SPIR-V under
//!   `target/spirv/`, installing the pinned nightly when missing.
//! * `demo`: render the triangle example to a PNG.
//! * `test`: set up what is missing (nightly, lavapipe, validation layers), build
//!   the shaders and run every test with validation on.
//! * `bench`: build `raykit-bench` in release and run it (suites such as `accel`);
//!   it writes `target/bench/bench.json` and `bench.md`. The binary needs only the
//!   Vulkan loader and the SPIR-V files, so it can be copied to a GPU machine
//!   without Rust.
//!
//! xtask never links rust-gpu's codegen backend: it builds the small
//! `xtask/shader-builder` program with the pinned nightly into a per-user cache
//! and runs it.

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
    },
    /// Render the triangle example to a PNG and print where.
    Demo {
        /// Output file.
        #[arg(long, default_value = "target/demo/triangle.png")]
        output: PathBuf,
    },
    /// Build the shaders and run the whole test suite with validation on.
    Test {
        /// Extra arguments for `cargo test` (after `--`).
        #[arg(last = true)]
        cargo_args: Vec<String>,
    },
    /// Only install what is missing (toolchain, Vulkan driver, validation layers).
    Setup,
    /// Build and run the benchmarks (target/bench/bench.{json,md}).
    Bench {
        /// Build the shaders first (suites that trace need them; `accel` does not).
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
        Cmd::BuildShaders { force } => {
            setup::ensure_toolchain()?;
            shaders::build_all(&root, force)?;
        }
        Cmd::Demo { output } => {
            setup::ensure_toolchain()?;
            setup::ensure_vulkan(false)?;
            shaders::build_all(&root, false)?;
            let output = if output.is_absolute() { output } else { root.join(output) };
            if let Some(dir) = output.parent() {
                std::fs::create_dir_all(dir)?;
            }
            run(
                cargo()
                    .args(["run", "--release", "--quiet", "-p", "triangle", "--"])
                    .arg(&output)
                    .env("RAYKIT_SPIRV_DIR", shaders::spirv_dir(&root)),
                "the triangle example",
            )?;
            println!("demo: wrote {}", output.display());
        }
        Cmd::Test { cargo_args } => {
            setup::ensure_toolchain()?;
            setup::ensure_vulkan(true)?;
            shaders::build_all(&root, false)?;
            let mut cmd = cargo();
            cmd.args(["test", "--workspace"]).args(&cargo_args);
            cmd.env("RAYKIT_SPIRV_DIR", shaders::spirv_dir(&root));
            cmd.env("RAYKIT_VALIDATION", "1");
            if std::env::var_os("RAYKIT_REQUIRE_DEVICE").is_none() {
                // `cargo xtask test` installed a driver above: a test that finds no
                // device is a failure, not a skip.
                cmd.env("RAYKIT_REQUIRE_DEVICE", "1");
            }
            run(&mut cmd, "cargo test")?;
        }
        Cmd::Bench { shaders, args } => {
            setup::ensure_vulkan(false)?;
            if shaders {
                setup::ensure_toolchain()?;
                shaders::build_all(&root, false)?;
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
        Cmd::Setup => {
            setup::ensure_toolchain()?;
            setup::ensure_vulkan(true)?;
        }
    }
    Ok(())
}
