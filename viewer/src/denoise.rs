//! Denoising in the viewer (`--denoise`): the accumulation's mean radiance,
//! denoised by Intel Open Image Denoise ([`raykit_denoise`]), guided by the
//! renderer's first-hit albedo and normals when it writes them
//! ([`Render::enable_guides`]). A picture is denoised every
//! [`DenoiseOptions::every`] frames of one camera (so the first comes that many
//! frames after the camera stops), when the last sample asked for (`--max-spp`)
//! is in, and for each screenshot. While the latest denoised picture is of the
//! current accumulation the window shows it in place of the noisy one; `N`
//! ([`crate::ViewerInput::ShowDenoised`]) toggles between them.

use raykit::glam::{Vec3, Vec4};
use raykit::{Context, DeviceBuffer};
use raykit_denoise::{DenoiseDevice, Denoiser, Input};

use crate::display::Samples;
use crate::error::{Result, ViewerError};
use crate::render::Render;

/// Frames of one camera between denoised pictures unless `--denoise-every` says otherwise.
pub const DEFAULT_EVERY: u32 = 16;

/// How the viewer denoises.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct DenoiseOptions {
    /// Where Open Image Denoise runs.
    pub device: DenoiseDevice,
    /// Whether to ask the renderer for albedo and normal guides.
    pub guides: bool,
    /// Frames of one camera between denoised pictures (at least 1).
    pub every: u32,
}

impl Default for DenoiseOptions {
    fn default() -> Self {
        DenoiseOptions { device: DenoiseDevice::Auto, guides: true, every: DEFAULT_EVERY }
    }
}

/// Which accumulation a denoised picture is of: the viewer's restarts and the
/// samples per pixel then.
pub(crate) type AccumulationId = (u64, Samples);

/// The viewer's denoiser and its latest picture.
pub(crate) struct ViewDenoiser {
    denoiser: Denoiser,
    every: u32,
    /// Whether the renderer writes guides.
    guided: bool,
    /// Whether the window shows the denoised picture (`N` toggles it).
    pub(crate) shown: bool,
    /// The latest denoised picture as the display pass reads it (the mean in
    /// xyz, w = 1), and its radiance for screenshots.
    picture: Option<(DeviceBuffer<Vec4>, Vec<Vec3>)>,
    /// The accumulation the picture is of.
    of: Option<AccumulationId>,
}

impl ViewDenoiser {
    /// Loads the denoiser (a missing library fails here, naming its install
    /// command) and asks `renderer` for guides when `options` want them.
    pub(crate) fn new(options: &DenoiseOptions, renderer: &mut impl Render) -> Result<ViewDenoiser> {
        let denoiser = Denoiser::new(options.device)?;
        let guided = options.guides && renderer.enable_guides().map_err(ViewerError::Render)?;
        let guides = match (options.guides, guided) {
            (true, true) => "albedo and normal guides",
            (true, false) => "no guides (the renderer writes none)",
            (false, _) => "no guides",
        };
        let every = options.every.max(1);
        println!(
            "viewer: denoising with Open Image Denoise on its {} device, {guides}, every {every} frames (N toggles)",
            denoiser.device()
        );
        Ok(ViewDenoiser { denoiser, every, guided, shown: true, picture: None, of: None })
    }

    /// Whether the `frames`-th frame since the last restart gets a denoised picture.
    pub(crate) fn due(&self, frames: u64) -> bool {
        frames > 0 && frames.is_multiple_of(self.every as u64)
    }

    /// The latest picture, if it is of an accumulation since restart `restarts`
    /// (the same camera, maybe fewer samples than now).
    pub(crate) fn picture_since(&self, restarts: u64) -> Option<&DeviceBuffer<Vec4>> {
        self.picture.as_ref().filter(|_| self.of.is_some_and(|(r, _)| r == restarts)).map(|(buffer, _)| buffer)
    }

    /// The latest picture's radiance, if it is of accumulation `of`.
    pub(crate) fn radiance_of(&self, of: AccumulationId) -> Option<&[Vec3]> {
        self.picture.as_ref().filter(|_| self.of == Some(of)).map(|(_, radiance)| radiance.as_slice())
    }

    /// Denoises the mean of `renderer`'s accumulation (`width` pixels wide, `of`
    /// samples per pixel) into the picture; call it with no launch in flight.
    pub(crate) fn denoise(
        &mut self,
        ctx: &Context,
        renderer: &impl Render,
        width: u32,
        of: AccumulationId,
    ) -> Result<()> {
        let color = mean(&renderer.accumulation().read()?, width, of.1);
        let height = (color.len() / width.max(1) as usize) as u32;
        let rgb = |v: &[Vec3]| -> Vec<[f32; 3]> { v.iter().map(|c| c.to_array()).collect() };
        let color_rgb = rgb(&color);
        let guides = if self.guided { renderer.guides().map_err(ViewerError::Render)? } else { None };
        let mut input = Input::new(width, height, &color_rgb);
        if let Some(guides) = &guides {
            input = input.with_guides(&guides.albedo, &guides.normal);
        }
        let radiance: Vec<Vec3> = self.denoiser.denoise(&input)?.into_iter().map(Vec3::from_array).collect();
        let texels: Vec<Vec4> = radiance.iter().map(|c| c.extend(1.0)).collect();
        match &mut self.picture {
            Some((buffer, kept)) if buffer.len() == texels.len() => {
                buffer.write(&texels)?;
                *kept = radiance;
            }
            _ => self.picture = Some((ctx.buffer_from(&texels)?, radiance)),
        }
        self.of = Some(of);
        Ok(())
    }
}

/// The mean radiance of an accumulation (sums in xyz) `width` pixels wide with
/// `samples` per pixel by rows; 0 where no sample is in.
pub(crate) fn mean(accumulation: &[Vec4], width: u32, samples: Samples) -> Vec<Vec3> {
    let mean = |(i, a): (usize, &Vec4)| {
        let n = if (i as u32 / width.max(1)) < samples.split_row { samples.above } else { samples.below };
        if n == 0 {
            Vec3::ZERO
        } else {
            a.truncate() / n as f32
        }
    };
    accumulation.iter().enumerate().map(mean).collect()
}
