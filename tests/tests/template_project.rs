//! The new-project template, used as a user would: written outside the
//! workspace, built with plain `cargo build` (its build.rs compiles its device
//! crate through raykit-builder, sharing the per-user codegen cache), run on the
//! Vulkan driver with validation on, its picture checked against a CPU reference; then its binary
//! alone, copied into an empty directory, still runs; built with its `viewer`
//! feature, `--headless` writes the viewer's antialiased picture, checked against
//! a CPU reference on Vulkan and on the CPU backend, the window (under Xvfb) shows
//! the same bytes, and without the feature `--view` says how to get it; a params struct that disagrees with its device
//! crate fails `cargo build` with raykit's layout message; and an error in the
//! device crate is printed once. The package is named after the project's directory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

use raykit::glam::Vec3;
use raykit_scene::Camera;
use raykit_viewer_device::{display_pixel, layout};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;
/// The template's colours (`my-app-device`'s `HIT_COLOR` and `BACKGROUND`), as RGB bytes.
const HIT: [u8; 3] = [0xff, 0xc0, 0x30];
const BACKGROUND: [u8; 3] = [0x10, 0x20, 0x40];
/// The template's `CAMERA`.
const CAMERA: Camera =
    Camera { eye: Vec3::new(0.0, 0.0, 2.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 53.130_104 };
/// Frames (one sample per pixel each) of the `--headless` render.
const FRAMES: u32 = 8;

fn raykit_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the tests crate is inside the workspace").to_path_buf()
}

/// A fresh directory under the system's temporary directory (outside the workspace).
fn temp_dir(what: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!("raykit-{what}-{}-{nanos}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("creating a temporary directory");
    dir
}

/// `cargo build` in `project` with `args`, as a user runs it, with a target
/// directory kept across runs (raykit and its dependencies compile once).
fn cargo_build_with(project: &Path, args: &[&str]) -> Output {
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    for (key, _) in std::env::vars_os() {
        if key.to_str().is_some_and(|k| k.starts_with("CARGO") && k != "CARGO_HOME") {
            cmd.env_remove(key);
        }
    }
    cmd.arg("build")
        .args(args)
        .current_dir(project)
        .env("CARGO_TARGET_DIR", raykit_root().join("target").join("template-project"));
    cmd.output().expect("running cargo build")
}

fn cargo_build(project: &Path) -> Output {
    cargo_build_with(project, &[])
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

/// Reads the template's binary P6 PPM.
fn read_ppm(path: &Path) -> Vec<[u8; 3]> {
    let bytes = std::fs::read(path).expect("the app writes its picture");
    let header = format!("P6\n{WIDTH} {HEIGHT}\n255\n");
    assert!(bytes.starts_with(header.as_bytes()), "unexpected PPM header in {}", path.display());
    let body = &bytes[header.len()..];
    assert_eq!(body.len(), (WIDTH * HEIGHT * 3) as usize);
    body.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Signed distance-like margin of point `p` inside the template's triangle
/// (positive inside), in the camera's [-1, 1]² view.
fn inside_margin(p: (f32, f32)) -> f32 {
    let tri = [(-0.5f32, -0.5f32), (0.5, -0.5), (0.0, 0.5)];
    let mut margin = f32::INFINITY;
    for i in 0..3 {
        let (a, b) = (tri[i], tri[(i + 1) % 3]);
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let len = (ex * ex + ey * ey).sqrt();
        // Counter-clockwise triangle: inside is to the left of each edge.
        margin = margin.min((ex * (p.1 - a.1) - ey * (p.0 - a.0)) / len);
    }
    margin
}

/// Where the camera's ray through `(sx, sy)` of pixel `(x, y)` (offsets in
/// [0, 1]) meets the triangle's plane z = 0.
fn on_plane(x: u32, y: u32, sx: f32, sy: f32) -> (f32, f32) {
    let (u, v, w) = CAMERA.uvw(WIDTH as f32 / HEIGHT as f32);
    let p = ((x as f32 + sx) / WIDTH as f32 * 2.0 - 1.0, 1.0 - (y as f32 + sy) / HEIGHT as f32 * 2.0);
    let direction = p.0 * u + p.1 * v + w;
    let at = CAMERA.eye - CAMERA.eye.z / direction.z * direction;
    (at.x, at.y)
}

/// Checks the picture against the CPU reference: every pixel whose centre is
/// clearly inside the triangle has the hit colour, every pixel clearly outside
/// the background; pixels within 1e-3 of an edge may be either.
fn check_picture(pixels: &[[u8; 3]]) {
    let (mut hits, mut misses) = (0, 0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let got = pixels[(y * WIDTH + x) as usize];
            let margin = inside_margin(on_plane(x, y, 0.5, 0.5));
            if margin > 1e-3 {
                assert_eq!(got, HIT, "pixel ({x}, {y}) sees the triangle");
                hits += 1;
            } else if margin < -1e-3 {
                assert_eq!(got, BACKGROUND, "pixel ({x}, {y}) sees nothing");
                misses += 1;
            } else {
                assert!(got == HIT || got == BACKGROUND, "pixel ({x}, {y}) on an edge is {got:?}");
            }
        }
    }
    // The triangle covers 1/8 of the view's height squared: 3/32 of its pixels.
    assert!(hits > 250 && misses > 2600, "{hits} hit pixels, {misses} background pixels");
}

/// The viewer's displayed colour (its display pass's own function) of `FRAMES`
/// samples of `rgb`, summed as the device program sums them.
fn displayed(rgb: [u8; 3]) -> [u8; 3] {
    let colour = Vec3::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32) / 255.0;
    let mut sum = Vec3::ZERO;
    for _ in 0..FRAMES {
        sum += colour;
    }
    let p = display_pixel(sum, FRAMES, 1.0, layout::RGBA, 255);
    [p as u8, (p >> 8) as u8, (p >> 16) as u8]
}

/// Checks the viewer's `--headless` picture of `FRAMES` jittered samples per pixel
/// against the CPU reference: a pixel whose square lies inside the triangle
/// (seen on the plane) has the hit colour's displayed value, one outside it the
/// background's, each within `tolerance` levels; a pixel across an edge lies
/// between the two, channel by channel, and some are strictly between
/// (antialiasing). Returns the indices of the pixels across an edge.
fn check_viewer_picture(what: &str, png: &Path, tolerance: u8) -> Vec<usize> {
    let image = image::open(png).unwrap_or_else(|e| panic!("{what}: reading {}: {e}", png.display())).to_rgb8();
    assert_eq!(image.dimensions(), (WIDTH, HEIGHT), "{what}");
    let (hit, background) = (displayed(HIT), displayed(BACKGROUND));
    let near = |got: [u8; 3], want: [u8; 3]| got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= tolerance);
    // The view's plane z = 0 is parallel to the image plane: a pixel is a square
    // of side `side` there, inside a circle of radius `reach` around its centre.
    let (_, v, _) = CAMERA.uvw(WIDTH as f32 / HEIGHT as f32);
    let side = 2.0 * v.length() / HEIGHT as f32;
    let reach = side * std::f32::consts::FRAC_1_SQRT_2 + 1e-3;
    let (mut inside, mut outside, mut blended, mut edges) = (0, 0, 0, Vec::new());
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let got = image.get_pixel(x, y).0;
            // The triangle is convex: its least signed distance to an edge line
            // beyond `reach` puts the whole circle on one side.
            let margin = inside_margin(on_plane(x, y, 0.5, 0.5));
            if margin > reach {
                assert!(near(got, hit), "{what}: pixel ({x}, {y}) inside the triangle is {got:?}, not {hit:?}");
                inside += 1;
            } else if margin < -reach {
                assert!(near(got, background), "{what}: pixel ({x}, {y}) outside is {got:?}, not {background:?}");
                outside += 1;
            } else {
                for c in 0..3 {
                    let (lo, hi) = (hit[c].min(background[c]), hit[c].max(background[c]));
                    assert!(
                        got[c].saturating_add(tolerance) >= lo && got[c] <= hi.saturating_add(tolerance),
                        "{what}: pixel ({x}, {y}) across an edge is {got:?}, not between {background:?} and {hit:?}"
                    );
                }
                blended += usize::from(got != hit && got != background);
                edges.push((y * WIDTH + x) as usize);
            }
        }
    }
    assert!(inside > 180 && outside > 2500, "{what}: {inside} pixels inside, {outside} outside");
    assert!(blended > 20, "{what}: only {blended} of {} edge pixels are blends: no antialiasing", edges.len());
    edges
}

/// Whether a display is there for the window; without one, fails when
/// `RAYKIT_REQUIRE_DISPLAY=1` (as `cargo xtask test` sets, with Xvfb started) and
/// says it skips otherwise.
fn display() -> bool {
    if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
        return true;
    }
    assert_ne!(
        std::env::var("RAYKIT_REQUIRE_DISPLAY").as_deref(),
        Ok("1"),
        "no DISPLAY, and RAYKIT_REQUIRE_DISPLAY=1: run `cargo xtask test` (it starts Xvfb) or set DISPLAY"
    );
    eprintln!("the template's window: SKIPPED: no DISPLAY (`cargo xtask test` starts Xvfb)");
    false
}

/// Runs the viewer-built app `--view` on `backend` (validation on) for `FRAMES`
/// frames of one sample, then a screenshot: the window's picture, as PNG bytes.
fn run_window(binary: &Path, cwd: &Path, backend: &str) -> Vec<u8> {
    let png = cwd.join(format!("window-{backend}.png"));
    let script = cwd.join("window.txt");
    std::fs::write(&script, format!("frames {FRAMES}\nscreenshot {}\nclose\n", png.display()))
        .expect("writing the script");
    let output = Command::new(binary)
        .args(["--view", "--spp-per-frame", "1", "--width", &WIDTH.to_string(), "--height", &HEIGHT.to_string()])
        .arg("--script")
        .arg(&script)
        .current_dir(cwd)
        .env("RAYKIT_VALIDATION", "1")
        .env("RAYKIT_BACKEND", backend)
        .output()
        .expect("running the app");
    let log = text(&output);
    assert!(output.status.success(), "--view on {backend} failed:\n{log}");
    assert!(log.contains(&format!("({WIDTH}x{HEIGHT}, {FRAMES} spp, camera ")), "{log}");
    assert!(!log.contains("validation:"), "{log}");
    image::open(&png).expect("decoding the window's picture").to_rgb8().into_raw()
}

/// Runs the viewer-built app `--headless` on `backend` (validation on) and checks its picture.
fn run_headless(binary: &Path, cwd: &Path, backend: &str, tolerance: u8) -> (Vec<u8>, Vec<usize>) {
    let png = cwd.join(format!("headless-{backend}.png"));
    let frames = FRAMES.to_string();
    let output = Command::new(binary)
        .args(["--headless", "--frames", &frames, "--width", &WIDTH.to_string(), "--height", &HEIGHT.to_string()])
        .arg("-o")
        .arg(&png)
        .current_dir(cwd)
        .env("RAYKIT_VALIDATION", "1")
        .env("RAYKIT_BACKEND", backend)
        .output()
        .expect("running the app");
    let log = text(&output);
    assert!(output.status.success(), "--headless on {backend} failed:\n{log}");
    assert!(log.contains(&format!("viewer: {FRAMES} frames at {WIDTH}x{HEIGHT} (headless)")), "{log}");
    assert!(log.contains(&format!("({WIDTH}x{HEIGHT}, {FRAMES} spp, camera 0,0,2,0,0,0,0,1,0,")), "{log}");
    assert!(!log.contains("validation:"), "{log}");
    let edges = check_viewer_picture(backend, &png, tolerance);
    (image::open(&png).expect("decoding the picture").to_rgb8().into_raw(), edges)
}

/// Levels a denoised pixel away from the triangle's edges may differ from the
/// noisy one (OIDN's filter moves flat colour at the image's corners a little).
const DENOISE_TOLERANCE: u8 = 16;

/// Runs the viewer-built app `--headless --denoise` on the CPU backend: the picture's RGB bytes.
fn run_headless_denoised(binary: &Path, cwd: &Path) -> Vec<u8> {
    let png = cwd.join("headless-denoised.png");
    let (frames, width, height) = (FRAMES.to_string(), WIDTH.to_string(), HEIGHT.to_string());
    let output = Command::new(binary)
        .args(["--headless", "--frames", &frames, "--width", &width, "--height", &height])
        .args(["--denoise", "--denoise-device", "cpu", "-o"])
        .arg(&png)
        .current_dir(cwd)
        .env("RAYKIT_VALIDATION", "1")
        .env("RAYKIT_BACKEND", "cpu")
        .output()
        .expect("running the app");
    let log = text(&output);
    assert!(output.status.success(), "--headless --denoise failed:\n{log}");
    assert!(log.contains("no guides (the renderer writes none)"), "{log}");
    assert!(log.contains(&format!("({WIDTH}x{HEIGHT}, {FRAMES} spp, denoised, camera ")), "{log}");
    image::open(&png).expect("decoding the denoised picture").to_rgb8().into_raw()
}

fn run_app(binary: &Path, cwd: &Path) -> Vec<[u8; 3]> {
    // With the validation layer on: the app fails on any message.
    let output = Command::new(binary)
        .arg("picture.ppm")
        .current_dir(cwd)
        .env("RAYKIT_VALIDATION", "1")
        .output()
        .expect("running the app");
    assert!(output.status.success(), "{} failed:\n{}", binary.display(), text(&output));
    read_ppm(&cwd.join("picture.ppm"))
}

#[test]
fn template_project_builds_runs_alone_and_rejects_a_params_mismatch() {
    let project = temp_dir("template");
    raykit_builder::write_new_project(&project, &raykit_root()).expect("writing the template");
    // The package is named after the directory: `raykit-template-<pid>-<nanos>`.
    let name = raykit_builder::project_name(&project).expect("the directory names the package");
    assert!(name.starts_with("raykit-template-"), "{name}");
    let manifest = std::fs::read_to_string(project.join("Cargo.toml")).expect("reading the manifest");
    assert!(manifest.contains(&format!("name = \"{name}\"")), "{manifest}");
    assert!(manifest.contains(&format!("{name}-device = {{ path = \"device\" }}")), "{manifest}");

    // 1. Plain `cargo build`: build.rs compiles the device crate to SPIR-V.
    let started = Instant::now();
    let output = cargo_build(&project);
    assert!(output.status.success(), "cargo build of the template failed:\n{}", text(&output));
    eprintln!("template project built in {:.1} s", started.elapsed().as_secs_f64());
    let binary = raykit_root().join("target").join("template-project").join("debug").join(&name);
    let pixels = run_app(&binary, &project);
    check_picture(&pixels);

    // 2. The binary alone in an empty directory: the SPIR-V is inside it.
    let alone = temp_dir("template-binary");
    let copy = alone.join(&name);
    std::fs::copy(&binary, &copy).expect("copying the binary");
    assert_eq!(std::fs::read_dir(&alone).map(|d| d.count()).unwrap_or(0), 1, "only the binary is there");
    assert_eq!(run_app(&copy, &alone), pixels, "the copied binary renders the same picture");

    // 3. Without the `viewer` feature, `--view` names it.
    let output = Command::new(&binary).arg("--view").current_dir(&project).output().expect("running the app");
    assert!(!output.status.success(), "--view without the viewer succeeded:\n{}", text(&output));
    assert!(text(&output).contains("--features viewer -- --view"), "{}", text(&output));

    // 4. With it, `--headless` writes the viewer's picture on both backends: the
    //    CPU backend runs the same Rust functions as the reference (exact); Vulkan
    //    may round the device program's division by 255 differently (one level).
    let started = Instant::now();
    let output = cargo_build_with(&project, &["--features", "viewer"]);
    assert!(output.status.success(), "cargo build --features viewer failed:\n{}", text(&output));
    eprintln!("template project with the viewer built in {:.1} s", started.elapsed().as_secs_f64());
    let (on_cpu, edges) = run_headless(&binary, &project, "cpu", 0);
    let (on_vulkan, _) = run_headless(&binary, &project, "vulkan", 1);
    // Across the backends only edge pixels may differ (a sample on an edge may hit on one and miss on the other).
    let differing: Vec<usize> =
        (0..on_cpu.len() / 3).filter(|&i| on_cpu[3 * i..3 * i + 3] != on_vulkan[3 * i..3 * i + 3]).collect();
    let inner = differing.iter().filter(|i| !edges.contains(i)).count();
    assert!(inner == 0, "{inner} pixels off the edges differ between the backends (of {} differing)", differing.len());
    eprintln!("--headless: {} of {} edge pixels differ between the backends", differing.len(), edges.len());
    // `--denoise` (Open Image Denoise on its CPU device; the template writes no
    // guides): the flat colours more than two pixels from the triangle's edges
    // come through, all but 1 in 50 within one level.
    let denoised = run_headless_denoised(&binary, &project);
    let near_edge = |i: usize| {
        let (x, y) = ((i as u32 % WIDTH) as i64, (i as u32 / WIDTH) as i64);
        edges.iter().any(|&e| {
            let (ex, ey) = ((e as u32 % WIDTH) as i64, (e as u32 / WIDTH) as i64);
            (ex - x).abs() <= 2 && (ey - y).abs() <= 2
        })
    };
    let off_edges: Vec<u8> = (0..on_cpu.len() / 3)
        .filter(|&i| !near_edge(i))
        .map(|i| (0..3).map(|c| on_cpu[3 * i + c].abs_diff(denoised[3 * i + c])).max().unwrap_or(0))
        .collect();
    let worst = off_edges.iter().copied().max().unwrap_or(0);
    let moved = off_edges.iter().filter(|&&d| d > 1).count();
    eprintln!(
        "--headless --denoise: of {} pixels away from the edges, {moved} moved by more than 1 level, at most {worst}",
        off_edges.len()
    );
    // Measured: 20 of 2568 by more than 1 level (at the image's corners and
    // beside the edges' reach), at most 11.
    assert!(moved * 50 <= off_edges.len(), "denoising moved {moved} flat pixels by more than one level");
    assert!(worst <= DENOISE_TOLERANCE, "denoising moved a flat pixel by {worst} levels");
    // The window (under Xvfb) shows what `--headless` writes, bit for bit, on both backends.
    if display() {
        assert!(
            run_window(&binary, &project, "cpu") == on_cpu,
            "the window on the CPU backend differs from --headless"
        );
        assert!(run_window(&binary, &project, "vulkan") == on_vulkan, "the window on Vulkan differs from --headless");
    }

    // 5. A params struct the device lays out differently: `cargo build` fails
    //    with raykit's layout message.
    let lib = project.join("device").join("src").join("lib.rs");
    let source = std::fs::read_to_string(&lib).expect("reading the device crate");
    let mismatched = source.replacen(
        "    /// The scene.\n",
        "    /// Only on the device: moves `scene` by 16 bytes there.\n    #[cfg(target_arch = \"spirv\")]\n    pub extra: [u32; 4],\n    /// The scene.\n",
        1,
    );
    assert_ne!(mismatched, source, "the template's Params has a `/// The scene.` field");
    std::fs::write(&lib, mismatched).expect("editing the device crate");
    let output = cargo_build(&project);
    let log = text(&output);
    assert!(!output.status.success(), "cargo build accepted a params mismatch:\n{log}");
    assert!(
        log.contains("launch params `Params` do not match the SPIR-V of `__raygen__rg`"),
        "cargo build failed without raykit's layout message:\n{log}"
    );
    assert_eq!(log.matches("do not match the SPIR-V of `__raygen__rg`").count(), 1, "printed more than once:\n{log}");

    // 6. A type error in the device crate: `cargo build` fails, and rustc's
    //    message is printed once.
    std::fs::write(&lib, source.replacen("pub struct Radiance;", "pub struct Radiance;\nconst WRONG: u32 = 1.5;", 1))
        .expect("editing the device crate");
    let output = cargo_build(&project);
    let log = text(&output);
    assert!(!output.status.success(), "cargo build accepted a type error:\n{log}");
    assert_eq!(log.matches("error[E0308]").count(), 1, "the error is not printed exactly once:\n{log}");

    let _ = std::fs::remove_dir_all(&project);
    let _ = std::fs::remove_dir_all(&alone);
}
