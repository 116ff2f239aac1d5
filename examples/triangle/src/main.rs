//! `cargo run -p triangle -- [OUTPUT.png] [WIDTH HEIGHT]`: renders optixTriangle.
//! Build the shaders first (`cargo xtask build-shaders`), or run `cargo xtask demo`.

use anyhow::Context as _;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let output = args.first().cloned().unwrap_or_else(|| "triangle.png".to_owned());
    let width: u32 = args.get(1).map(|s| s.parse()).transpose().context("WIDTH must be a number")?.unwrap_or(1024);
    let height: u32 = args.get(2).map(|s| s.parse()).transpose().context("HEIGHT must be a number")?.unwrap_or(768);
    let ctx = raykit::Context::new(raykit::ContextOptions::default())?;
    let pixels = triangle::render(&ctx, width, height)?;
    let path = std::path::Path::new(&output);
    triangle::write_png(path, width, height, &pixels)?;
    println!("rendered {width}x{height} on {} to {}", ctx.device_name(), path.display());
    Ok(())
}
