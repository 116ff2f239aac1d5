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

/// The rust-gpu codegen crate raykit builds with its fix applied.
const CODEGEN_CRATE: &str = "rustc_codegen_spirv-0.11.0";

/// raykit's fix to rust-gpu 0.11 (to be upstreamed): its linker erases the
/// `Offset`/`ArrayStride` decorations of every type reached through a storage
/// class other than push-constant, uniform, storage or physical-storage buffers.
/// `ShaderRecordBufferKHR` needs them too (Vulkan requires an explicit layout
/// for shader records), or programs read their SBT data from undefined offsets.
const CODEGEN_PATCH: (&str, &str, &str) = (
    "src/linker/spirt_passes/explicit_layout.rs",
    "        .map(AddrSpace::SpvStorageClass)\n        .contains(&addr_space)\n    }",
    "        .map(AddrSpace::SpvStorageClass)\n        .contains(&addr_space)\n            // raykit: ShaderRecordBufferKHR (5343) needs explicit layout too.\n            || addr_space == AddrSpace::SpvStorageClass(5343)\n    }",
);

fn copy_tree(from: &Path, to: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            if entry.file_name() != "target" {
                copy_tree(&entry.path(), &target)?;
            }
        } else {
            let bytes = std::fs::read(entry.path())?;
            if std::fs::read(&target).ok().as_deref() != Some(&bytes[..]) {
                std::fs::write(&target, bytes)?;
            }
        }
    }
    Ok(())
}

/// Copies the codegen crate's source from cargo's registry into `dest` and
/// applies [`CODEGEN_PATCH`]; leaves an already patched copy untouched.
fn patched_codegen(builder_src: &Path, dest: &Path) -> anyhow::Result<()> {
    let (file, from, to) = CODEGEN_PATCH;
    if std::fs::read_to_string(dest.join(file)).is_ok_and(|t| t.contains(to)) {
        return Ok(());
    }
    // Download the pinned dependencies (the codegen crate's source among them).
    crate::run(
        nightly("cargo").args(["fetch", "--locked", "--quiet", "--manifest-path"]).arg(builder_src.join("Cargo.toml")),
        "cargo fetch (shader builder)",
    )?;
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
        .context("neither CARGO_HOME nor HOME is set")?;
    let registry = cargo_home.join("registry").join("src");
    let source = std::fs::read_dir(&registry)
        .with_context(|| format!("reading {}", registry.display()))?
        .flatten()
        .map(|index| index.path().join(CODEGEN_CRATE))
        .find(|p| p.join("Cargo.toml").exists())
        .with_context(|| format!("{CODEGEN_CRATE} not found under {} after cargo fetch", registry.display()))?;
    copy_tree(&source, dest)?;
    let path = dest.join(file);
    let text = std::fs::read_to_string(&path)?;
    if !text.contains(from) {
        bail!("cannot apply raykit's fix to {}: the code it patches changed", path.display());
    }
    std::fs::write(&path, text.replacen(from, to, 1))?;
    println!("xtask: applied raykit's shader-record layout fix to {CODEGEN_CRATE} ({})", dest.display());
    Ok(())
}

/// Builds (or finds up to date) the shader-builder; returns its path and the
/// library path it needs.
fn shader_builder(root: &Path) -> anyhow::Result<(PathBuf, String)> {
    let cache = cache_dir();
    let target = cache.join("shader-builder");
    let binary = target.join("release").join("raykit-shader-builder");
    if !binary.exists() {
        println!(
            "xtask: building rust-gpu's codegen backend into {} (once per machine; ~15 min on 2 cores)",
            target.display()
        );
    }
    let started = Instant::now();
    // Build from a copy at a fixed place in the cache, so every clone of the
    // repository shares one build, with the patched codegen crate beside it.
    let builder_src = cache.join("shader-builder-src");
    copy_tree(&root.join("xtask").join("shader-builder"), &builder_src)?;
    let codegen = cache.join("patched").join(CODEGEN_CRATE);
    patched_codegen(&builder_src, &codegen)?;
    let manifest = builder_src.join("Cargo.toml");
    crate::run(
        nightly("cargo")
            .args(["build", "--release", "--quiet", "--manifest-path"])
            .arg(&manifest)
            .arg("--target-dir")
            .arg(&target)
            .arg("--config")
            .arg(format!("patch.crates-io.rustc_codegen_spirv.path={:?}", codegen.display().to_string())),
        "building the shader builder",
    )?;
    if started.elapsed().as_secs() > 20 {
        println!("xtask: codegen backend built in {:.0} s", started.elapsed().as_secs_f64());
    }
    let sysroot = String::from_utf8(nightly("rustc").args(["--print", "sysroot"]).output()?.stdout)?;
    let release = target.join("release");
    let lib_path = format!("{}:{}:{}/lib", release.display(), release.join("deps").display(), sysroot.trim());
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
        let opt = spirv_opt_enabled();
        let print = format!("{}{}", fingerprint(root, krate, &builder)?, if opt { "+spirv-opt" } else { "" });
        if !force && spv.exists() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == print) {
            println!("xtask: {} is up to date ({})", krate.name, spv.display());
            continue;
        }
        let started = Instant::now();
        let mut cmd = Command::new(&builder);
        cmd.arg(&krate.dir).arg(&spv).arg(&shader_target).env("LD_LIBRARY_PATH", &lib_path);
        cmd.env_remove("RUSTUP_TOOLCHAIN");
        crate::run(&mut cmd, &format!("building device crate {}", krate.name))?;
        if opt {
            spirv_opt(&spv)?;
        }
        std::fs::write(&stamp, print)?;
        let size = std::fs::metadata(&spv).map(|m| m.len()).unwrap_or(0);
        println!(
            "xtask: built {} → {} ({size} bytes) in {:.1} s",
            krate.name,
            spv.display(),
            started.elapsed().as_secs_f64()
        );
    }
    check_params_layouts(&crates, &out_dir)
}

/// Set by `build-shaders --spirv-opt`.
pub static SPIRV_OPT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `RAYKIT_SPIRV_OPT` (or `build-shaders --spirv-opt`) asks for
/// `spirv-opt -O` after rust-gpu.
fn spirv_opt_enabled() -> bool {
    SPIRV_OPT.load(std::sync::atomic::Ordering::Relaxed)
        || std::env::var("RAYKIT_SPIRV_OPT").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// Runs `spirv-opt -O` over `spv` in place (the GLSL twins' pipeline) and checks
/// the result with `spirv-val`; leaves the module as rust-gpu wrote it when
/// either fails. rust-gpu already runs most of what `-O` does (inlining,
/// mem2reg, scalar replacement, dead-code elimination); `-O` adds mainly FMA
/// fusion and a few folds.
fn spirv_opt(spv: &Path) -> anyhow::Result<()> {
    let out = spv.with_extension("opt.spv");
    let layout = ["--target-env=vulkan1.2", "--scalar-block-layout"];
    crate::run(
        Command::new("spirv-opt").arg("-O").args(layout).arg(spv).arg("-o").arg(&out),
        "spirv-opt -O (apt-get install spirv-tools)",
    )?;
    let val =
        Command::new("spirv-val").args(["--target-env", "vulkan1.2", "--scalar-block-layout"]).arg(&out).output()?;
    if !val.status.success() {
        let _ = std::fs::remove_file(&out);
        bail!(
            "spirv-opt -O produced an invalid module from {}:\n{}",
            spv.display(),
            String::from_utf8_lossy(&val.stderr)
        );
    }
    std::fs::rename(&out, spv)?;
    Ok(())
}

/// Rebuilds device crate `name` (its dependencies already built) and returns
/// the seconds it took: the shader build time the benchmarks report.
pub fn time_rebuild(root: &Path, name: &str) -> anyhow::Result<f64> {
    let krate =
        device_crates(root)?.into_iter().find(|k| k.name == name).with_context(|| format!("no device crate {name}"))?;
    let (builder, lib_path) = shader_builder(root)?;
    let spv = spirv_dir(root).join(format!("{}.spv", name.replace('-', "_")));
    // Touch a source file so cargo recompiles the crate itself.
    let lib = krate.dir.join("src").join("lib.rs");
    let text = std::fs::read(&lib)?;
    std::fs::write(&lib, &text)?;
    let started = Instant::now();
    let mut cmd = Command::new(&builder);
    cmd.arg(&krate.dir).arg(&spv).arg(root.join("target").join("spirv-builder")).env("LD_LIBRARY_PATH", &lib_path);
    cmd.env_remove("RUSTUP_TOOLCHAIN");
    crate::run(&mut cmd, &format!("building device crate {name}"))?;
    Ok(started.elapsed().as_secs_f64())
}

/// Runs the tests that `#[params]` programs generate: each compares the host's
/// layout of its params struct with the SPIR-V just built, and fails with the
/// same message as `Pipeline::new` would.
fn check_params_layouts(crates: &[DeviceCrate], spirv_dir: &Path) -> anyhow::Result<()> {
    let started = Instant::now();
    let mut cmd = crate::cargo();
    cmd.args(["test", "--quiet", "--lib"]);
    for krate in crates {
        cmd.args(["-p", &krate.name]);
    }
    cmd.args(["--", "__raykit_params_layout_"]).env("RAYKIT_SPIRV_DIR", spirv_dir);
    let output = cmd.output().context("running the params layout checks")?;
    if !output.status.success() {
        let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        let reasons: Vec<&str> = text
            .lines()
            .filter(|l| l.contains("launch params") || l.contains("reads its params") || l.starts_with("error"))
            .collect();
        bail!(
            "a launch-params struct disagrees with the SPIR-V built from it:\n{}\n(full output of the check follows)\n{text}",
            reasons.join("\n")
        );
    }
    println!("xtask: params layouts match the SPIR-V ({:.1} s)", started.elapsed().as_secs_f64());
    Ok(())
}
