//! The builder's error type.

use std::path::PathBuf;

/// What can go wrong while building a device crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// rustup is missing, so the pinned nightly cannot be installed.
    #[error(
        "rustup is not available; raykit's device builds need {toolchain} (with {components}). Install rustup \
         (https://rustup.rs) or run: rustup toolchain install {toolchain} --profile minimal --component {components}"
    )]
    NoRustup {
        /// The toolchain needed.
        toolchain: &'static str,
        /// Its components, comma-separated.
        components: String,
    },
    /// A command could not be started or failed.
    #[error("{what} failed ({status}){}", if output.is_empty() { String::new() } else { format!(":\n{output}") })]
    Command {
        /// What was run.
        what: String,
        /// Its exit status, or why it did not start.
        status: String,
        /// What it printed on stderr, when captured.
        output: String,
    },
    /// SPIRV-Tools' `spirv-opt` or `spirv-val`, which rust-gpu's codegen backend runs, is not on `PATH`.
    #[error(
        "rust-gpu's codegen backend optimises and validates SPIR-V with SPIRV-Tools, but {} not on PATH. \
         Install SPIRV-Tools: on Debian or Ubuntu `apt-get install spirv-tools`, elsewhere the Vulkan SDK \
         (https://vulkan.lunarg.com)",
        if missing.len() == 1 { format!("{} is", missing[0]) } else { format!("{} are", missing.join(" and ")) }
    )]
    SpirvTools {
        /// The tools not found.
        missing: Vec<&'static str>,
    },
    /// rustc (with rust-gpu's backend) rejected the device crate.
    #[error("compiling device crate {krate} to SPIR-V failed:\n{message}")]
    Compile {
        /// The device crate.
        krate: String,
        /// rustc's messages.
        message: String,
    },
    /// A launch-params or buffer-element struct is laid out differently on the host and in the SPIR-V.
    #[error("a launch-params or buffer-element struct of {krate} disagrees with the SPIR-V built from it:\n{message}")]
    ParamsLayout {
        /// The device crate.
        krate: String,
        /// raykit's layout messages (field, both offsets, the fix).
        message: String,
    },
    /// raykit's fix to the codegen backend no longer applies to its source.
    #[error(
        "cannot apply raykit's patch {patch} to {file}: {reason}. The codegen crate's source is not the one the patch \
         was written for; check the pinned rust-gpu version"
    )]
    Patch {
        /// The patch's name.
        patch: &'static str,
        /// The file it patches.
        file: PathBuf,
        /// Why it does not apply.
        reason: String,
    },
    /// A path that must be a device crate is not one.
    #[error("{path} is not a crate directory (no Cargo.toml); pass the directory of the device crate")]
    NotACrate {
        /// The path given.
        path: PathBuf,
    },
    /// A device crate's `Cargo.toml` names no package.
    #[error("{path} names no package: {problem}; give it a [package] table with name = \"...\"")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// A new project's directory already has files.
    #[error("{path} is not empty: choose a new directory for the project")]
    NotEmpty {
        /// The directory.
        path: PathBuf,
    },
    /// A new project's directory name makes no package name.
    #[error("cannot name a project after {path}: {reason}; choose another directory name, one that starts with a letter (e.g. my-renderer)")]
    ProjectName {
        /// The directory.
        path: PathBuf,
        /// Why its name does not do.
        reason: String,
    },
    /// The file watcher could not start.
    #[error("watching the device crate's sources: {reason}")]
    Watch {
        /// notify's error.
        reason: String,
    },
    /// An I/O error on a named path.
    #[error("{what} {path}: {source}")]
    Io {
        /// What was being done.
        what: &'static str,
        /// On which path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// A variable that cargo sets for build scripts is missing.
    #[error("{0} is not set: `build_script` must be called from a build.rs run by cargo")]
    NotABuildScript(&'static str),
}

/// The builder's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

pub(crate) fn io<'a>(what: &'static str, path: &'a std::path::Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io { what, path: path.to_owned(), source }
}
