//! The book's first renderer (`examples/first_renderer`, shown in
//! `docs/book/src/first-renderer.md`), a project of its own as a user writes it: copied outside the workspace, built with plain
//! `cargo build`, run on the Vulkan driver (validation on) and on the CPU
//! backend, and its pictures compared with a path tracer written again here in
//! plain f64 Rust (its own scene description, camera, sphere test, random
//! numbers and materials): the mean linear radiance of every 8×8 block agrees
//! within 5 combined standard errors per channel. The standard errors come
//! from the reference's per-pixel spread of single samples, which a correct
//! renderer shares (radiance lies in [0, 1]: no heavy tails). The PNG is the
//! PFM's radiance, sRGB-encoded. The project is at most 150 lines of code, and
//! the chapter's code blocks of it are its code.

use std::path::Path;
use std::time::Instant;

use raykit::glam::DVec3;
use raykit::Backend;
use raykit_tests::own_project::{
    backend_name, binary, block_summary, blocks, cargo_build, code_lines, copy_project, project_dir, raykit_root,
    render, text, SOURCES,
};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;
/// Samples per pixel of the project's render, and of the reference.
const DEVICE_SPP: u32 = 128;
const REFERENCE_SPP: u32 = 512;
/// The project's `MAX_BOUNCES`: traces a path takes at most.
const MAX_BOUNCES: u32 = 16;

// --- The reference: the scene and the renderer written again in f64. ---

#[derive(Copy, Clone, PartialEq)]
enum Material {
    Lambertian,
    Metal { fuzz: f64 },
    Dielectric { ior: f64 },
}

/// A sphere: centre, radius, material, colour.
struct Sphere(DVec3, f64, Material, DVec3);

fn scene() -> Vec<Sphere> {
    let v = DVec3::new;
    let small = |x: f64, z: f64, m: Material, colour: DVec3| Sphere(v(x, 0.2, z), 0.2, m, colour);
    let (metal, glass) = (Material::Metal { fuzz: 0.05 }, Material::Dielectric { ior: 1.5 });
    vec![
        Sphere(v(0.0, -1000.0, 0.0), 1000.0, Material::Lambertian, DVec3::splat(0.5)),
        Sphere(v(-4.0, 1.0, 0.0), 1.0, Material::Lambertian, v(0.4, 0.2, 0.1)),
        small(-2.5, 1.8, Material::Lambertian, v(0.1, 0.6, 0.2)),
        small(1.5, 2.2, Material::Lambertian, v(0.8, 0.2, 0.3)),
        Sphere(v(4.0, 1.0, 0.0), 1.0, metal, v(0.7, 0.6, 0.5)),
        small(2.8, -1.6, metal, DVec3::splat(0.9)),
        Sphere(v(0.0, 1.0, 0.0), 1.0, glass, DVec3::ONE),
        small(-1.0, 2.4, glass, DVec3::ONE),
    ]
}

/// SplitMix64: the reference's own random numbers.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A point in the unit ball, by rejection.
    fn in_ball(&mut self) -> DVec3 {
        loop {
            let p = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            if p.length_squared() < 1.0 {
                return p;
            }
        }
    }
}

/// The nearest sphere hit past `1e-9`: distance and sphere.
fn hit(spheres: &[Sphere], o: DVec3, d: DVec3) -> Option<(f64, &Sphere)> {
    let mut best: Option<(f64, &Sphere)> = None;
    for s in spheres {
        let f = o - s.0;
        let (a, b, c) = (d.dot(d), f.dot(d), f.dot(f) - s.1 * s.1);
        let disc = b * b - a * c;
        if disc < 0.0 {
            continue;
        }
        for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
            if t > 1e-9 && best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, s));
                break;
            }
        }
    }
    best
}

/// One path's radiance.
fn radiance(spheres: &[Sphere], mut o: DVec3, mut d: DVec3, rng: &mut Rng) -> DVec3 {
    let mut throughput = DVec3::ONE;
    for _ in 0..MAX_BOUNCES {
        let Some((t, sphere)) = hit(spheres, o, d) else {
            let s = 0.5 * (d.normalize().y + 1.0);
            return throughput * ((1.0 - s) * DVec3::ONE + s * DVec3::new(0.5, 0.7, 1.0));
        };
        let unit = d.normalize();
        let p = o + t * d;
        let outward = (p - sphere.0) / sphere.1;
        let front = unit.dot(outward) < 0.0;
        let n = if front { outward } else { -outward };
        let mirror = unit - 2.0 * unit.dot(n) * n;
        d = match sphere.2 {
            // n + a uniform unit vector is cosine-distributed (the book's form).
            Material::Lambertian => (n + rng.in_ball().normalize()).normalize(),
            Material::Metal { fuzz } => {
                let s = (mirror + fuzz * rng.in_ball()).normalize();
                if s.dot(n) <= 0.0 {
                    return DVec3::ZERO;
                }
                s
            }
            Material::Dielectric { ior } => {
                let eta = if front { 1.0 / ior } else { ior };
                let cos = (-unit.dot(n)).min(1.0);
                let sin = (1.0 - cos * cos).sqrt();
                let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
                if eta * sin > 1.0 || rng.next() < r0 + (1.0 - r0) * (1.0 - cos).powi(5) {
                    mirror
                } else {
                    let perpendicular = eta * (unit + cos * n);
                    perpendicular - (1.0 - perpendicular.length_squared()).abs().sqrt() * n
                }
            }
        };
        throughput *= sphere.3;
        o = p;
    }
    DVec3::ZERO
}

/// Per pixel, top row first: the mean radiance of `REFERENCE_SPP` samples and
/// the variance of one sample, through the book's thin-lens camera from
/// (13, 2, 3) at the origin, 20° vertically, aperture 0.1, focused at 10.
fn reference() -> Vec<(DVec3, DVec3)> {
    let spheres = scene();
    let (eye, target, aperture, focus) = (DVec3::new(13.0, 2.0, 3.0), DVec3::ZERO, 0.1, 10.0);
    let half_height = (20f64.to_radians() / 2.0).tan();
    let half_width = half_height * WIDTH as f64 / HEIGHT as f64;
    let back = (eye - target).normalize();
    let right = DVec3::Y.cross(back).normalize();
    let up = back.cross(right);
    let mut rng = Rng(0x5eed);
    (0..WIDTH * HEIGHT)
        .map(|i| {
            let (x, y) = ((i % WIDTH) as f64, (i / WIDTH) as f64);
            let (mut sum, mut squares) = (DVec3::ZERO, DVec3::ZERO);
            for _ in 0..REFERENCE_SPP {
                // (s, t) from the top-left corner of the image.
                let s = (x + rng.next()) / WIDTH as f64;
                let t = (y + rng.next()) / HEIGHT as f64;
                let disk = loop {
                    let (a, b) = (2.0 * rng.next() - 1.0, 2.0 * rng.next() - 1.0);
                    if a * a + b * b < 1.0 {
                        break (a, b);
                    }
                };
                let origin = eye + aperture / 2.0 * (disk.0 * right + disk.1 * up);
                let on_focus_plane =
                    eye + focus * (-back + (2.0 * s - 1.0) * half_width * right + (1.0 - 2.0 * t) * half_height * up);
                let l = radiance(&spheres, origin, on_focus_plane - origin, &mut rng);
                (sum, squares) = (sum + l, squares + l * l);
            }
            let n = REFERENCE_SPP as f64;
            let mean = sum / n;
            (mean, ((squares - n * mean * mean) / (n - 1.0)).max(DVec3::ZERO))
        })
        .collect()
}

/// Runs the project's binary on `backend` and checks its pictures against the
/// reference (per pixel: the mean and the variance of one sample).
fn render_and_compare(binary: &Path, dir: &Path, backend: Backend, want: &[(DVec3, DVec3)]) {
    let name = backend_name(backend);
    let got = render(binary, dir, "the first renderer", backend, [WIDTH, HEIGHT, DEVICE_SPP]);

    // The variance of a pixel's mean: of the device's, then of the reference's.
    let pixel_variance = |p: usize| want[p].1 * (1.0 / DEVICE_SPP as f64 + 1.0 / REFERENCE_SPP as f64);
    let blocks = blocks(&got, want, (WIDTH, HEIGHT), pixel_variance);
    for b in &blocks {
        // Blocks of sky alone have almost no noise: f32 rounding is the floor.
        for c in 0..3 {
            assert!(
                b.z[c] < 5.0,
                "{name}: block ({}, {}) channel {c}: {} against the reference's {} ({:.1} standard errors)",
                b.x,
                b.y,
                b.mean[c],
                b.reference[c],
                b.z[c]
            );
        }
        // The scene is not black: the comparison has something to compare.
        assert!(b.reference.min_element() > 0.05, "block ({}, {}) of the reference is black", b.x, b.y);
    }
    let (worst, rms, signed, n) = block_summary(&blocks);
    eprintln!(
        "{name}: worst 8x8 block {worst:.2} standard errors from the reference (over {n} blocks and channels: \
         root mean square {rms:.2}, mean {signed:+.2})"
    );
}

#[test]
fn the_first_renderer_is_short() {
    let mut total = 0;
    for file in SOURCES {
        let source = std::fs::read_to_string(project_dir("first_renderer").join(file)).expect("reading the project");
        eprintln!("{file}: {} lines of code", code_lines(&source));
        total += code_lines(&source);
    }
    eprintln!("the first renderer: {total} lines of code");
    assert!(total <= 150, "the first renderer has {total} lines of code (neither blank nor comments), over 150");
}

#[test]
fn the_book_shows_the_first_renderers_code() {
    let chapter = raykit_root().join("docs/book/src/first-renderer.md");
    let section = std::fs::read_to_string(chapter).expect("reading the book's first-renderer chapter");
    // Each source as its lines without indentation (blocks in list items are indented).
    let sources: Vec<Vec<String>> = SOURCES
        .iter()
        .map(|f| std::fs::read_to_string(project_dir("first_renderer").join(f)).expect("reading the project"))
        .map(|s| s.lines().map(|l| l.trim().to_owned()).collect())
        .collect();
    let mut blocks = 0;
    for block in section.split("```rust").skip(1) {
        let code = block.split_once('\n').map(|(_, rest)| rest).unwrap_or("");
        let code: Vec<String> = code[..code.find("```").expect("a closed code block")]
            .lines()
            .map(|l| l.trim().to_owned())
            .filter(|l| !l.is_empty())
            .collect();
        let shown = |lines: &Vec<String>| {
            let lines: Vec<&String> = lines.iter().filter(|l| !l.is_empty()).collect();
            lines.windows(code.len()).any(|w| w.iter().zip(&code).all(|(a, b)| *a == b))
        };
        assert!(
            sources.iter().any(shown),
            "a block of the book's chapter is not the project's code:\n{}",
            code.join("\n")
        );
        blocks += 1;
    }
    assert!(blocks >= 3, "{blocks} code blocks in the section");
}

#[test]
fn the_first_renderer_builds_outside_the_workspace_and_matches_a_plain_rust_path_tracer() {
    let project = copy_project("first_renderer");
    let started = Instant::now();
    let output = cargo_build(&project);
    assert!(output.status.success(), "cargo build of the first renderer failed:\n{}", text(&output));
    eprintln!("the first renderer built in {:.1} s", started.elapsed().as_secs_f64());
    let binary = binary("first_renderer");

    let started = Instant::now();
    let want = reference();
    eprintln!("reference rendered in {:.1} s", started.elapsed().as_secs_f64());
    for backend in raykit_tests::test_backends().expect("RAYKIT_TEST_BACKENDS") {
        render_and_compare(&binary, &project, backend, &want);
    }
    let _ = std::fs::remove_dir_all(&project);
}
