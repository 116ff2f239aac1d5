//! # raykit-builder
//!
//! Builds raykit device crates to SPIR-V with rust-gpu 0.11, from a build script
//! or an xtask:
//!
//! * installs the pinned nightly ([`TOOLCHAIN`]) with rustup when it is missing,
//!   and says so;
//! * builds rust-gpu's codegen backend once per user into a cache
//!   ([`cache_dir`]), with raykit's fix to it applied from a reviewed patch file
//!   ([`CODEGEN_PATCH`]); the backend runs SPIRV-Tools' `spirv-opt` and
//!   `spirv-val` from `PATH` ([`SPIRV_TOOLS`]; Debian's `spirv-tools`);
//! * compiles a device crate to one `.spv`, skipped when neither it nor raykit's
//!   device crates changed;
//! * runs the launch-params layout check and reports a mismatch as a build error
//!   with raykit's message.
//!
//! In a host crate's `build.rs`:
//!
//! ```no_run
//! // build.rs
//! let device = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("device");
//! if let Err(e) = raykit_builder::DeviceBuild::new(device).build_script() {
//!     eprintln!("error: {e}");
//!     std::process::exit(1);
//! }
//! ```
//!
//! and in its code, `raykit::include_spirv!("my-device")` embeds the result.
//!
//! The codegen backend must be built by the pinned nightly, while build scripts
//! and xtasks run on stable: so the backend is linked into a small program
//! (`shader-builder/`, on rust-gpu's `spirv-builder`) built into the cache, and
//! this crate runs it.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod codegen;
mod device;
mod error;
pub mod params;
mod report;
mod template;
mod toolchain;
#[cfg(feature = "watch")]
mod watch;

pub use codegen::{
    apply_codegen_patch, cache_dir, check_spirv_tools, ShaderBuilder, CODEGEN_CRATE, CODEGEN_PATCH, SPIRV_TOOLS,
};
pub use device::{env_var_name, BuiltModule, DeviceBuild};
pub use error::{Error, Result};
pub use report::Report;
pub use template::{project_name, raykit_root, write_new_project};
pub use toolchain::{ensure_toolchain, nightly, rustup, COMPONENTS, TOOLCHAIN};
#[cfg(feature = "watch")]
pub use watch::{DeviceWatcher, Rebuild};
