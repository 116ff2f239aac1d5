//! The launch-params layout check: each `#[params]` program of a device crate
//! generates a host test (`__raykit_params_layout_<entry>`) that reads the
//! SPIR-V's params block through raykit-spirv and compares it with the layout
//! `#[derive(LaunchParams)]` recorded on the host; a disagreement fails with the
//! same message `Pipeline::new` would give (the field, both offsets, the fix).
//! Each `#[derive(Element)]` struct of a device crate generates one too
//! (`__raykit_params_layout_element_<Struct>`), comparing the buffer element's
//! host layout with the one its hidden entry point records in the SPIR-V.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use crate::error::{Error, Result};
use crate::report::Report;

/// The stable cargo (the one running this build, when there is one).
fn cargo() -> Command {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    crate::toolchain::scrub_cargo_env(&mut cmd);
    cmd
}

/// Checks the params layouts of device crate `name` (in `crate_dir`) against its
/// SPIR-V in `spirv_dir`, building the host tests in `target_dir`.
pub fn check(crate_dir: &Path, name: &str, spirv_dir: &Path, target_dir: &Path, report: Report) -> Result<()> {
    let mut cmd = cargo();
    cmd.arg("test").arg("--manifest-path").arg(crate_dir.join("Cargo.toml")).arg("--target-dir").arg(target_dir);
    cmd.args(["-p", name]);
    run(cmd, name, spirv_dir, report)
}

/// Checks several device crates of one workspace at once (one `cargo test`),
/// from `workspace_root`, in the workspace's own target directory.
pub fn check_workspace(workspace_root: &Path, names: &[&str], spirv_dir: &Path, report: Report) -> Result<()> {
    let mut cmd = cargo();
    cmd.current_dir(workspace_root).arg("test");
    for name in names {
        cmd.args(["-p", name]);
    }
    run(cmd, &names.join(", "), spirv_dir, report)
}

fn run(mut cmd: Command, what: &str, spirv_dir: &Path, report: Report) -> Result<()> {
    let started = Instant::now();
    cmd.args(["--quiet", "--lib", "--", "__raykit_params_layout_"]).env("RAYKIT_SPIRV_DIR", spirv_dir);
    let output = cmd.output().map_err(|e| Error::Command {
        what: format!("cargo test (params layout check of {what})"),
        status: e.to_string(),
        output: String::new(),
    })?;
    if !output.status.success() {
        let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        // The layout messages alone when there are any (each once: the test
        // harness repeats a panic's message); else everything cargo said, so
        // that a host build error keeps its context.
        let mut reasons: Vec<&str> = Vec::new();
        for line in text
            .lines()
            .filter(|l| l.contains("launch params") || l.contains("buffer element") || l.contains("reads its params"))
        {
            if !reasons.contains(&line) {
                reasons.push(line);
            }
        }
        let message = if reasons.is_empty() { text.clone() } else { reasons.join("\n") };
        return Err(Error::ParamsLayout { krate: what.to_owned(), message });
    }
    report.progress(&format!(
        "params and buffer-element layouts of {what} match the SPIR-V ({:.1} s)",
        started.elapsed().as_secs_f64()
    ));
    Ok(())
}
