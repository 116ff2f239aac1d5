//! Compiles the device crate to SPIR-V (rust-gpu, through raykit-builder) and
//! hands its path to `raykit::include_spirv!`.
fn main() {
    let device = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("device");
    if let Err(e) = raykit_builder::DeviceBuild::new(device).build_script() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
