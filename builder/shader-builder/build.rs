//! Records which toolchain this builder was compiled with, so the shader crates
//! are compiled by the same nightly (`RUSTUP_TOOLCHAIN` is set by rustup's proxy).
fn main() {
    let toolchain = std::env::var("RUSTUP_TOOLCHAIN").unwrap_or_else(|_| "nightly-2026-08-15".to_owned());
    // rustup may give the full name `nightly-2026-08-15-x86_64-unknown-linux-gnu`; both work with `+`.
    println!("cargo:rustc-env=RAYKIT_SHADER_TOOLCHAIN={toolchain}");
    println!("cargo:rerun-if-env-changed=RUSTUP_TOOLCHAIN");
}
