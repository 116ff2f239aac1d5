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
use std::time::Instant;

use raykit::glam::DVec3;
use raykit::Backend;
use raykit_tests::own_project::{
    backend_name, binary, block_summary, blocks, cargo_build, code_lines, copy_project, project_dir, render,
    standard_errors, text, SOURCES,
};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 96;
/// Samples per pixel of the project's render, and of the reference.
const DEVICE_SPP: u32 = 256;
const REFERENCE_SPP: u32 = 1024;

/// Runs the project's binary on `backend` and checks its pictures against the
/// reference (per pixel: the mean and the variance of one sample).
fn render_and_compare(binary: &Path, dir: &Path, backend: Backend, want: &[(DVec3, DVec3)]) {
    let name = backend_name(backend);
    let got = render(binary, dir, "the next_week example", backend, [WIDTH, HEIGHT, DEVICE_SPP]);
    assert!(got.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "{name}: a pixel is negative or not finite");

    // The variance of a pixel's mean: of the device's, then of the reference's.
    let pixel_variance = |p: usize| want[p].1 * (1.0 / DEVICE_SPP as f64 + 1.0 / REFERENCE_SPP as f64);
    let blocks = blocks(&got, want, (WIDTH, HEIGHT), pixel_variance);
    for b in &blocks {
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
    }
    let (worst, rms, signed, n) = block_summary(&blocks);
    let count = (WIDTH * HEIGHT) as f64;
    let mean: DVec3 = got.iter().sum::<DVec3>() / count;
    let reference: DVec3 = want.iter().map(|w| w.0).sum::<DVec3>() / count;
    let variance: DVec3 = (0..got.len()).map(pixel_variance).sum::<DVec3>() / (count * count);
    let whole = standard_errors(mean, reference, variance);
    eprintln!(
        "{name}: worst 8x8 block {worst:.2} standard errors from the reference (over {n} blocks and channels: \
         root mean square {rms:.2}, mean {signed:+.2}); the whole picture {:.2} / {:.2} / {:.2} (mean radiance {:.4}, \
         reference {:.4})",
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
