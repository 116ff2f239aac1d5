//! The viewer without a window: the same [`Viewer`] (renderer, camera, display
//! pass, samples per frame) for a number of frames, then a screenshot. With the
//! same camera, size, frames and fixed samples per frame it writes the bytes the
//! window shows (the display pass is the same program on the same device).

use std::path::Path;

use raykit_scene::Camera;

use crate::display::PixelFormat;
use crate::error::Result;
use crate::render::Render;
use crate::viewer::{FrameOptions, Viewer};
use crate::window::Summary;

/// Renders `frames` frames of `renderer` at `width × height` from `camera` and
/// writes the picture to `output` (PNG) and the mean radiance beside it (`.exr`).
pub fn run<R: Render>(
    renderer: R,
    camera: Camera,
    width: u32,
    height: u32,
    options: FrameOptions,
    frames: u64,
    output: &Path,
) -> Result<Summary> {
    let mut viewer = Viewer::new(renderer, camera, width, height, PixelFormat::BGRA8, options)?;
    while viewer.frames() < frames {
        if !viewer.render_frame()? {
            break;
        }
    }
    viewer.write_screenshot(output)?;
    viewer.summary("headless")
}
