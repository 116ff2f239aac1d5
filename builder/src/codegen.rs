//! rust-gpu's codegen backend (`rustc_codegen_spirv`), with raykit's fix applied,
//! built once per user into a cache and linked into the small `shader-builder`
//! program that compiles device crates.
//!
//! The cache is `$RAYKIT_CACHE_DIR`, else `$XDG_CACHE_HOME/raykit`, else
//! `~/.cache/raykit`: every project (and every clone of raykit) shares one build
//! of the backend (about 4 minutes on 2 cores beside other builds, 3½ alone).
//!
//! The backend runs SPIRV-Tools (`spirv-opt`, `spirv-val`) from `PATH` (Debian's
//! `spirv-tools` package) rather than compiling their C++ into itself.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::error::{io, Error, Result};
use crate::report::Report;
use crate::toolchain::{nightly, run};

/// The sources of the shader-builder program, written into the cache and built
/// there with the pinned nightly.
const SHADER_BUILDER_FILES: [(&str, &str); 5] = [
    ("Cargo.toml", include_str!("../shader-builder/Cargo.toml")),
    ("Cargo.lock", include_str!("../shader-builder/Cargo.lock")),
    ("build.rs", include_str!("../shader-builder/build.rs")),
    ("rust-toolchain.toml", include_str!("../shader-builder/rust-toolchain.toml")),
    ("src/main.rs", include_str!("../shader-builder/src/main.rs")),
];

/// The rust-gpu codegen crate raykit builds with its fix applied.
pub const CODEGEN_CRATE: &str = "rustc_codegen_spirv-0.11.0";

/// raykit's fix to rust-gpu 0.11 (see `docs/upstream/`): its linker erases the
/// `Offset`/`ArrayStride` decorations of types reached through
/// `ShaderRecordBufferKHR`, which Vulkan requires to be explicitly laid out.
pub const CODEGEN_PATCH: &str = include_str!("../patches/rustc_codegen_spirv-0.11.0-shader-record-layout.patch");
const CODEGEN_PATCH_NAME: &str = "rustc_codegen_spirv-0.11.0-shader-record-layout.patch";

/// The per-user cache directory.
pub fn cache_dir() -> PathBuf {
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

/// Writes `bytes` to `path` unless it already holds them (so cargo's
/// fingerprints, which look at modification times, stay valid).
fn write_if_changed(path: &Path, bytes: &[u8]) -> Result<()> {
    if std::fs::read(path).ok().as_deref() == Some(bytes) {
        return Ok(());
    }
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(io("creating", parent))?;
    }
    std::fs::write(path, bytes).map_err(io("writing", path))
}

fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    std::fs::create_dir_all(to).map_err(io("creating", to))?;
    for entry in std::fs::read_dir(from).map_err(io("reading", from))? {
        let entry = entry.map_err(io("reading", from))?;
        let target = to.join(entry.file_name());
        let is_dir = entry.file_type().map_err(io("reading", &entry.path()))?.is_dir();
        if is_dir {
            if entry.file_name() != "target" {
                copy_tree(&entry.path(), &target)?;
            }
        } else {
            let bytes = std::fs::read(entry.path()).map_err(io("reading", &entry.path()))?;
            write_if_changed(&target, &bytes)?;
        }
    }
    Ok(())
}

/// The file [`CODEGEN_PATCH`] changes, relative to the crate's root.
fn patched_file() -> Result<(PathBuf, diffy::Patch<'static, str>)> {
    let patch = diffy::Patch::from_str(CODEGEN_PATCH).map_err(|e| Error::Patch {
        patch: CODEGEN_PATCH_NAME,
        file: PathBuf::new(),
        reason: format!("the patch file does not parse: {e}"),
    })?;
    let name = patch.modified().or(patch.original()).unwrap_or_default();
    let file = PathBuf::from(name.strip_prefix("b/").or(name.strip_prefix("a/")).unwrap_or(name));
    Ok((file, patch))
}

/// Applies [`CODEGEN_PATCH`] to the text of the file it patches; fails when a
/// line of its context or a removed line differs.
pub fn apply_codegen_patch(original: &str) -> Result<String> {
    let (file, patch) = patched_file()?;
    diffy::apply(original, &patch).map_err(|e| Error::Patch { patch: CODEGEN_PATCH_NAME, file, reason: e.to_string() })
}

/// Whether `text` already carries every line the patch adds.
fn is_patched(text: &str) -> bool {
    let added: Vec<&str> =
        CODEGEN_PATCH.lines().filter(|l| l.starts_with('+') && !l.starts_with("+++")).map(|l| &l[1..]).collect();
    !added.is_empty() && added.iter().all(|line| text.lines().any(|t| t == *line))
}

fn cargo_home() -> Option<PathBuf> {
    std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")))
}

/// Copies the codegen crate's source from cargo's registry into `dest` and
/// applies [`CODEGEN_PATCH`]; leaves an already patched copy untouched.
fn patched_codegen(builder_src: &Path, dest: &Path, report: Report) -> Result<()> {
    let (file, _) = patched_file()?;
    if std::fs::read_to_string(dest.join(&file)).is_ok_and(|t| is_patched(&t)) {
        return Ok(());
    }
    // Download the pinned dependencies (the codegen crate's source among them).
    run(
        nightly("cargo").args(["fetch", "--locked", "--quiet", "--manifest-path"]).arg(builder_src.join("Cargo.toml")),
        "cargo fetch (shader builder)",
        report,
    )?;
    let Some(home) = cargo_home() else {
        return Err(Error::Command {
            what: "finding cargo's registry".to_owned(),
            status: "neither CARGO_HOME nor HOME is set".to_owned(),
            output: String::new(),
        });
    };
    let registry = home.join("registry").join("src");
    let source = std::fs::read_dir(&registry)
        .map_err(io("reading", &registry))?
        .flatten()
        .map(|index| index.path().join(CODEGEN_CRATE))
        .find(|p| p.join("Cargo.toml").exists())
        .ok_or_else(|| Error::Command {
            what: format!("finding {CODEGEN_CRATE} under {}", registry.display()),
            status: "not found after cargo fetch".to_owned(),
            output: String::new(),
        })?;
    copy_tree(&source, dest)?;
    let path = dest.join(&file);
    let text = std::fs::read_to_string(&path).map_err(io("reading", &path))?;
    let patched = apply_codegen_patch(&text)?;
    std::fs::write(&path, patched).map_err(io("writing", &path))?;
    report.notable(&format!("applied {CODEGEN_PATCH_NAME} to {}", dest.display()));
    Ok(())
}

/// The SPIRV-Tools programs the codegen backend runs: it is built with
/// rust-gpu's `use-installed-tools`, which runs them from `PATH` instead of
/// compiling SPIRV-Tools' C++ into the backend (that build alone takes longer
/// than all of the backend's Rust).
pub const SPIRV_TOOLS: [&str; 2] = ["spirv-opt", "spirv-val"];

/// Fails with [`Error::SpirvTools`] unless every one of [`SPIRV_TOOLS`] runs.
pub fn check_spirv_tools() -> Result<()> {
    let runs = |tool: &str| Command::new(tool).arg("--version").output().is_ok_and(|o| o.status.success());
    let missing: Vec<&'static str> = SPIRV_TOOLS.into_iter().filter(|tool| !runs(tool)).collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(Error::SpirvTools { missing })
    }
}

/// The shader-builder program, built and ready to run.
#[derive(Clone, Debug)]
pub struct ShaderBuilder {
    /// The executable.
    pub binary: PathBuf,
    /// The library path it needs (the codegen backend and the nightly's libraries).
    pub library_path: String,
}

impl ShaderBuilder {
    /// Builds (or finds up to date) the shader builder and its codegen backend in
    /// the per-user cache. Call [`crate::ensure_toolchain`] first.
    pub fn ensure(report: Report) -> Result<ShaderBuilder> {
        let cache = cache_dir();
        let target = cache.join("shader-builder");
        let binary = target.join("release").join("raykit-shader-builder");
        if !binary.exists() {
            report.notable(&format!(
                "building rust-gpu's codegen backend into {} (once per user; a few minutes on 2 cores)",
                target.display()
            ));
        }
        let started = Instant::now();
        // Built from a copy at a fixed place in the cache, so every project shares
        // one build, with the patched codegen crate beside it.
        let builder_src = cache.join("shader-builder-src");
        for (name, text) in SHADER_BUILDER_FILES {
            write_if_changed(&builder_src.join(name), text.as_bytes())?;
        }
        let codegen = cache.join("patched").join(CODEGEN_CRATE);
        patched_codegen(&builder_src, &codegen, report)?;
        run(
            nightly("cargo")
                .args(["build", "--release", "--quiet", "--manifest-path"])
                .arg(builder_src.join("Cargo.toml"))
                .arg("--target-dir")
                .arg(&target)
                .arg("--config")
                .arg(format!("patch.crates-io.rustc_codegen_spirv.path={:?}", codegen.display().to_string())),
            "building the shader builder",
            report,
        )?;
        if started.elapsed().as_secs() > 20 {
            report.notable(&format!("codegen backend built in {:.0} s", started.elapsed().as_secs_f64()));
        }
        let sysroot = nightly("rustc").args(["--print", "sysroot"]).output().map_err(|e| Error::Command {
            what: "rustc --print sysroot".to_owned(),
            status: e.to_string(),
            output: String::new(),
        })?;
        let sysroot = String::from_utf8_lossy(&sysroot.stdout).trim().to_owned();
        let release = target.join("release");
        let library_path = format!("{}:{}:{sysroot}/lib", release.display(), release.join("deps").display());
        Ok(ShaderBuilder { binary, library_path })
    }

    /// A command that compiles the crate at `crate_dir` to `out_file`, with
    /// `target_dir` for the nested nightly build.
    pub fn command(&self, crate_dir: &Path, out_file: &Path, target_dir: &Path) -> Command {
        let mut cmd = Command::new(&self.binary);
        crate::toolchain::scrub_cargo_env(&mut cmd);
        cmd.arg(crate_dir).arg(out_file).arg(target_dir).env("LD_LIBRARY_PATH", &self.library_path);
        // The builder runs `cargo +<nightly>`: make sure that `cargo` is rustup's proxy.
        if let Some(bin) = cargo_home().map(|h| h.join("bin")).filter(|b| b.join("rustup").exists()) {
            let path = std::env::var_os("PATH").unwrap_or_default();
            let mut paths = vec![bin];
            paths.extend(std::env::split_paths(&path));
            if let Ok(joined) = std::env::join_paths(paths) {
                cmd.env("PATH", joined);
            }
        }
        cmd
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ORIGINAL: &str = "        ]\n        .map(AddrSpace::SpvStorageClass)\n        .contains(&addr_space)\n    }\n\n    // FIXME(eddyb) properly distinguish between zero-extension and sign-extension.\n";

    fn with_context(body: &str) -> String {
        // The hunk starts at line 410: pad so the line numbers match.
        format!("{}{body}", "x\n".repeat(409))
    }

    #[test]
    fn missing_spirv_tools_are_named_with_the_fix() {
        let one = Error::SpirvTools { missing: vec!["spirv-opt"] }.to_string();
        assert!(one.contains("but spirv-opt is not on PATH"), "{one}");
        assert!(one.contains("apt-get install spirv-tools"), "{one}");
        let both = Error::SpirvTools { missing: SPIRV_TOOLS.to_vec() }.to_string();
        assert!(both.contains("but spirv-opt and spirv-val are not on PATH"), "{both}");
    }

    #[test]
    fn the_spirv_tools_are_found_where_installed() {
        // `cargo xtask test` installs them before the tests run.
        check_spirv_tools().expect("spirv-opt and spirv-val run");
    }

    #[test]
    fn patch_adds_the_shader_record_storage_class() {
        let patched = apply_codegen_patch(&with_context(ORIGINAL)).unwrap();
        assert!(patched.contains(
            "        .contains(&addr_space)\n            // raykit: ShaderRecordBufferKHR (5343) needs explicit layout too.\n            || addr_space == AddrSpace::SpvStorageClass(5343)\n    }\n"
        ));
        assert!(is_patched(&patched));
        assert!(!is_patched(&with_context(ORIGINAL)));
    }

    #[test]
    fn patch_refuses_changed_code() {
        let changed = with_context(&ORIGINAL.replace(".contains(&addr_space)", ".any(|s| s == addr_space)"));
        let err = apply_codegen_patch(&changed).unwrap_err();
        assert!(matches!(err, Error::Patch { .. }), "{err}");
        assert!(err.to_string().contains("explicit_layout.rs"), "{err}");
    }

    #[test]
    fn patch_matches_the_registry_source_byte_for_byte_when_present() {
        // On a machine that has fetched the codegen crate, the patch applied to the
        // registry's file gives exactly the text of the previous string replace.
        let Some(home) = cargo_home() else { return };
        let Ok(dirs) = std::fs::read_dir(home.join("registry").join("src")) else { return };
        for dir in dirs.flatten() {
            let file = dir.path().join(CODEGEN_CRATE).join("src/linker/spirt_passes/explicit_layout.rs");
            let Ok(text) = std::fs::read_to_string(&file) else { continue };
            let from = "        .map(AddrSpace::SpvStorageClass)\n        .contains(&addr_space)\n    }";
            let to = "        .map(AddrSpace::SpvStorageClass)\n        .contains(&addr_space)\n            // raykit: ShaderRecordBufferKHR (5343) needs explicit layout too.\n            || addr_space == AddrSpace::SpvStorageClass(5343)\n    }";
            assert_eq!(apply_codegen_patch(&text).unwrap(), text.replacen(from, to, 1));
        }
    }
}
