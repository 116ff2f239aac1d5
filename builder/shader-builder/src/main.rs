//! `raykit-shader-builder <crate-dir> <out-file.spv> [<target-dir>]`
//!
//! Compiles one rust-gpu device crate to a single SPIR-V module for Vulkan 1.2
//! (SPIR-V 1.5, which the ray-tracing stages need) and copies it to `out-file`.
//! Run by `cargo xtask build-shaders`; not meant to be called by hand.

use std::path::PathBuf;
use std::process::ExitCode;

use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (crate_dir, out_file) = match (args.first(), args.get(1)) {
        (Some(c), Some(o)) => (PathBuf::from(c), PathBuf::from(o)),
        _ => {
            eprintln!("usage: raykit-shader-builder <crate-dir> <out-file.spv> [<target-dir>]");
            return ExitCode::from(2);
        }
    };
    let mut builder = SpirvBuilder::new(&crate_dir, "spirv-unknown-vulkan1.2")
        .spirv_metadata(SpirvMetadata::NameVariables)
        .capability(Capability::RayTracingKHR)
        .capability(Capability::Int64)
        .capability(Capability::RuntimeDescriptorArray)
        .extension("SPV_KHR_ray_tracing")
        .scalar_block_layout(true);
    // spirv-builder clears RUSTUP_TOOLCHAIN for the inner cargo, so name the
    // pinned nightly explicitly (the same one this program was built with).
    builder.toolchain_overwrite = Some(env!("RAYKIT_SHADER_TOOLCHAIN").to_owned());
    if let Some(target_dir) = args.get(2) {
        builder = builder.target_dir_path(PathBuf::from(target_dir));
    }
    let result = match builder.build() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: building {}: {e}", crate_dir.display());
            return ExitCode::FAILURE;
        }
    };
    let spv = match result.module {
        ModuleResult::SingleModule(path) => path,
        ModuleResult::MultiModule(_) => {
            eprintln!("error: expected one SPIR-V module");
            return ExitCode::FAILURE;
        }
    };
    if let Some(parent) = out_file.parent() {
        if let Err(e) = std::fs::create_dir_all(parent) {
            eprintln!("error: creating {}: {e}", parent.display());
            return ExitCode::FAILURE;
        }
    }
    if let Err(e) = std::fs::copy(&spv, &out_file) {
        eprintln!("error: copying {} to {}: {e}", spv.display(), out_file.display());
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
