//! What the viewer asks of a renderer: a progressive accumulation it can launch a
//! few samples at a time, aim, resize and restart.

use std::ops::Range;

use raykit::glam::Vec4;
use raykit::{Context, DeviceBuffer, Launch};
use raykit_scene::Camera;

use crate::error::RenderError;

/// The denoiser's guides of an accumulation: per pixel (row-major, row 0 at the
/// top), the mean over its paths of the first hit's albedo and world normal.
#[derive(Clone, Debug, Default)]
pub struct DenoiseGuides {
    /// First-hit albedo (0 for a miss).
    pub albedo: Vec<[f32; 3]>,
    /// First-hit world normal (0 for a miss).
    pub normal: Vec<[f32; 3]>,
}

/// A progressive renderer the viewer drives.
///
/// The accumulation buffer holds, per pixel (row-major, row 0 at the top), the sum
/// of the radiance samples so far (xyz) and the rays traced for the pixel (w, for
/// the Mrays/s of the stats line). Launch `n` (counted from the last restart)
/// overwrites it when `n == 0` and adds to it otherwise.
pub trait Render {
    /// The context the renderer launches on.
    fn context(&self) -> &Context;

    /// Starts over at `width × height` pixels (both at least 1) seen from `camera`.
    fn resize(&mut self, width: u32, height: u32, camera: &Camera) -> Result<(), RenderError>;

    /// Aims the camera; the next launch starts over.
    fn set_camera(&mut self, camera: &Camera);

    /// Starts over: the next launch overwrites the accumulation.
    fn reset(&mut self);

    /// Submits a launch adding `samples` samples per pixel and returns it without
    /// waiting; the viewer waits for (or polls) it before reading the accumulation.
    fn launch(&mut self, samples: u32) -> Result<Launch, RenderError>;

    /// Whether [`Render::launch_rows`] works: a renderer that can launch a band of
    /// rows lets the viewer keep frames short when one sample of the whole image
    /// takes longer than the target frame time.
    fn launches_rows(&self) -> bool {
        false
    }

    /// Submits a launch adding `samples` samples per pixel to the rows `rows` only,
    /// as part of the current launch of the progressive sequence: the launch that
    /// reaches the last row completes it (then [`Render::samples_done`] counts
    /// `samples` more and the next launch is the sequence's next). The viewer sends
    /// the bands of one pass top to bottom, each starting where the last ended.
    fn launch_rows(&mut self, samples: u32, rows: Range<u32>) -> Result<Launch, RenderError> {
        let _ = (samples, rows);
        Err("this renderer launches whole images only".into())
    }

    /// The accumulation buffer (see the trait's docs).
    fn accumulation(&self) -> &DeviceBuffer<Vec4>;

    /// Samples per pixel accumulated by the launches submitted so far.
    fn samples_done(&self) -> u32;

    /// Asks the renderer to write the denoiser's guides (first-hit albedo and
    /// normals, [`Render::guides`]) from the next launch on, in the same launches;
    /// `Ok(false)`: it has none (the default), and the viewer denoises the colour alone.
    fn enable_guides(&mut self) -> Result<bool, RenderError> {
        Ok(false)
    }

    /// The guides of the accumulation so far, once [`Render::enable_guides`]
    /// returned `true` (the viewer reads them only then, with no launch in flight).
    fn guides(&self) -> Result<Option<DenoiseGuides>, RenderError> {
        Ok(None)
    }

    /// Hot reload: called before every launch; a renderer that watches its device
    /// programs swaps in new ones here and returns what happened (a message for the
    /// terminal, or the compile error while the old programs keep rendering).
    fn poll_reload(&mut self) -> Option<Result<String, RenderError>> {
        None
    }
}
