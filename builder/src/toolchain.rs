//! The pinned nightly that rust-gpu 0.11 needs, installed with rustup when missing.

use std::process::Command;

use crate::error::{Error, Result};
use crate::report::Report;

/// The nightly rust-gpu 0.11 requires.
pub const TOOLCHAIN: &str = "nightly-2026-08-15";
/// Its components.
pub const COMPONENTS: [&str; 3] = ["rust-src", "rustc-dev", "llvm-tools"];

/// `rustup`, with the toolchain override that cargo's proxy sets removed.
pub fn rustup() -> Command {
    let mut cmd = Command::new("rustup");
    cmd.env_remove("RUSTUP_TOOLCHAIN");
    cmd
}

/// Removes the variables a parent cargo (or build script) sets, so that a nested
/// cargo or rustc starts clean.
pub(crate) fn scrub_cargo_env(cmd: &mut Command) {
    for (key, _) in std::env::vars_os() {
        let Some(key) = key.to_str() else { continue };
        let cargo_var = (key.starts_with("CARGO") && key != "CARGO_HOME") || key.starts_with("RUSTC");
        let build_script_var = matches!(
            key,
            "RUSTFLAGS"
                | "RUSTDOC"
                | "RUSTDOCFLAGS"
                | "RUSTUP_TOOLCHAIN"
                | "OUT_DIR"
                | "TARGET"
                | "HOST"
                | "PROFILE"
                | "OPT_LEVEL"
                | "DEBUG"
                | "NUM_JOBS"
        );
        if cargo_var || build_script_var {
            cmd.env_remove(key);
        }
    }
}

/// A command run with the pinned nightly, with no parent cargo's environment.
pub fn nightly(program: &str) -> Command {
    let mut cmd = rustup();
    scrub_cargo_env(&mut cmd);
    cmd.args(["run", TOOLCHAIN, program]);
    cmd
}

fn output(cmd: &mut Command) -> Option<String> {
    let out = cmd.output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

pub(crate) fn run(cmd: &mut Command, what: &str, report: Report) -> Result<()> {
    report.route(cmd);
    let status = cmd.status().map_err(|e| Error::Command {
        what: what.to_owned(),
        status: e.to_string(),
        output: String::new(),
    })?;
    if !status.success() {
        return Err(Error::Command { what: what.to_owned(), status: status.to_string(), output: String::new() });
    }
    Ok(())
}

/// Installs [`TOOLCHAIN`] and its [`COMPONENTS`] with rustup when missing, and
/// says so.
pub fn ensure_toolchain(report: Report) -> Result<()> {
    let Some(list) = output(rustup().args(["toolchain", "list"])) else {
        return Err(Error::NoRustup { toolchain: TOOLCHAIN, components: COMPONENTS.join(",") });
    };
    let installed = list.lines().any(|l| l.starts_with(TOOLCHAIN));
    let missing: Vec<&str> = if installed {
        let have =
            output(rustup().args(["component", "list", "--installed", "--toolchain", TOOLCHAIN])).unwrap_or_default();
        COMPONENTS.iter().copied().filter(|c| !have.lines().any(|l| l.starts_with(c))).collect()
    } else {
        COMPONENTS.to_vec()
    };
    if installed && missing.is_empty() {
        return Ok(());
    }
    if !installed {
        report.notable(&format!(
            "installing the Rust toolchain {TOOLCHAIN} with {} (rust-gpu 0.11 needs it to build device crates)",
            COMPONENTS.join(", ")
        ));
        let components = COMPONENTS.join(",");
        run(
            rustup().args(["toolchain", "install", TOOLCHAIN, "--profile", "minimal", "--component", &components]),
            &format!("rustup toolchain install {TOOLCHAIN}"),
            report,
        )
    } else {
        report.notable(&format!("adding components {} to {TOOLCHAIN}", missing.join(", ")));
        run(
            rustup().args(["component", "add", "--toolchain", TOOLCHAIN]).args(&missing),
            "rustup component add",
            report,
        )
    }
}
