//! The display pass: `raykit-viewer-device`'s raygen program, linked as a
//! pipeline of its own, turns the accumulation into the window's pixels in a
//! device-local buffer (see the device crate for why it is a raykit program).

use raykit::glam::Vec4;
use raykit::{Context, DeviceBuffer, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use raykit_viewer_device::{display_pixel, layout, DisplayParams, DISPLAY};

use crate::error::Result;

/// The display pass's SPIR-V, built by build.rs and carried in the program.
static DISPLAY_SPIRV: raykit::EmbeddedSpirv = raykit::include_spirv!("raykit-viewer-device");

/// How the displayed `u32`s are laid out (the device crate's [`layout`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct PixelFormat {
    /// [`layout::RGBA`] or [`layout::BGRA`].
    pub layout: u32,
    /// The alpha byte.
    pub alpha: u32,
}

impl PixelFormat {
    /// `VK_FORMAT_B8G8R8A8_UNORM`, opaque.
    pub const BGRA8: PixelFormat = PixelFormat { layout: layout::BGRA, alpha: 255 };
    /// `VK_FORMAT_R8G8B8A8_UNORM`, opaque.
    pub const RGBA8: PixelFormat = PixelFormat { layout: layout::RGBA, alpha: 255 };
    /// softbuffer's `0RGB` words.
    pub const SOFTBUFFER: PixelFormat = PixelFormat { layout: layout::BGRA, alpha: 0 };

    /// `pixel` (in this format) as RGBA8 with red in the lowest byte and alpha 255,
    /// as PNG files are written.
    pub fn to_rgba8(self, pixel: u32) -> u32 {
        let rgb = if self.layout == layout::BGRA {
            ((pixel >> 16) & 0xff) | (pixel & 0xff00) | ((pixel & 0xff) << 16)
        } else {
            pixel & 0x00ff_ffff
        };
        rgb | 0xff00_0000
    }
}

/// Samples per pixel of an accumulation: `above` in the rows above `split_row`,
/// `below` from there down (a pass of row bands under way has reached `split_row`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Samples {
    /// Samples per pixel above `split_row`.
    pub above: u32,
    /// The first row with `below` samples.
    pub split_row: u32,
    /// Samples per pixel from `split_row` down.
    pub below: u32,
}

impl Samples {
    /// `n` samples in every row.
    pub fn whole(n: u32) -> Samples {
        Samples { above: n, split_row: u32::MAX, below: n }
    }
}

/// The linked display pass and the pixels it writes.
pub struct DisplayPass {
    pipeline: Pipeline<DisplayParams>,
    sbt: Sbt,
    pixels: DeviceBuffer<u32>,
    width: u32,
    height: u32,
    format: PixelFormat,
    /// Whether the context is the CPU backend's.
    on_cpu: bool,
}

impl DisplayPass {
    /// Links the pass on `ctx` for `width × height` pixels in `format`.
    pub fn new(ctx: &Context, width: u32, height: u32, format: PixelFormat) -> Result<DisplayPass> {
        let module = Module::from_embedded(ctx, &DISPLAY_SPIRV)?;
        let raygen = ProgramGroup::raygen(&module, DISPLAY)?;
        let pipeline = Pipeline::<DisplayParams>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let pixels = ctx.buffer::<u32>(width as usize * height as usize)?;
        let on_cpu = ctx.backend() == raykit::Backend::Cpu;
        Ok(DisplayPass { pipeline, sbt, pixels, width, height, format, on_cpu })
    }

    /// A new pixel buffer for `width × height`.
    pub fn resize(&mut self, ctx: &Context, width: u32, height: u32) -> Result<()> {
        if (width, height) != (self.width, self.height) {
            self.pixels = ctx.buffer::<u32>(width as usize * height as usize)?;
            self.width = width;
            self.height = height;
        }
        Ok(())
    }

    /// Runs the pass over `accumulation` (`samples` per pixel above `split_row`,
    /// `samples_below` from there down); waits for it.
    pub fn run(&mut self, accumulation: &DeviceBuffer<Vec4>, samples: Samples, exposure: f32) -> Result<()> {
        let params = DisplayParams {
            accum: accumulation.handle(),
            pixels: self.pixels.handle(),
            width: self.width,
            samples: samples.above,
            exposure,
            layout: self.format.layout,
            alpha: self.format.alpha,
            split_row: samples.split_row.min(self.height),
            samples_below: samples.below,
        };
        if self.on_cpu {
            return self.run_on_host(accumulation, &params);
        }
        self.pipeline.launch(&self.sbt, &params, [self.width, self.height, 1])?;
        Ok(())
    }

    /// The CPU backend's display pass: the program's own function over the rows
    /// in parallel, without a launch's per-invocation machinery (the same bytes:
    /// on the CPU backend a launch calls this function too).
    fn run_on_host(&mut self, accumulation: &DeviceBuffer<Vec4>, p: &DisplayParams) -> Result<()> {
        use rayon::prelude::*;
        let sums = accumulation.read()?;
        let mut pixels = vec![0u32; sums.len()];
        let width = p.width.max(1) as usize;
        pixels.par_chunks_mut(width).zip(sums.par_chunks(width)).enumerate().for_each(|(y, (out, row))| {
            let samples = if (y as u32) < p.split_row { p.samples } else { p.samples_below };
            for (pixel, sum) in out.iter_mut().zip(row) {
                *pixel = display_pixel(sum.truncate(), samples, p.exposure, p.layout, p.alpha);
            }
        });
        self.pixels.write(&pixels)?;
        Ok(())
    }

    /// The displayed pixels of the last run.
    pub fn pixels(&self) -> &DeviceBuffer<u32> {
        &self.pixels
    }

    /// The pixel format.
    pub fn format(&self) -> PixelFormat {
        self.format
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}
