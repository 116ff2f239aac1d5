//! Denoising the Cornell box: at a few paths per pixel, OIDN guided by the
//! renderer's first-hit albedo and normals (written in the same launch) comes
//! at least 5× closer, in mean squared error over the displayed picture, to a
//! converged render of the same renderer than the noisy input, on both
//! backends. Writing the guides leaves the picture as it was.
//!
//! The error is measured on the picture as displayed (the PNG's tonemap,
//! unquantised); the linear radiance's error is printed too. That one is
//! dominated by the few pixels on the light's edge (radiance 15 beside 0.5),
//! whose error at 8 spp is the light's coverage of the pixel: antialiasing,
//! which the guides share and a denoiser keeps.
//!
//! The tests need Open Image Denoise (`cargo xtask setup --denoise`; `cargo
//! xtask test` installs it): without it they fail, naming that command.

use path_tracer::{Image, Programs, Renderer, Scene};
use raykit::{Backend, Context, ContextOptions};
use raykit_denoise::{DenoiseDevice, Denoiser};

const SIZE: u32 = 64;
/// Paths per pixel of the noisy render.
const NOISY_SPP: u32 = 8;
/// Paths per pixel of the converged reference, in launches of `REFERENCE_CHUNK`.
const REFERENCE_SPP: u32 = 1024;
const REFERENCE_CHUNK: u32 = 64;

/// A context of `backend` with the validation layer as `RAYKIT_VALIDATION` says
/// (`cargo xtask test` turns it on) and no disk compile cache.
fn context(backend: Backend) -> anyhow::Result<Option<Context>> {
    let options = ContextOptions {
        backend: Some(backend),
        validation: Some(std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1")),
        pipeline_cache: raykit::PipelineCacheLocation::Off,
        ..Default::default()
    };
    match Context::new(options) {
        Ok(ctx) => Ok(Some(ctx)),
        Err(e) if backend == Backend::Vulkan && std::env::var("RAYKIT_REQUIRE_DEVICE").as_deref() != Ok("1") => {
            eprintln!("SKIPPED: no Vulkan device with ray tracing ({e})");
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// Mean squared error over the image's pixels and channels, of `map`ped values.
fn mse_of(a: &Image, b: &Image, map: impl Fn(f32) -> f64) -> f64 {
    let sum: f64 = a
        .radiance
        .iter()
        .zip(&b.radiance)
        .flat_map(|(p, q)| p.to_array().into_iter().zip(q.to_array()))
        .map(|(p, q)| (map(p) - map(q)).powi(2))
        .sum();
    sum / (a.radiance.len() * 3) as f64
}

/// Mean squared error of linear radiance.
fn mse(a: &Image, b: &Image) -> f64 {
    mse_of(a, b, f64::from)
}

/// Mean squared error of the picture as the PNG shows it (Reinhard on each
/// channel, then sRGB's transfer curve; values in 0..1), unquantised.
fn display_mse(a: &Image, b: &Image) -> f64 {
    mse_of(a, b, |v| {
        let v = f64::from(v.max(0.0));
        let r = v / (1.0 + v);
        if r <= 0.003_130_8 {
            12.92 * r
        } else {
            1.055 * r.powf(1.0 / 2.4) - 0.055
        }
    })
}

/// Fails on any validation message `ctx` logged.
fn no_validation_messages(ctx: &Context, what: &str) {
    let messages = ctx.messages().take();
    assert!(messages.is_empty(), "{what}: {} validation message(s): {messages:?}", messages.len());
}

fn denoises_the_cornell_box(ctx: &Context, what: &str) -> anyhow::Result<()> {
    let denoiser = Denoiser::new(DenoiseDevice::Cpu)?;
    let programs = Programs::rust(ctx)?;
    let scene = Scene::new(ctx)?;

    // The converged reference, and an estimate of its own noise from its two halves.
    let mut reference = Renderer::new(ctx, &programs, &scene, SIZE, SIZE)?;
    let mut first_half = None;
    while reference.samples_done() < REFERENCE_SPP {
        reference.launch(REFERENCE_CHUNK)?;
        if reference.samples_done() == REFERENCE_SPP / 2 {
            first_half = Some(reference.image()?);
        }
    }
    let truth = reference.image()?;
    let first_half = first_half.expect("the reference passes its half-way point");
    let second_half = Image {
        radiance: truth.radiance.iter().zip(&first_half.radiance).map(|(t, a)| *t * 2.0 - *a).collect(),
        ..truth.clone()
    };
    // Each half's error is twice the whole's (in variance): the whole's is a quarter of their MSE.
    let reference_noise = display_mse(&first_half, &second_half) / 4.0;

    let mut noisy = Renderer::new(ctx, &programs, &scene, SIZE, SIZE)?;
    noisy.enable_guides(ctx, &programs)?;
    noisy.launch(NOISY_SPP)?;
    let image = noisy.image()?;
    let guides = noisy.guides()?.expect("guides were enabled");
    for (name, guide) in [("albedo", &guides.albedo), ("normal", &guides.normal)] {
        assert!(guide.iter().all(|v| v.is_finite()), "{what}: a non-finite {name} guide");
    }
    let in_unit = |v: &raykit::glam::Vec3| v.min_element() >= 0.0 && v.max_element() <= 1.0 + 1e-5;
    assert!(guides.albedo.iter().all(in_unit), "{what}: an albedo outside 0..=1");
    assert!(guides.normal.iter().all(|n| n.length() <= 1.0 + 1e-4), "{what}: a normal guide longer than 1");
    // The image's centre is on a face of the tall white (0.8) block, facing the camera.
    let centre = (SIZE / 2 * SIZE + SIZE / 2) as usize;
    let (albedo, normal) = (guides.albedo[centre], guides.normal[centre]);
    assert!((albedo - raykit::glam::Vec3::splat(0.8)).length() < 1e-3, "{what}: centre albedo {albedo}");
    let forward = path_tracer::camera_frame(1.0).w.normalize();
    assert!(normal.dot(forward) < -0.9 && (normal.length() - 1.0).abs() < 1e-3, "{what}: centre normal {normal}");

    let guided = image.denoised(&denoiser, Some(&guides))?;
    let unguided = image.denoised(&denoiser, None)?;
    let [before, with_guides, without_guides] = [&image, &guided, &unguided].map(|i| display_mse(i, &truth));
    let [linear_before, linear_with, linear_without] = [&image, &guided, &unguided].map(|i| mse(i, &truth));
    println!(
        "{what}: {SIZE}×{SIZE} at {NOISY_SPP} spp against {REFERENCE_SPP} spp (its own noise ≈ {reference_noise:.2e}), \
         on OIDN's {} device. Displayed picture's MSE: noisy {before:.3e}, denoised with guides {with_guides:.3e} \
         ({:.1}× closer), without guides {without_guides:.3e} ({:.1}×). Linear radiance's MSE: noisy \
         {linear_before:.3e}, with guides {linear_with:.3e} ({:.1}×), without {linear_without:.3e} ({:.1}×)",
        denoiser.device(),
        before / with_guides,
        before / without_guides,
        linear_before / linear_with,
        linear_before / linear_without,
    );
    for (name, out) in [("with guides", &guided), ("without guides", &unguided)] {
        assert!(
            out.radiance.iter().all(|c| c.is_finite() && c.min_element() >= 0.0),
            "{what}: a NaN or negative pixel denoised {name}"
        );
    }
    assert!(
        with_guides * 5.0 <= before,
        "{what}: denoising with guides took MSE {before:.3e} only to {with_guides:.3e}"
    );
    // The reference's own noise is small against the margin the test asserts.
    assert!(reference_noise * 10.0 < before / 5.0, "{what}: reference noise {reference_noise:.3e}");
    no_validation_messages(ctx, what);
    Ok(())
}

/// Writing the guides changes nothing of the picture: the same radiance sums
/// and ray counts as the renderer without them.
fn guides_leave_the_picture_alone(ctx: &Context, what: &str) -> anyhow::Result<()> {
    let programs = Programs::rust(ctx)?;
    let scene = Scene::new(ctx)?;
    let mut plain = Renderer::new(ctx, &programs, &scene, 16, 12)?;
    let mut guided = Renderer::new(ctx, &programs, &scene, 16, 12)?;
    guided.enable_guides(ctx, &programs)?;
    assert!(plain.guides()?.is_none() && guided.has_guides());
    for _ in 0..2 {
        plain.launch(2)?;
        guided.launch(2)?;
    }
    let (a, b) = (plain.accumulation()?, guided.accumulation()?);
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!(
            (*x - *y).abs().max_element() <= 1e-5 * x.abs().max_element().max(1.0),
            "{what}: pixel {i}: {x} vs {y}"
        );
    }
    assert!(a.iter().any(|p| p.w > 0.0), "{what}: nothing was traced");
    // GLSL programs have no guide-writing raygen: a typed error, not a panic.
    if ctx.backend() == Backend::Vulkan {
        let err = guided.enable_guides(ctx, &Programs::glsl(ctx)?).unwrap_err();
        assert!(matches!(err, path_tracer::GuidesError::NoGuidesProgram), "{err}");
        assert!(err.to_string().contains("Programs::rust"), "{err}");
    }
    no_validation_messages(ctx, what);
    Ok(())
}

#[test]
fn guided_denoising_comes_5x_closer_to_the_converged_cornell_box_on_the_cpu_backend() -> anyhow::Result<()> {
    let ctx = context(Backend::Cpu)?.expect("the CPU backend always exists");
    denoises_the_cornell_box(&ctx, "CPU backend")
}

#[test]
fn guided_denoising_comes_5x_closer_to_the_converged_cornell_box_on_vulkan() -> anyhow::Result<()> {
    match context(Backend::Vulkan)? {
        Some(ctx) => denoises_the_cornell_box(&ctx, "Vulkan"),
        None => Ok(()),
    }
}

#[test]
fn writing_the_guides_leaves_the_picture_alone_on_both_backends() -> anyhow::Result<()> {
    guides_leave_the_picture_alone(&context(Backend::Cpu)?.expect("the CPU backend always exists"), "CPU backend")?;
    if let Some(ctx) = context(Backend::Vulkan)? {
        guides_leave_the_picture_alone(&ctx, "Vulkan")?;
    }
    Ok(())
}
