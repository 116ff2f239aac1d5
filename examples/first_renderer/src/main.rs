//! `cargo run --release -p first_renderer -- [OUTPUT.png] [WIDTH HEIGHT SPP]`: the README's first renderer.
//! Build the shaders first (`cargo xtask build-shaders`).

use anyhow::Context as _;
use raykit::glam::UVec2;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let output = args.first().cloned().unwrap_or_else(|| "first_renderer.png".to_owned());
    let number = |i: usize, default: u32| -> anyhow::Result<u32> {
        args.get(i)
            .map(|s| s.parse().context("WIDTH, HEIGHT and SPP are numbers"))
            .transpose()
            .map(|n| n.unwrap_or(default))
    };
    let (width, height, spp) = (number(1, 600)?, number(2, 400)?, number(3, 64)?);
    let ctx = raykit::Context::new(raykit::ContextOptions::default())?;
    // Launches of at most 16 samples per pixel, so each stays short.
    let launches = spp.div_ceil(16).max(1);
    let per_launch = spp.div_ceil(launches);
    let steps = first_renderer::render(&ctx, UVec2::new(width, height), per_launch, launches)?;
    let last = steps.last().context("no launch")?;
    raykit::write_png_rgba8(std::path::Path::new(&output), width, height, &first_renderer::to_rgba8(last))?;
    let spp = per_launch * launches;
    println!("rendered {width}x{height}, {spp} spp on {} to {output}", ctx.device_name());
    Ok(())
}
