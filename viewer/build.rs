//! Compiles the display pass (`device/`, `raykit-viewer-device`) to SPIR-V
//! (rust-gpu, through raykit-builder) for `raykit::include_spirv!`: the viewer
//! carries its display pass inside every program that uses it, wherever that
//! program is built or run.
fn main() {
    let device = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("device");
    if let Err(e) = raykit_builder::DeviceBuild::new(device).build_script() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
