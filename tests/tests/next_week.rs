//! *The Next Week*'s final scene (`examples/next_week`), a project of its own
//! as a user writes it: copied outside the workspace, built with plain
//! `cargo build`, run on the Vulkan driver (validation on) and on the CPU
//! backend, and its pictures compared with the same scene path-traced in plain
//! f64 Rust by `tests/next-week-reference` (its own scene description, camera,
//! box, quad and sphere tests, random numbers, materials and media): the mean
//! linear radiance of every 8×8 block, and of the whole picture, agrees within
//! 5 combined standard errors per channel. The standard errors come from the
//! reference's per-pixel spread of single samples (the light's radiance of 7
//! makes the tails long but bounded; a block holds 64 · 256 device samples).
//! The PNG is the PFM's radiance, sRGB-encoded. The project is at most 350
//! lines of code.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use raykit::glam::DVec3;
use raykit::Backend;
use raykit_tests::own_project::{
    binary, cargo_build, check_png, code_lines, copy_project, project_dir, read_pfm, text, SOURCES,
};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 96;
/// Samples per pixel of the project's render, and of the reference.
const DEVICE_SPP: u32 = 256;
const REFERENCE_SPP: u32 = 1024;

/// Runs the project's binary on `backend` and checks its pictures against the
/// reference (per pixel: the mean and the variance of one sample).
fn render_and_compare(binary: &Path, dir: &Path, backend: Backend, want: &[(DVec3, DVec3)]) {
    let name = match backend {
        Backend::Vulkan => "vulkan",
        Backend::Cpu => "cpu",
    };
    let started = Instant::now();
    let output = Command::new(binary)
        .args([&format!("{name}.png"), &WIDTH.to_string(), &HEIGHT.to_string(), &DEVICE_SPP.to_string()])
        .current_dir(dir)
        .env("RAYKIT_BACKEND", name)
        .env("RAYKIT_VALIDATION", "1")
        .output()
        .expect("running the next_week example");
    assert!(output.status.success(), "the next_week example failed on {name}:\n{}", text(&output));
    eprintln!("{name}: rendered in {:.1} s: {}", started.elapsed().as_secs_f64(), text(&output).trim());
    let got = read_pfm(&dir.join(format!("{name}.pfm")), WIDTH, HEIGHT);
    check_png(&dir.join(format!("{name}.png")), WIDTH, HEIGHT, &got);
    assert!(got.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "{name}: a pixel is negative or not finite");

    // The variance of a pixel's mean: of the device's, then of the reference's.
    let pixel_variance = |p: usize| want[p].1 * (1.0 / DEVICE_SPP as f64 + 1.0 / REFERENCE_SPP as f64);
    let z = |got: DVec3, reference: DVec3, variance: DVec3| {
        // A block no light reaches has no noise: f32 rounding is the floor.
        (got - reference).abs()
            / DVec3::new(variance.x.sqrt(), variance.y.sqrt(), variance.z.sqrt()).max(DVec3::splat(1e-5))
    };
    let (mut worst, mut squares, mut signed) = (0.0f64, 0.0, 0.0);
    for (by, bx) in (0..HEIGHT / 8).flat_map(|by| (0..WIDTH / 8).map(move |bx| (by, bx))) {
        let (mut mean, mut reference, mut variance) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        for p in (0..64).map(|k| ((by * 8 + k / 8) * WIDTH + bx * 8 + k % 8) as usize) {
            mean += got[p] / 64.0;
            reference += want[p].0 / 64.0;
            variance += pixel_variance(p) / (64.0 * 64.0);
        }
        let block = z(mean, reference, variance);
        for c in 0..3 {
            (worst, squares, signed) = (
                worst.max(block[c]),
                squares + block[c] * block[c],
                signed + block[c].copysign(mean[c] - reference[c]),
            );
            assert!(
                block[c] < 5.0,
                "{name}: block ({bx}, {by}) channel {c}: {} against the reference's {} ({:.1} standard errors)",
                mean[c],
                reference[c],
                block[c]
            );
        }
    }
    let n = (WIDTH / 8 * HEIGHT / 8 * 3) as f64;
    let count = (WIDTH * HEIGHT) as f64;
    let mean: DVec3 = got.iter().sum::<DVec3>() / count;
    let reference: DVec3 = want.iter().map(|w| w.0).sum::<DVec3>() / count;
    let variance: DVec3 = (0..got.len()).map(pixel_variance).sum::<DVec3>() / (count * count);
    let whole = z(mean, reference, variance);
    eprintln!(
        "{name}: worst 8x8 block {worst:.2} standard errors from the reference (over {n} blocks and channels: \
         root mean square {:.2}, mean {:+.2}); the whole picture {:.2} / {:.2} / {:.2} (mean radiance {:.4}, \
         reference {:.4})",
        (squares / n).sqrt(),
        signed / n,
        whole.x,
        whole.y,
        whole.z,
        mean.element_sum() / 3.0,
        reference.element_sum() / 3.0,
    );
    assert!(whole.max_element() < 5.0, "{name}: the whole picture is {whole} standard errors from the reference");
}

#[test]
fn the_next_week_example_is_short() {
    let mut total = 0;
    for file in SOURCES {
        let source = std::fs::read_to_string(project_dir("next_week").join(file)).expect("reading the project");
        eprintln!("{file}: {} lines of code", code_lines(&source));
        total += code_lines(&source);
    }
    eprintln!("the next_week example: {total} lines of code");
    assert!(total <= 350, "the next_week example has {total} lines of code (neither blank nor comments), over 350");
}

#[test]
fn the_next_week_example_builds_outside_the_workspace_and_matches_a_plain_rust_path_tracer() {
    let project = copy_project("next_week");
    let started = Instant::now();
    let output = cargo_build(&project);
    assert!(output.status.success(), "cargo build of the next_week example failed:\n{}", text(&output));
    eprintln!("the next_week example built in {:.1} s", started.elapsed().as_secs_f64());
    let binary = binary("next_week");

    let started = Instant::now();
    let want = next_week_reference::render(WIDTH, HEIGHT, REFERENCE_SPP, 2);
    assert_eq!(want.len(), (WIDTH * HEIGHT) as usize, "the reference's picture");
    eprintln!("reference rendered in {:.1} s", started.elapsed().as_secs_f64());
    // The scene is lit: the comparison has something to compare.
    let lit = want.iter().filter(|w| w.0.min_element() > 0.01).count();
    assert!(lit > want.len() / 2, "only {lit} pixels of the reference are lit");
    for backend in raykit_tests::test_backends().expect("RAYKIT_TEST_BACKENDS") {
        render_and_compare(&binary, &project, backend, &want);
    }
    let _ = std::fs::remove_dir_all(&project);
}
