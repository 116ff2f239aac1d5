//! The SPIR-V that `cargo xtask build-shaders` writes: where it lies, and the
//! check of one entry point's params in it.

use raykit_abi::{ParamsLayout, PARAMS_BINDING, PARAMS_SET};

use super::{bad, check, parse, reflect_params, ParamsDelivery, Result};

/// The 32-bit words of the SPIR-V file `path` that `cargo xtask build-shaders`
/// wrote, or an error saying how to build it.
pub(crate) fn read_built_words(path: &std::path::Path) -> Result<Vec<u32>> {
    let bytes = std::fs::read(path).map_err(|e| {
        bad(format!("reading {}: {e}; build the device crates with `cargo xtask build-shaders`", path.display()))
    })?;
    if bytes.len() % 4 != 0 {
        return Err(bad(format!("{} is not a whole number of 32-bit words", path.display())));
    }
    Ok(bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

/// Checks entry point `entry` of the SPIR-V file `path` against `host`: what
/// the tests generated for `#[params]` programs run after
/// `cargo xtask build-shaders`.
pub fn check_file(path: &std::path::Path, entry: &str, host: &ParamsLayout, push_constants: bool) -> Result<()> {
    let module = parse(&read_built_words(path)?)?;
    let blocks = reflect_params(&module)?;
    let Some(blocks) = blocks.get(entry) else {
        return Err(bad(format!("{} has no params block for entry point `{entry}`", path.display())));
    };
    let expected = if push_constants {
        ParamsDelivery::PushConstants
    } else {
        ParamsDelivery::UniformBuffer { set: PARAMS_SET, binding: PARAMS_BINDING }
    };
    check(host, entry, blocks, expected)
}

/// Where `cargo xtask build-shaders` put the SPIR-V of the device crate whose
/// manifest directory is `manifest_dir`: `$RAYKIT_SPIRV_DIR/<crate>.spv`, else
/// `target/spirv/<crate>.spv` in the nearest ancestor directory that has it.
pub fn built_spirv_path(manifest_dir: &str, crate_name: &str) -> std::path::PathBuf {
    let file = format!("{}.spv", crate_name.replace('-', "_"));
    if let Some(dir) = std::env::var_os("RAYKIT_SPIRV_DIR") {
        return std::path::PathBuf::from(dir).join(file);
    }
    let start = std::path::Path::new(manifest_dir);
    for dir in start.ancestors() {
        let candidate = dir.join("target").join("spirv").join(&file);
        if candidate.is_file() {
            return candidate;
        }
    }
    start.join("target").join("spirv").join(file)
}
