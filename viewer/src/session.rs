//! A program's `--view` and `--headless` in one call: the window on a renderer,
//! or the frames it would show rendered to a file, as [`ViewerArgs`] ask.

use std::path::PathBuf;

use raykit_denoise::DenoiseArgs;
use raykit_scene::Camera;

use crate::error::{Result, ViewerError};
use crate::options::ViewerArgs;
use crate::render::Render;
use crate::window::{Summary, WindowOptions};

/// What a program shows in the viewer, besides its renderer.
#[derive(Clone, Debug)]
pub struct Session {
    /// The window's title (the stats line follows it).
    pub title: String,
    /// Width of the picture (the window's inner width) in pixels.
    pub width: u32,
    /// Height of the picture in pixels.
    pub height: u32,
    /// The camera to start from when `--camera` gives none.
    pub camera: Camera,
    /// Scale of the radiance before the tonemap.
    pub exposure: f32,
    /// Where `--headless` writes the picture (PNG; the mean radiance goes beside
    /// it as `.exr`).
    pub output: PathBuf,
    /// `--denoise` and its options (`DenoiseArgs::default()`: no denoising).
    pub denoise: DenoiseArgs,
}

/// Opens the window on `renderer` (`--view`) or renders `--frames N` frames of it
/// without one to `session.output` (`--headless`), then prints the summary line
/// (`viewer: N frames at WxH ...`) and returns it.
pub fn run<R: Render>(renderer: R, args: &ViewerArgs, session: Session) -> Result<Summary> {
    let camera = args.camera_or(session.camera)?;
    let frames = args.frame_options(session.exposure, &session.denoise)?;
    let summary = if args.headless {
        let count = args.frames.ok_or(ViewerError::HeadlessFrames)?;
        crate::headless::run(renderer, camera, session.width, session.height, frames, count, &session.output)?
    } else {
        let options = WindowOptions {
            title: session.title,
            width: session.width,
            height: session.height,
            camera,
            frames,
            script: args.script()?,
            frame_limit: args.frames,
        };
        crate::window::run(renderer, options)?
    };
    println!("viewer: {}", summary.line());
    Ok(summary)
}
