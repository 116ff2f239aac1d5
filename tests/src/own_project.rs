//! The examples that are projects of their own (`examples/first_renderer`,
//! `examples/next_week`), as their tests use them: copied out of the workspace,
//! built with plain `cargo build` as a user builds them, their lines of code
//! counted, run, the PFM and PNG they write read back, and their pictures
//! compared with a reference block by block.

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

/// Runs the project's `binary` in `dir` on `backend` (validation on), asking
/// for a `width × height` picture of `spp` samples per pixel, checks that it
/// succeeded and that its PNG is its PFM sRGB-encoded; returns the PFM's
/// radiance, top row first. `what` names the project in failures.
pub fn render(
    binary: &Path,
    dir: &Path,
    what: &str,
    backend: raykit::Backend,
    [width, height, spp]: [u32; 3],
) -> Vec<DVec3> {
    let name = backend_name(backend);
    let started = std::time::Instant::now();
    let output = Command::new(binary)
        .args([&format!("{name}.png"), &width.to_string(), &height.to_string(), &spp.to_string()])
        .current_dir(dir)
        .env("RAYKIT_BACKEND", name)
        .env("RAYKIT_VALIDATION", "1")
        .output()
        .unwrap_or_else(|e| panic!("running {what}: {e}"));
    assert!(output.status.success(), "{what} failed on {name}:\n{}", text(&output));
    eprintln!("{name}: rendered in {:.1} s: {}", started.elapsed().as_secs_f64(), text(&output).trim());
    let got = read_pfm(&dir.join(format!("{name}.pfm")), width, height);
    check_png(&dir.join(format!("{name}.png")), width, height, &got);
    got
}

/// `RAYKIT_BACKEND`'s name of `backend`.
pub fn backend_name(backend: raykit::Backend) -> &'static str {
    match backend {
        raykit::Backend::Vulkan => "vulkan",
        raykit::Backend::Cpu => "cpu",
    }
}

/// How many standard errors `got` is from `reference` per channel, where the
/// variance of their difference is `variance`; a floor of 1e-5 on the standard
/// error stands for f32 rounding where there is no noise (no light reaches).
pub fn standard_errors(got: DVec3, reference: DVec3, variance: DVec3) -> DVec3 {
    (got - reference).abs()
        / DVec3::new(variance.x.sqrt(), variance.y.sqrt(), variance.z.sqrt()).max(DVec3::splat(1e-5))
}

/// An 8×8 block of a picture compared with the reference.
pub struct Block {
    pub x: u32,
    pub y: u32,
    /// The block's mean radiance, and the reference's.
    pub mean: DVec3,
    pub reference: DVec3,
    /// [`standard_errors`] of the two means.
    pub z: DVec3,
}

/// The picture `got` (`width × height`, both multiples of 8) against the
/// reference's per-pixel means `want[p].0`, in 8×8 blocks, row by row;
/// `pixel_variance(p)` is the variance of pixel `p`'s difference.
pub fn blocks(
    got: &[DVec3],
    want: &[(DVec3, DVec3)],
    (width, height): (u32, u32),
    pixel_variance: impl Fn(usize) -> DVec3,
) -> Vec<Block> {
    let mut blocks = Vec::new();
    for (by, bx) in (0..height / 8).flat_map(|by| (0..width / 8).map(move |bx| (by, bx))) {
        let (mut mean, mut reference, mut variance) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        for p in (0..64).map(|k| ((by * 8 + k / 8) * width + bx * 8 + k % 8) as usize) {
            mean += got[p] / 64.0;
            reference += want[p].0 / 64.0;
            variance += pixel_variance(p) / (64.0 * 64.0);
        }
        blocks.push(Block { x: bx, y: by, mean, reference, z: standard_errors(mean, reference, variance) });
    }
    blocks
}

/// Over every block and channel: the worst standard errors, their root mean
/// square and their mean signed by the difference's sign; and the count.
pub fn block_summary(blocks: &[Block]) -> (f64, f64, f64, f64) {
    let (mut worst, mut squares, mut signed) = (0.0f64, 0.0, 0.0);
    for b in blocks {
        for c in 0..3 {
            let z = b.z[c];
            (worst, squares, signed) = (worst.max(z), squares + z * z, signed + z.copysign(b.mean[c] - b.reference[c]));
        }
    }
    let n = (blocks.len() * 3) as f64;
    (worst, (squares / n).sqrt(), signed / n, n)
}
