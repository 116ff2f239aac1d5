//! What the calling crate's `Cargo.toml` says about it.

/// Whether the crate being compiled is a device crate
/// (`[package.metadata.raykit] device = true`), which `cargo xtask build-shaders`
/// compiles to SPIR-V and whose layout tests it runs.
pub fn is_device_crate() -> bool {
    let Some(dir) = std::env::var_os("CARGO_MANIFEST_DIR") else { return false };
    let Ok(text) = std::fs::read_to_string(std::path::Path::new(&dir).join("Cargo.toml")) else { return false };
    let Ok(manifest) = text.parse::<toml_edit::DocumentMut>() else { return false };
    manifest
        .get("package")
        .and_then(|p| p.get("metadata"))
        .and_then(|m| m.get("raykit"))
        .and_then(|r| r.get("device"))
        .and_then(|d| d.as_bool())
        .unwrap_or(false)
}
