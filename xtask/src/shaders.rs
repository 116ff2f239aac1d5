//! Building device crates to SPIR-V.
//!
//! The codegen backend (rust-gpu's `rustc_codegen_spirv`) is linked into the
//! small `xtask/shader-builder` program, built with the pinned nightly into a
//! per-user cache (`$RAYKIT_CACHE_DIR`, else `$XDG_CACHE_HOME/raykit`, else
//! `~/.cache/raykit`), so it is compiled once per machine (~15 min) and shared by
//! every clone. Each device crate — a workspace member with
//! `[package.metadata.raykit] device = true` — is then compiled to
//! `target/spirv/<crate>.spv`, and skipped when neither it nor raykit's device
//! crates nor the builder changed since the last build.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context as _};

use crate::setup::{rustup, TOOLCHAIN};

/// Where the SPIR-V modules go.
pub fn spirv_dir(root: &Path) -> PathBuf {
    root.join("target").join("spirv")
}

fn cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("RAYKIT_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("raykit");
    }
    match std::env::var_os("HOME") {
        Some(home) => PathBuf::from(home).join(".cache").join("raykit"),
        None => std::env::temp_dir().join("raykit-cache"),
    }
}

/// A command run with the pinned nightly, without the stable toolchain's
/// cargo environment leaking in.
fn nightly(program: &str) -> Command {
    let mut cmd = rustup();
    cmd.args(["run", TOOLCHAIN, program]);
    for (key, _) in std::env::vars_os() {
        let Some(key) = key.to_str() else { continue };
        if key == "CARGO" || key.starts_with("CARGO_") || key == "RUSTC" || key == "RUSTFLAGS" || key == "RUSTDOC" {
            cmd.env_remove(key);
        }
    }
    cmd
}

/// Builds (or finds up to date) the shader-builder; returns its path and the
/// library path it needs.
fn shader_builder(root: &Path) -> anyhow::Result<(PathBuf, String)> {
    let target = cache_dir().join("shader-builder");
    let binary = target.join("release").join("raykit-shader-builder");
    if !binary.exists() {
        println!(
            "xtask: building rust-gpu's codegen backend into {} (once per machine; ~15 min on 2 cores)",
            target.display()
        );
    }
    let started = Instant::now();
    let manifest = root.join("xtask").join("shader-builder").join("Cargo.toml");
    crate::run(
        nightly("cargo")
            .args(["build", "--release", "--locked", "--quiet", "--manifest-path"])
            .arg(&manifest)
            .arg("--target-dir")
            .arg(&target),
        "building the shader builder",
    )?;
    if started.elapsed().as_secs() > 20 {
        println!("xtask: codegen backend built in {:.0} s", started.elapsed().as_secs_f64());
    }
    let sysroot = String::from_utf8(nightly("rustc").args(["--print", "sysroot"]).output()?.stdout)?;
    let lib_path = format!("{}:{}/lib", target.join("release").join("deps").display(), sysroot.trim());
    Ok((binary, lib_path))
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

/// Hashes every file under `dir` (skipping `target`), in a stable order.
fn hash_tree(dir: &Path, hasher: &mut DefaultHasher) -> anyhow::Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.flatten().map(|e| e.path()).collect();
    entries.sort();
    for path in entries {
        if path.file_name().is_some_and(|n| n == "target") {
            continue;
        }
        if path.is_dir() {
            hash_tree(&path, hasher)?;
        } else {
            path.hash(hasher);
            std::fs::read(&path)?.hash(hasher);
        }
    }
    Ok(())
}

fn fingerprint(root: &Path, krate: &DeviceCrate, builder: &Path) -> anyhow::Result<String> {
    let mut hasher = DefaultHasher::new();
    hash_tree(&krate.dir, &mut hasher)?;
    hash_tree(&root.join("device"), &mut hasher)?;
    for file in ["Cargo.toml", "Cargo.lock"] {
        std::fs::read(root.join(file)).unwrap_or_default().hash(&mut hasher);
    }
    let meta = std::fs::metadata(builder)?;
    meta.len().hash(&mut hasher);
    meta.modified()?.hash(&mut hasher);
    Ok(format!("{:016x}", hasher.finish()))
}

/// Builds every device crate; skips those whose inputs did not change.
pub fn build_all(root: &Path, force: bool) -> anyhow::Result<()> {
    let crates = device_crates(root)?;
    if crates.is_empty() {
        bail!("no device crates found (workspace members with [package.metadata.raykit] device = true)");
    }
    let (builder, lib_path) = shader_builder(root)?;
    let out_dir = spirv_dir(root);
    std::fs::create_dir_all(&out_dir)?;
    let shader_target = root.join("target").join("spirv-builder");
    for krate in &crates {
        let file = krate.name.replace('-', "_");
        let spv = out_dir.join(format!("{file}.spv"));
        let stamp = out_dir.join(format!("{file}.stamp"));
        let print = fingerprint(root, krate, &builder)?;
        if !force && spv.exists() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == print) {
            println!("xtask: {} is up to date ({})", krate.name, spv.display());
            continue;
        }
        let started = Instant::now();
        let mut cmd = Command::new(&builder);
        cmd.arg(&krate.dir).arg(&spv).arg(&shader_target).env("LD_LIBRARY_PATH", &lib_path);
        cmd.env_remove("RUSTUP_TOOLCHAIN");
        crate::run(&mut cmd, &format!("building device crate {}", krate.name))?;
        std::fs::write(&stamp, print)?;
        let size = std::fs::metadata(&spv).map(|m| m.len()).unwrap_or(0);
        println!(
            "xtask: built {} → {} ({size} bytes) in {:.1} s",
            krate.name,
            spv.display(),
            started.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
