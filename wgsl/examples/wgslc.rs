//! Compiles a `.wgsl` file to raykit-ready SPIR-V: `wgslc IN.wgsl OUT.spv`.
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, input, output] = args.as_slice() else {
        eprintln!("usage: wgslc IN.wgsl OUT.spv");
        std::process::exit(2);
    };
    match raykit_wgsl::compile_file(input) {
        Ok(bytes) => {
            if let Err(e) = std::fs::write(output, bytes) {
                eprintln!("writing {output}: {e}");
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
