//! Building the workspace's device crates to SPIR-V, through `raykit-builder`.
//!
//! Each device crate — a workspace member with `[package.metadata.raykit]
//! device = true` — is compiled to `target/spirv/<crate>.spv` and skipped when
//! neither it nor raykit's device crates changed since the last build; then the
//! launch-params layouts of all of them are checked in one `cargo test`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _};
use raykit_builder::{DeviceBuild, Report, ShaderBuilder};

/// Where the SPIR-V modules go.
pub fn spirv_dir(root: &Path) -> PathBuf {
    root.join("target").join("spirv")
}

/// A device crate of the workspace.
struct DeviceCrate {
    name: String,
    dir: PathBuf,
}

fn device_crates(root: &Path) -> anyhow::Result<Vec<DeviceCrate>> {
    let out = crate::cargo()
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .output()
        .context("running cargo metadata")?;
    if !out.status.success() {
        // --offline fails before the first fetch; retry online.
        let out = crate::cargo().args(["metadata", "--format-version", "1", "--no-deps"]).output()?;
        if !out.status.success() {
            bail!("cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
        }
        return parse_device_crates(&out.stdout, root);
    }
    parse_device_crates(&out.stdout, root)
}

fn parse_device_crates(json: &[u8], _root: &Path) -> anyhow::Result<Vec<DeviceCrate>> {
    let meta: serde_json::Value = serde_json::from_slice(json)?;
    let mut crates = Vec::new();
    for package in meta["packages"].as_array().into_iter().flatten() {
        if package["metadata"]["raykit"]["device"].as_bool() != Some(true) {
            continue;
        }
        let (Some(name), Some(manifest)) = (package["name"].as_str(), package["manifest_path"].as_str()) else {
            continue;
        };
        let dir = Path::new(manifest).parent().map(Path::to_path_buf).unwrap_or_default();
        crates.push(DeviceCrate { name: name.to_owned(), dir });
    }
    crates.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(crates)
}

/// Set by `build-shaders --spirv-opt`.
pub static SPIRV_OPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `RAYKIT_SPIRV_OPT` (or `build-shaders --spirv-opt`) asks for
/// `spirv-opt -O` after rust-gpu.
fn spirv_opt_enabled() -> bool {
    SPIRV_OPT.load(std::sync::atomic::Ordering::Relaxed)
        || std::env::var("RAYKIT_SPIRV_OPT").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// The build of one workspace device crate into `target/spirv/`.
fn device_build(root: &Path, krate: &DeviceCrate) -> DeviceBuild {
    DeviceBuild::new(&krate.dir)
        .name(&krate.name)
        .out_dir(spirv_dir(root))
        .target_dir(root.join("target"))
        .check_params(false)
        .spirv_opt(spirv_opt_enabled())
        .report(Report::Terminal)
}

/// Builds every device crate; skips those whose inputs did not change; then
/// checks every params layout.
pub fn build_all(root: &Path, force: bool) -> anyhow::Result<()> {
    let crates = device_crates(root)?;
    if crates.is_empty() {
        bail!("no device crates found (workspace members with [package.metadata.raykit] device = true)");
    }
    let builder = ShaderBuilder::ensure(Report::Terminal)?;
    for krate in &crates {
        device_build(root, krate).force(force).build_with(&builder)?;
    }
    let names: Vec<&str> = crates.iter().map(|k| k.name.as_str()).collect();
    raykit_builder::params::check_workspace(root, &names, &spirv_dir(root), Report::Terminal)?;
    Ok(())
}

/// Builds device crate `name` alone (skipped when unchanged) with `builder`,
/// without the build-time params check: what `cargo xtask demo` needs.
pub fn build_one(root: &Path, name: &str, builder: &ShaderBuilder) -> anyhow::Result<()> {
    let krate =
        device_crates(root)?.into_iter().find(|k| k.name == name).with_context(|| format!("no device crate {name}"))?;
    device_build(root, &krate).build_with(builder)?;
    Ok(())
}

/// Rebuilds device crate `name` (its dependencies already built) and returns
/// the seconds it took: the shader build time the benchmarks report.
pub fn time_rebuild(root: &Path, name: &str) -> anyhow::Result<f64> {
    let krate =
        device_crates(root)?.into_iter().find(|k| k.name == name).with_context(|| format!("no device crate {name}"))?;
    // Touch a source file so cargo recompiles the crate itself.
    let lib = krate.dir.join("src").join("lib.rs");
    let text = std::fs::read(&lib)?;
    std::fs::write(&lib, &text)?;
    let built = device_build(root, &krate).force(true).spirv_opt(false).build()?;
    Ok(built.seconds)
}
