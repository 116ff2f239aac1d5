//! `cargo run -p program-model -- [SCENE...] [--size N] [--out DIR]`: renders
//! the program-model scenes (all by default) to `DIR/<scene>.png`. Build the
//! shaders first (`cargo xtask build-shaders`).

use clap::Parser;

#[derive(Parser)]
#[command(about = "OptiX's program kinds on raykit: renders each scene to a PNG")]
struct Args {
    /// Scenes to render: spheres, cutout, shadows, callables, sbt_data (all when none).
    scenes: Vec<String>,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Output directory.
    #[arg(long, default_value = "target/program_model")]
    out: std::path::PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let ctx = raykit::Context::new(raykit::ContextOptions::default())?;
    std::fs::create_dir_all(&args.out)?;
    let scenes: Vec<String> = if args.scenes.is_empty() {
        program_model::SCENES.iter().map(|s| s.to_string()).collect()
    } else {
        args.scenes
    };
    for scene in &scenes {
        let pixels = program_model::render(&ctx, scene, args.size)?;
        let path = args.out.join(format!("{scene}.png"));
        program_model::write_png(&path, args.size, &pixels)?;
        println!("{scene}: {}", path.display());
    }
    Ok(())
}
