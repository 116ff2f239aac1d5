//! Compiling one device crate to SPIR-V, skipped when nothing it depends on
//! changed, followed by the launch-params layout check.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::codegen::ShaderBuilder;
use crate::error::{io, Error, Result};
use crate::report::Report;

/// raykit's device crates (`raykit-device`, its macros and ABI), whose changes
/// rebuild every device crate; absent when raykit is not used from a path.
fn raykit_device_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).parent()?.join("device");
    dir.join("Cargo.toml").is_file().then_some(dir)
}

/// One device crate to build.
#[derive(Clone, Debug)]
#[must_use]
pub struct DeviceBuild {
    crate_dir: PathBuf,
    name: Option<String>,
    out_dir: Option<PathBuf>,
    target_dir: Option<PathBuf>,
    check_params: bool,
    force: bool,
    spirv_opt: bool,
    watch: Vec<PathBuf>,
    report: Report,
}

/// What a build produced.
#[derive(Clone, Debug)]
pub struct BuiltModule {
    /// The crate's package name.
    pub name: String,
    /// The SPIR-V file.
    pub spv: PathBuf,
    /// Whether it was compiled now (false: it was up to date).
    pub rebuilt: bool,
    /// Seconds spent compiling (0 when up to date).
    pub seconds: f64,
}

/// How many times a build compiles a crate whose sources keep changing under it.
const REBUILDS_FOR_CHANGES_DURING_A_BUILD: usize = 3;

impl DeviceBuild {
    /// A build of the device crate in `crate_dir` (the directory of its Cargo.toml).
    pub fn new(crate_dir: impl Into<PathBuf>) -> DeviceBuild {
        DeviceBuild {
            crate_dir: crate_dir.into(),
            name: None,
            out_dir: None,
            target_dir: None,
            check_params: true,
            force: false,
            spirv_opt: false,
            watch: Vec::new(),
            report: Report::Terminal,
        }
    }

    /// The crate's package name, when known (else read from its Cargo.toml).
    pub fn name(mut self, name: impl Into<String>) -> Self {
        self.name = Some(name.into());
        self
    }

    /// Where `<crate_name>.spv` goes (default: `<crate>/target/spirv`).
    pub fn out_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.out_dir = Some(dir.into());
        self
    }

    /// The target directory of the nested builds (default: `<crate>/target/raykit`).
    /// It must differ from the target directory of a cargo run that is waiting on
    /// this build (a build script's own), or the two cargo processes deadlock.
    pub fn target_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.target_dir = Some(dir.into());
        self
    }

    /// Run the launch-params layout check after building (default: on).
    pub fn check_params(mut self, on: bool) -> Self {
        self.check_params = on;
        self
    }

    /// Rebuild even when nothing changed.
    pub fn force(mut self, on: bool) -> Self {
        self.force = on;
        self
    }

    /// Post-optimise with `spirv-opt -O` and check with `spirv-val` (SPIRV-Tools).
    pub fn spirv_opt(mut self, on: bool) -> Self {
        self.spirv_opt = on;
        self
    }

    /// Another directory whose changes rebuild the crate (a shared crate it uses by path).
    pub fn watch(mut self, dir: impl Into<PathBuf>) -> Self {
        self.watch.push(dir.into());
        self
    }

    /// How to report progress (default: [`Report::Terminal`]).
    pub fn report(mut self, report: Report) -> Self {
        self.report = report;
        self
    }

    fn package_name(&self) -> Result<String> {
        if let Some(name) = &self.name {
            return Ok(name.clone());
        }
        let manifest = self.crate_dir.join("Cargo.toml");
        let text = std::fs::read_to_string(&manifest).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => Error::NotACrate { path: self.crate_dir.clone() },
            _ => io("reading", &manifest)(e),
        })?;
        package_name_of(&text).ok_or_else(|| Error::Manifest {
            path: manifest.clone(),
            problem: "it has no `name = \"...\"` in a [package] table (or is not TOML cargo can read)",
        })
    }

    /// The directories whose files decide whether the crate must be rebuilt.
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut dirs = vec![self.crate_dir.clone()];
        dirs.extend(self.watch.iter().cloned());
        dirs.extend(raykit_device_dir());
        dirs
    }

    /// Compiles the crate (or finds it up to date) and checks its params layouts.
    ///
    /// A crate whose sources change while it compiles is compiled again (three
    /// times at most), so its SPIR-V is not older than its sources.
    pub fn build(&self) -> Result<BuiltModule> {
        let builder = ShaderBuilder::ensure(self.report)?;
        self.build_with(&builder)
    }

    /// [`DeviceBuild::build`] with a shader builder already ensured (for several crates).
    pub fn build_with(&self, builder: &ShaderBuilder) -> Result<BuiltModule> {
        if !self.crate_dir.join("Cargo.toml").is_file() {
            return Err(Error::NotACrate { path: self.crate_dir.clone() });
        }
        let name = self.package_name()?;
        let file = name.replace('-', "_");
        let out_dir = self.out_dir.clone().unwrap_or_else(|| self.crate_dir.join("target").join("spirv"));
        std::fs::create_dir_all(&out_dir).map_err(io("creating", &out_dir))?;
        let spv = out_dir.join(format!("{file}.spv"));
        let stamp = out_dir.join(format!("{file}.stamp"));
        let print = format!("{}{}", self.fingerprint(builder)?, if self.spirv_opt { "+spirv-opt" } else { "" });
        if !self.force && spv.exists() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == print) {
            self.report.progress(&format!("{name} is up to date ({})", spv.display()));
            return Ok(BuiltModule { name, spv, rebuilt: false, seconds: 0.0 });
        }
        let target_dir = self.target_dir.clone().unwrap_or_else(|| self.crate_dir.join("target").join("raykit"));
        crate::codegen::check_spirv_tools()?;
        let started = Instant::now();
        // A source saved while the compiler runs would leave SPIR-V older than the crate: build again. The
        // stamp records the sources the last compile started from, so sources still changing rebuild next time.
        let (mut built_from, mut now) = (print.clone(), print);
        for _ in 0..REBUILDS_FOR_CHANGES_DURING_A_BUILD {
            built_from = now;
            let mut cmd = builder.command(&self.crate_dir, &spv, &target_dir.join("spirv-builder"));
            compile(&mut cmd, &name, self.report)?;
            now = format!("{}{}", self.fingerprint(builder)?, if self.spirv_opt { "+spirv-opt" } else { "" });
            if now == built_from {
                break;
            }
            self.report.progress(&format!("{name} changed during its build: building it again"));
        }
        if self.spirv_opt {
            spirv_opt(&spv)?;
        }
        let seconds = started.elapsed().as_secs_f64();
        let size = std::fs::metadata(&spv).map(|m| m.len()).unwrap_or(0);
        self.report.progress(&format!("built {name} → {} ({size} bytes) in {seconds:.1} s", spv.display()));
        if self.check_params {
            crate::params::check(&self.crate_dir, &name, &out_dir, &target_dir.join("host"), self.report)?;
        }
        // Written last: a crate whose check failed is rebuilt and checked again.
        std::fs::write(&stamp, built_from).map_err(io("writing", &stamp))?;
        Ok(BuiltModule { name, spv, rebuilt: true, seconds })
    }

    pub(crate) fn fingerprint(&self, builder: &ShaderBuilder) -> Result<String> {
        let mut hasher = DefaultHasher::new();
        for dir in self.inputs() {
            hash_tree(&dir, &mut hasher, Locks::Hashed)?;
        }
        // The lock file and manifest of the workspace the crate belongs to.
        if let Some(root) = self.crate_dir.ancestors().find(|d| d.join("Cargo.lock").is_file()) {
            for file in ["Cargo.toml", "Cargo.lock"] {
                std::fs::read(root.join(file)).unwrap_or_default().hash(&mut hasher);
            }
        }
        let meta = std::fs::metadata(&builder.binary).map_err(io("reading", &builder.binary))?;
        meta.len().hash(&mut hasher);
        meta.modified().map_err(io("reading", &builder.binary))?.hash(&mut hasher);
        Ok(format!("{:016x}", hasher.finish()))
    }

    /// A hash of the sources and manifests the crate is built from, leaving out
    /// lock files: the watcher's test for "the user changed something" (cargo
    /// itself rewrites a crate's `Cargo.lock` during a build, which must not
    /// start another one).
    #[cfg(feature = "watch")]
    pub(crate) fn source_fingerprint(&self) -> Result<String> {
        let mut hasher = DefaultHasher::new();
        for dir in self.inputs() {
            hash_tree(&dir, &mut hasher, Locks::Skipped)?;
        }
        Ok(format!("{:016x}", hasher.finish()))
    }

    /// From a build script: builds the crate under the build's `OUT_DIR` (nested
    /// builds in `<target>/raykit`, beside cargo's own profile directories), tells
    /// cargo to rerun when the crate's sources change, and sets `<crate>.spv`
    /// (spirv-builder's convention, e.g. `env!("my-device.spv")`) to the SPIR-V
    /// file for `raykit::include_spirv!`. Messages go to cargo
    /// ([`Report::BuildScript`]).
    pub fn build_script(self) -> Result<BuiltModule> {
        let out = std::env::var_os("OUT_DIR").ok_or(Error::NotABuildScript("OUT_DIR"))?;
        let out = PathBuf::from(out);
        let mut this = self.report(Report::BuildScript);
        if this.out_dir.is_none() {
            this.out_dir = Some(out.join("spirv"));
        }
        if this.target_dir.is_none() {
            this.target_dir = Some(target_dir_of(&out).join("raykit"));
        }
        crate::toolchain::ensure_toolchain(Report::BuildScript)?;
        for dir in this.inputs() {
            for entry in ["src", "Cargo.toml", "build.rs"] {
                let path = dir.join(entry);
                if path.exists() {
                    println!("cargo:rerun-if-changed={}", path.display());
                }
            }
        }
        if let Some(root) = this.crate_dir.ancestors().find(|d| d.join("Cargo.lock").is_file()) {
            println!("cargo:rerun-if-changed={}", root.join("Cargo.lock").display());
        }
        println!("cargo:rerun-if-env-changed=RAYKIT_CACHE_DIR");
        let built = this.build()?;
        println!("cargo:rustc-env={}={}", env_var_name(&built.name), built.spv.display());
        Ok(built)
    }
}

/// The variable [`DeviceBuild::build_script`] sets for device crate `name`.
pub fn env_var_name(name: &str) -> String {
    format!("{name}.spv")
}

/// The cargo target directory holding a build script's `OUT_DIR`
/// (`<target>/[<triple>/]<profile>/build/<pkg>-<hash>/out`).
fn target_dir_of(out_dir: &Path) -> PathBuf {
    if let Some(dir) = std::env::var_os("CARGO_TARGET_DIR") {
        return PathBuf::from(dir);
    }
    // out → <pkg>-<hash> → build → <profile>; its parent is the target dir (or <target>/<triple>).
    let profile = out_dir.ancestors().find(|d| d.file_name().is_some_and(|n| n == "build")).and_then(Path::parent);
    match profile.and_then(Path::parent) {
        Some(dir) => dir.to_path_buf(),
        None => out_dir.to_path_buf(),
    }
}

/// The `name` of the `[package]` table of a manifest.
fn package_name_of(manifest: &str) -> Option<String> {
    let mut in_package = false;
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            in_package = line == "[package]";
            continue;
        }
        if in_package {
            if let Some(rest) = line.strip_prefix("name") {
                let value = rest.trim_start().strip_prefix('=')?.trim();
                return Some(value.trim_matches('"').to_owned());
            }
        }
    }
    None
}

/// Hashes every file under `dir` (skipping `target`), in a stable order.
/// Whether [`hash_tree`] hashes `Cargo.lock` files.
#[derive(Clone, Copy, PartialEq)]
enum Locks {
    Hashed,
    Skipped,
}

fn hash_tree(dir: &Path, hasher: &mut DefaultHasher, locks: Locks) -> Result<()> {
    let mut entries: Vec<_> = std::fs::read_dir(dir).map_err(io("reading", dir))?.flatten().map(|e| e.path()).collect();
    entries.sort();
    for path in entries {
        if path.file_name().is_some_and(|n| n == "target" || (locks == Locks::Skipped && n == "Cargo.lock")) {
            continue;
        }
        if path.is_dir() {
            hash_tree(&path, hasher, locks)?;
        } else {
            path.hash(hasher);
            std::fs::read(&path).map_err(io("reading", &path))?.hash(hasher);
        }
    }
    Ok(())
}

/// Runs the shader builder; on failure returns rustc's messages.
fn compile(cmd: &mut Command, name: &str, report: Report) -> Result<()> {
    report.route(cmd);
    let output = cmd.stderr(std::process::Stdio::piped()).output().map_err(|e| Error::Command {
        what: format!("starting the shader builder for {name}"),
        status: e.to_string(),
        output: String::new(),
    })?;
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    // rustc's messages once: in the error when the build failed (whoever reports
    // the error prints them), else as they came (warnings, progress).
    if !output.status.success() {
        return Err(Error::Compile { krate: name.to_owned(), message: stderr });
    }
    if report != Report::Quiet {
        eprint!("{stderr}");
    }
    Ok(())
}

/// Runs `spirv-opt -O` over `spv` in place and checks the result with
/// `spirv-val`; leaves the module as rust-gpu wrote it when either fails.
fn spirv_opt(spv: &Path) -> Result<()> {
    let out = spv.with_extension("opt.spv");
    let layout = ["--target-env=vulkan1.2", "--scalar-block-layout"];
    let tool = |program: &str, args: &mut Command| -> Result<()> {
        let o = args.output().map_err(|e| Error::Command {
            what: format!("{program} (apt-get install spirv-tools)"),
            status: e.to_string(),
            output: String::new(),
        })?;
        if !o.status.success() {
            let _ = std::fs::remove_file(&out);
            return Err(Error::Command {
                what: format!("{program} on {}", spv.display()),
                status: o.status.to_string(),
                output: String::from_utf8_lossy(&o.stderr).into_owned(),
            });
        }
        Ok(())
    };
    tool("spirv-opt -O", Command::new("spirv-opt").arg("-O").args(layout).arg(spv).arg("-o").arg(&out))?;
    tool(
        "spirv-val",
        Command::new("spirv-val").args(["--target-env", "vulkan1.2", "--scalar-block-layout"]).arg(&out),
    )?;
    std::fs::rename(&out, spv).map_err(io("renaming", &out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_package_name() {
        let manifest = "[workspace]\nname = \"no\"\n\n[package]\nname = \"my-device\"\nversion = \"0.1.0\"\n";
        assert_eq!(package_name_of(manifest).as_deref(), Some("my-device"));
        assert_eq!(package_name_of("[dependencies]\nname = \"x\"\n"), None);
    }

    #[test]
    fn env_var_names_follow_spirv_builder() {
        assert_eq!(env_var_name("my-device"), "my-device.spv");
    }

    #[test]
    fn target_dir_is_above_the_profile() {
        let out = Path::new("/p/target/debug/build/app-0123/out");
        if std::env::var_os("CARGO_TARGET_DIR").is_none() {
            assert_eq!(target_dir_of(out), Path::new("/p/target"));
        }
    }

    #[test]
    fn a_manifest_without_a_package_name_is_a_manifest_error_not_a_missing_crate() {
        let dir = std::env::temp_dir().join(format!("raykit-builder-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a temp dir");
        std::fs::write(dir.join("Cargo.toml"), "[package\nname = broken").expect("a manifest");
        let err = DeviceBuild::new(&dir).package_name().unwrap_err();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(matches!(err, Error::Manifest { .. }), "{err}");
        assert!(err.to_string().contains("Cargo.toml names no package"), "{err}");
    }

    #[test]
    fn a_missing_crate_is_a_typed_error() {
        let err = DeviceBuild::new("/nonexistent/device").package_name().unwrap_err();
        assert!(matches!(err, Error::NotACrate { .. }), "{err}");
    }
}
