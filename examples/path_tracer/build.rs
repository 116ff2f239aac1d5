//! Compiles the WGSL twin (`wgsl/path_tracer.wgsl`) to SPIR-V at build time with
//! raykit-wgsl (naga and raykit's conventions); `Programs::wgsl` embeds it. A WGSL
//! error fails the build with naga's diagnostic.

fn main() {
    let source = "wgsl/path_tracer.wgsl";
    println!("cargo:rerun-if-changed={source}");
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    match raykit_wgsl::compile_file(source) {
        Ok(spirv) => std::fs::write(out.join("path_tracer.wgsl.spv"), spirv).expect("writing to OUT_DIR"),
        Err(e) => {
            eprintln!("{e}");
            panic!("compiling {source} failed (see above)");
        }
    }
}
