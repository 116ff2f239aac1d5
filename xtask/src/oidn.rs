//! Installing Intel Open Image Denoise for `raykit-denoise`: the official OIDN
//! 2.5.1 Linux libraries ship in PyPI's `pyoidn` 2.5.1.0 wheel (CPU and CUDA
//! devices, TBB). xtask looks the wheel up in PyPI's simple index, downloads it
//! with curl, checks its SHA-256 against the one pinned here and unpacks the
//! libraries the denoiser loads into `raykit_denoise::default_library_dir()`.
//! No Python is involved, then or at run time.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context as _};

const WHEEL: &str = "pyoidn-2.5.1.0-py3-none-manylinux2014_x86_64.whl";
const WHEEL_SHA256: &str = "32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e";
const INDEX: &str = "https://pypi.org/simple/pyoidn/";
/// The wheel's members the CPU and CUDA devices need (SYCL, HIP and Level Zero stay out).
const MEMBERS: [&str; 5] = [
    "libOpenImageDenoise.so.2",
    "libOpenImageDenoise_core.so.2.5.1",
    "libOpenImageDenoise_device_cpu.so.2.5.1",
    "libOpenImageDenoise_device_cuda.so.2.5.1",
    "libtbb.so.12",
];

/// Installs OIDN into raykit's cache unless it is there; says what it did.
pub fn ensure_oidn() -> anyhow::Result<()> {
    let dir = raykit_denoise::default_library_dir();
    if MEMBERS.iter().all(|m| dir.join(m).is_file()) {
        return Ok(());
    }
    let started = Instant::now();
    crate::setup::ensure_commands(
        &["curl", "unzip", "sha256sum"],
        &["curl", "unzip", "ca-certificates", "coreutils"],
        "installing Open Image Denoise",
    )?;
    println!(
        "xtask: installing Open Image Denoise {} (PyPI's {WHEEL}) into {}",
        raykit_denoise::OIDN_VERSION,
        dir.display()
    );
    let index = output(Command::new("curl").args(["-fsSL", INDEX]), "reading PyPI's index of pyoidn")?;
    let url = index
        .split("href=\"")
        .filter_map(|s| s.split('"').next())
        .find(|href| href.contains(&format!("/{WHEEL}#")))
        .with_context(|| format!("{INDEX} does not list {WHEEL}"))?;
    let url = url.split('#').next().unwrap_or(url);
    let staging = dir.parent().context("the OIDN folder has a parent")?.join("download");
    std::fs::create_dir_all(&staging).with_context(|| format!("creating {}", staging.display()))?;
    let wheel = staging.join(WHEEL);
    crate::run(
        Command::new("curl").args(["-fsSL", "--retry", "3", "-o"]).arg(&wheel).arg(url),
        "downloading the pyoidn wheel",
    )?;
    let sum = output(Command::new("sha256sum").arg(&wheel), "hashing the wheel")?;
    if sum.split_whitespace().next() != Some(WHEEL_SHA256) {
        bail!("{} has SHA-256 {}, not the pinned {WHEEL_SHA256}; not installing it", wheel.display(), sum.trim());
    }
    let unpacked = staging.join("unpacked");
    let mut unzip = Command::new("unzip");
    unzip.args(["-q", "-o", "-j"]).arg(&wheel);
    for member in MEMBERS {
        unzip.arg(format!("pyoidn/oidn/lib/{member}"));
    }
    crate::run(unzip.arg("-d").arg(&unpacked), "unpacking the OIDN libraries")?;
    replace_dir(&unpacked, &dir)?;
    let _ = std::fs::remove_dir_all(&staging);
    let size: u64 = MEMBERS.iter().filter_map(|m| std::fs::metadata(dir.join(m)).ok()).map(|m| m.len()).sum();
    println!(
        "xtask: installed Open Image Denoise {} ({} libraries, {:.0} MB) in {:.1} s; raykit-denoise loads {}",
        raykit_denoise::OIDN_VERSION,
        MEMBERS.len(),
        size as f64 / 1e6,
        started.elapsed().as_secs_f64(),
        dir.join(raykit_denoise::LIBRARY_NAME).display()
    );
    Ok(())
}

fn output(cmd: &mut Command, what: &str) -> anyhow::Result<String> {
    let out = cmd.output().with_context(|| format!("starting {what}"))?;
    if !out.status.success() {
        bail!("{what} failed ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Moves `from` to `to`, replacing what was there (a half-finished install).
fn replace_dir(from: &Path, to: &Path) -> anyhow::Result<()> {
    if to.exists() {
        std::fs::remove_dir_all(to).with_context(|| format!("removing {}", to.display()))?;
    }
    std::fs::rename(from, to).with_context(|| format!("moving {} to {}", from.display(), to.display()))
}
