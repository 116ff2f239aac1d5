//! The viewer's row bands: a pass of band launches from the top to the bottom
//! accumulates what one launch of the whole image does, bit for bit, and the pass
//! completes one launch of the progressive sequence.

use path_tracer::{Programs, Renderer, Scene};
use raykit::{Backend, Context, ContextOptions};

const WIDTH: u32 = 24;
const HEIGHT: u32 = 20;

fn bands_equal_one_launch(ctx: &Context) -> anyhow::Result<()> {
    let programs = Programs::rust(ctx)?;
    let scene = Scene::new(ctx)?;
    let mut whole = Renderer::new(ctx, &programs, &scene, WIDTH, HEIGHT)?;
    let mut banded = Renderer::new(ctx, &programs, &scene, WIDTH, HEIGHT)?;
    for _ in 0..2 {
        whole.launch_async(2)?.wait()?;
        for rows in [0..3, 3..4, 4..11, 11..HEIGHT] {
            banded.launch_rows_async(2, rows.clone())?.wait()?;
            let expected = if rows.end == HEIGHT { whole.samples_done() } else { whole.samples_done() - 2 };
            assert_eq!(banded.samples_done(), expected, "after rows {rows:?}");
        }
    }
    let (a, b) = (whole.accumulation()?, banded.accumulation()?);
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
    assert!(a.iter().any(|p| p.w > 0.0), "nothing was traced");
    Ok(())
}

#[test]
fn a_pass_of_row_bands_accumulates_what_one_launch_does_on_the_cpu_backend() -> anyhow::Result<()> {
    bands_equal_one_launch(&Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?)
}

#[test]
fn a_pass_of_row_bands_accumulates_what_one_launch_does_on_vulkan() -> anyhow::Result<()> {
    match Context::new(ContextOptions { backend: Some(Backend::Vulkan), ..Default::default() }) {
        Ok(ctx) => bands_equal_one_launch(&ctx),
        Err(e) if std::env::var("RAYKIT_REQUIRE_DEVICE").as_deref() != Ok("1") => {
            eprintln!("SKIPPED: no Vulkan device with ray tracing ({e})");
            Ok(())
        }
        Err(e) => Err(e.into()),
    }
}
