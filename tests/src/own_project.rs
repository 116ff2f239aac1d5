//! The examples that are projects of their own (`examples/first_renderer`,
//! `examples/next_week`), as their tests use them: copied out of the workspace,
//! built with plain `cargo build` as a user builds them, their lines of code
//! counted, and the PFM and PNG they write read back.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use raykit::glam::DVec3;

/// The project's Rust sources, relative to its directory.
pub const SOURCES: [&str; 3] = ["build.rs", "src/main.rs", "device/src/lib.rs"];

/// The raykit checkout the tests run in.
pub fn raykit_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the tests crate is inside the workspace").to_path_buf()
}

/// `examples/<name>`.
pub fn project_dir(name: &str) -> PathBuf {
    raykit_root().join("examples").join(name)
}

/// Lines of code: lines that are neither blank nor comments (`//`, `///`, `//!`).
pub fn code_lines(source: &str) -> usize {
    source.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("//")).count()
}

/// Copies project `name` to a fresh directory under the system's temporary
/// directory, its `path` dependencies pointed at this raykit checkout.
pub fn copy_project(name: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!("raykit-{}-{}-{nanos}", name.replace('_', "-"), std::process::id()));
    let root = raykit_root().display().to_string();
    for file in ["Cargo.toml", "device/Cargo.toml"].iter().chain(&SOURCES) {
        let text = std::fs::read_to_string(project_dir(name).join(file)).expect("reading the project");
        let up = if file.starts_with("device/") { "../../../" } else { "../../" };
        let moved = text.replace(&format!("path = \"{up}"), &format!("path = \"{root}/"));
        assert!(!file.ends_with(".toml") || moved != text, "{file} names no raykit crate by `{up}`");
        let to = dir.join(file);
        std::fs::create_dir_all(to.parent().expect("a file has a directory")).expect("creating the project");
        std::fs::write(to, moved).expect("writing the project");
    }
    dir
}

/// The target directory the projects share with the template test (raykit and
/// its dependencies compile once for all of them).
fn target_dir() -> PathBuf {
    raykit_root().join("target").join("template-project")
}

/// `cargo build` in `project`, as a user runs it, in the target directory the
/// projects share with the template test (raykit and its dependencies compile once).
pub fn cargo_build(project: &Path) -> Output {
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    for (key, _) in std::env::vars_os() {
        if key.to_str().is_some_and(|k| k.starts_with("CARGO") && k != "CARGO_HOME") {
            cmd.env_remove(key);
        }
    }
    cmd.arg("build").current_dir(project).env("CARGO_TARGET_DIR", target_dir());
    cmd.output().expect("running cargo build")
}

/// The debug binary [`cargo_build`] made of project `name`.
pub fn binary(name: &str) -> PathBuf {
    target_dir().join("debug").join(name)
}

/// A process's stdout and stderr.
pub fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

/// Reads a PFM of `width × height` (rows bottom to top, little-endian), top row first.
pub fn read_pfm(path: &Path, width: u32, height: u32) -> Vec<DVec3> {
    let bytes = std::fs::read(path).expect("the project writes a PFM");
    let header = format!("PF\n{width} {height}\n-1.0\n");
    assert!(bytes.starts_with(header.as_bytes()), "unexpected PFM header in {}", path.display());
    let floats: Vec<f64> =
        bytes[header.len()..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64).collect();
    assert_eq!(floats.len(), (width * height * 3) as usize);
    let w = width as usize;
    (0..(width * height) as usize)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let at = ((height as usize - 1 - y) * w + x) * 3;
            DVec3::new(floats[at], floats[at + 1], floats[at + 2])
        })
        .collect()
}

/// The sRGB encoding of a linear value, quantised to 8 bits.
fn srgb8(c: f64) -> i32 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as i32
}

/// The PNG of `width × height` holds `radiance` sRGB-encoded (within one step of rounding).
pub fn check_png(path: &Path, width: u32, height: u32, radiance: &[DVec3]) {
    let png = image::open(path).expect("the project writes a PNG").to_rgba8();
    assert_eq!(png.dimensions(), (width, height));
    for (i, (pixel, c)) in png.pixels().zip(radiance).enumerate() {
        for (channel, want) in [c.x, c.y, c.z].into_iter().enumerate() {
            let got = pixel.0[channel] as i32;
            assert!((got - srgb8(want)).abs() <= 1, "PNG pixel {i} channel {channel}: {got} for radiance {want}");
        }
        assert_eq!(pixel.0[3], 255);
    }
}
