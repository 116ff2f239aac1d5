//! The viewer without its window: a renderer, its camera, the display pass, the
//! launch in flight, the samples per frame and the stats. The window
//! ([`crate::window`]) and the headless mode ([`crate::headless`]) drive the same
//! [`Viewer`], so a headless render is what the window shows.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use raykit::glam::Vec3;
use raykit::Launch;
use raykit_scene::Camera;

use crate::camera::{format_camera, CameraRig};
use crate::denoise::{mean, DenoiseOptions, ViewDenoiser};
use crate::display::{DisplayPass, PixelFormat, Samples};
use crate::error::{Result, ViewerError};
use crate::input::ViewerInput;
use crate::render::Render;
use crate::stats::{Stats, RAY_COUNT_PERIOD};
use crate::window::Summary;

/// Most samples per pixel one frame launches when the frame time adapts.
pub const MAX_SAMPLES_PER_FRAME: u32 = 256;

/// How the viewer renders frames.
#[derive(Clone, Debug)]
pub struct FrameOptions {
    /// Samples per pixel of every frame; `None` adapts them to `target_frame_time`.
    pub samples_per_frame: Option<u32>,
    /// The frame time the samples per frame adapt to.
    pub target_frame_time: Duration,
    /// Stop launching once this many samples per pixel are accumulated.
    pub max_samples: Option<u32>,
    /// Scale of the radiance before the tonemap.
    pub exposure: f32,
    /// Denoise the picture (`--denoise`; see [`crate::denoise`]).
    pub denoise: Option<DenoiseOptions>,
}

impl Default for FrameOptions {
    fn default() -> Self {
        FrameOptions {
            samples_per_frame: None,
            target_frame_time: Duration::from_millis(33),
            max_samples: None,
            exposure: 1.0,
            denoise: None,
        }
    }
}

/// What [`Viewer::tick`] did.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Tick {
    /// A launch finished and its picture is in [`Viewer::display`]: present it.
    Displayed,
    /// A launch is running (or was just submitted).
    Working,
    /// Nothing to do: paused, or every sample asked for is accumulated.
    Idle,
}

/// A submitted launch.
struct InFlight {
    launch: Launch,
    samples: u32,
    /// Rows it renders.
    rows: u32,
    /// Samples per pixel in the accumulation once it has finished.
    shown: Samples,
    submitted: Instant,
    /// The viewer's restarts when it was submitted: fewer than now, and the
    /// accumulation it adds to was started over while it ran.
    restarts: u64,
}

/// The viewer's state apart from its window.
pub struct Viewer<R: Render> {
    renderer: R,
    rig: CameraRig,
    display: DisplayPass,
    options: FrameOptions,
    in_flight: Option<InFlight>,
    /// Samples per pixel of the next frame.
    next_samples: u32,
    /// Rows of the next frame when one sample of the whole image takes longer
    /// than the target frame time (and the renderer launches rows); `None`: the
    /// whole image.
    band_rows: Option<u32>,
    /// The first row of the next band of a pass under way (0: none is).
    band_next_row: u32,
    /// Samples per pixel shown by the last displayed frame.
    displayed: Samples,
    frames: u64,
    paused: bool,
    screenshots: Vec<PathBuf>,
    stats: Stats,
    /// Refreshes of the stats' ray count.
    rays_counted_at: Option<Instant>,
    /// Hot reloads that swapped in new programs.
    reloads: u64,
    /// Hot reloads whose build failed (the previous programs kept rendering).
    failed_reloads: u64,
    /// Times the accumulation started over.
    restarts: u64,
    /// Frames displayed since the last restart of launches submitted after it.
    frames_since_restart: u64,
    /// The denoiser, with `--denoise`.
    denoiser: Option<ViewDenoiser>,
    /// Whether the displayed picture is a denoised one.
    showing_denoised: bool,
}

impl<R: Render> Viewer<R> {
    /// A viewer of `renderer` at `width × height` pixels (at least 1 each) from
    /// `camera`, displaying in `format`.
    pub fn new(
        mut renderer: R,
        camera: Camera,
        width: u32,
        height: u32,
        format: PixelFormat,
        options: FrameOptions,
    ) -> Result<Viewer<R>> {
        let (width, height) = (width.max(1), height.max(1));
        renderer.resize(width, height, &camera).map_err(ViewerError::Render)?;
        let display = DisplayPass::new(renderer.context(), width, height, format)?;
        let denoiser = options.denoise.as_ref().map(|d| ViewDenoiser::new(d, &mut renderer)).transpose()?;
        let next_samples = options.samples_per_frame.unwrap_or(1).max(1);
        Ok(Viewer {
            renderer,
            rig: CameraRig::new(camera),
            display,
            options,
            in_flight: None,
            next_samples,
            band_rows: None,
            band_next_row: 0,
            displayed: Samples::default(),
            frames: 0,
            paused: false,
            screenshots: Vec::new(),
            stats: Stats::default(),
            rays_counted_at: None,
            reloads: 0,
            failed_reloads: 0,
            restarts: 0,
            frames_since_restart: 0,
            denoiser,
            showing_denoised: false,
        })
    }

    /// The renderer.
    pub fn renderer(&self) -> &R {
        &self.renderer
    }

    /// The camera now.
    pub fn camera(&self) -> Camera {
        self.rig.camera()
    }

    /// The camera rig (its mode, its speed).
    pub fn rig(&self) -> &CameraRig {
        &self.rig
    }

    /// The display pass, whose pixels hold the last displayed frame.
    pub fn display(&self) -> &DisplayPass {
        &self.display
    }

    /// Frames displayed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Samples per pixel in every row of the displayed picture (a pass of row
    /// bands under way has one more above [`Viewer::displayed`]'s split row).
    pub fn displayed_samples(&self) -> u32 {
        self.displayed.below
    }

    /// Samples per pixel of the displayed picture, by rows.
    pub fn displayed(&self) -> Samples {
        self.displayed
    }

    /// Rows per frame while frames launch bands of rows (`None`: whole images).
    pub fn band_rows(&self) -> Option<u32> {
        self.band_rows
    }

    /// Samples per pixel the next frame launches.
    pub fn next_samples(&self) -> u32 {
        self.next_samples
    }

    /// The stats.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Hot reloads that swapped in new device programs so far.
    pub fn reloads(&self) -> u64 {
        self.reloads
    }

    /// Hot reloads whose build failed so far (each printed its error once).
    pub fn failed_reloads(&self) -> u64 {
        self.failed_reloads
    }

    /// With `--denoise`, whether the window shows the denoised picture (`N`
    /// toggles it); `None` without a denoiser.
    pub fn shows_denoised(&self) -> Option<bool> {
        self.denoiser.as_ref().map(|d| d.shown)
    }

    /// Whether the displayed picture is a denoised one.
    pub fn displays_denoised(&self) -> bool {
        self.showing_denoised
    }

    /// Whether a launch is running.
    pub fn is_launching(&self) -> bool {
        self.in_flight.is_some()
    }

    /// Stops (`true`) or resumes launching, as a minimised window does.
    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }

    /// Sends one input. Camera inputs start the accumulation over (a launch in
    /// flight still finishes and is displayed with its own camera); a screenshot is
    /// written at once when no launch runs, else after the next displayed frame.
    /// Window inputs ([`ViewerInput::Resize`], [`ViewerInput::Minimize`],
    /// [`ViewerInput::Close`]) are the window's to handle and do nothing here.
    pub fn input(&mut self, input: ViewerInput) -> Result<()> {
        match input {
            ViewerInput::Drag { dx, dy } => self.rig.drag(dx, dy),
            ViewerInput::Zoom(steps) => self.rig.zoom(steps),
            ViewerInput::Translate { forward, right, up } => self.rig.translate(forward, right, up),
            ViewerInput::Camera(camera) => self.rig.set_camera(camera),
            ViewerInput::Mode(mode) => {
                self.rig.mode = mode;
                return Ok(());
            }
            ViewerInput::Reset => {}
            ViewerInput::Screenshot(path) => {
                self.screenshots.push(path);
                if self.in_flight.is_none() {
                    self.write_screenshots()?;
                }
                return Ok(());
            }
            ViewerInput::PrintCamera => {
                println!("camera: --camera {}", format_camera(&self.rig.camera()));
                return Ok(());
            }
            ViewerInput::ShowDenoised(show) => {
                if let Some(denoiser) = &mut self.denoiser {
                    denoiser.shown = show;
                    if self.in_flight.is_none() {
                        // Idle or between frames: show the change now (a launch in
                        // flight shows it when it finishes).
                        self.show(true, true)?;
                    }
                }
                return Ok(());
            }
            ViewerInput::Resize { .. } | ViewerInput::Minimize(_) | ViewerInput::Close => return Ok(()),
        }
        self.renderer.set_camera(&self.rig.camera());
        self.restart();
        Ok(())
    }

    /// Starts the accumulation over.
    fn restart(&mut self) {
        self.renderer.reset();
        self.band_next_row = 0;
        self.restarts += 1;
        self.frames_since_restart = 0;
        self.stats.restarted();
        if self.options.samples_per_frame.is_none() {
            // The first frames after a change come quickly.
            self.next_samples = 1;
        }
    }

    /// Resizes the picture to `width × height` (at least 1 each); waits for a
    /// launch in flight first and starts the accumulation over.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        let (width, height) = (width.max(1), height.max(1));
        if (width, height) == self.display.size() {
            return Ok(());
        }
        self.finish_launch()?;
        self.renderer.resize(width, height, &self.rig.camera()).map_err(ViewerError::Render)?;
        let ctx = self.renderer.context().clone();
        self.display.resize(&ctx, width, height)?;
        self.displayed = Samples::default();
        self.band_rows = self.band_rows.map(|rows| rows.min(height));
        self.restart();
        Ok(())
    }

    /// Waits for the launch in flight and drops its result.
    fn finish_launch(&mut self) -> Result<()> {
        if let Some(in_flight) = self.in_flight.take() {
            in_flight.launch.wait()?;
        }
        Ok(())
    }

    /// Does the next piece of work without blocking on a launch: displays a
    /// finished launch ([`Tick::Displayed`]; call again after presenting), or
    /// submits the next launch, or reports that one is running.
    pub fn tick(&mut self) -> Result<Tick> {
        if let Some(in_flight) = &self.in_flight {
            if !in_flight.launch.is_done()? {
                return Ok(Tick::Working);
            }
            if let Some(InFlight { launch, samples, rows, shown, submitted, restarts }) = self.in_flight.take() {
                launch.wait()?;
                self.frame_finished(samples, rows, shown, submitted.elapsed(), restarts)?;
                return Ok(Tick::Displayed);
            }
        }
        if self.paused || self.options.max_samples.is_some_and(|max| self.renderer.samples_done() >= max) {
            return Ok(Tick::Idle);
        }
        if let Some(reload) = self.renderer.poll_reload() {
            match reload {
                Ok(message) => {
                    println!("{message}");
                    self.reloads += 1;
                    self.restart();
                }
                Err(e) => {
                    eprintln!("keeping the previous pipeline: {e}");
                    self.failed_reloads += 1;
                }
            }
        }
        let done = self.renderer.samples_done();
        let height = self.display.size().1;
        let band = if self.band_next_row > 0 {
            // A pass under way goes on (in one launch when whole images resume).
            let start = self.band_next_row;
            Some(start..(start + self.band_rows.unwrap_or(height).max(1)).min(height))
        } else {
            self.band_rows.map(|rows| 0..rows.clamp(1, height))
        };
        let in_flight = if let Some(rows) = band {
            let launch = self.renderer.launch_rows(1, rows.clone()).map_err(ViewerError::Render)?;
            let shown = if rows.end == height {
                self.band_next_row = 0;
                Samples::whole(done + 1)
            } else {
                self.band_next_row = rows.end;
                Samples { above: done + 1, split_row: rows.end, below: done }
            };
            let rows = rows.len() as u32;
            InFlight { launch, samples: 1, rows, shown, submitted: Instant::now(), restarts: self.restarts }
        } else {
            let mut samples = self.next_samples;
            if let Some(max) = self.options.max_samples {
                samples = samples.min(max - done);
            }
            let launch = self.renderer.launch(samples).map_err(ViewerError::Render)?;
            let shown = Samples::whole(self.renderer.samples_done());
            InFlight { launch, samples, rows: height, shown, submitted: Instant::now(), restarts: self.restarts }
        };
        self.in_flight = Some(in_flight);
        Ok(Tick::Working)
    }

    /// Renders one frame, blocking until it is displayed (the headless mode's step);
    /// returns `false` when there is nothing more to render.
    pub fn render_frame(&mut self) -> Result<bool> {
        loop {
            match self.tick()? {
                Tick::Displayed => return Ok(true),
                Tick::Idle => return Ok(false),
                Tick::Working => {
                    if let Some(in_flight) = self.in_flight.take() {
                        // Blocks; the next tick finds nothing in flight, so hand it back.
                        let InFlight { launch, samples, rows, shown, submitted, restarts } = in_flight;
                        launch.wait()?;
                        self.frame_finished(samples, rows, shown, submitted.elapsed(), restarts)?;
                        return Ok(true);
                    }
                }
            }
        }
    }

    /// A launch of `samples` over `rows` rows finished in `took`: runs the display
    /// pass, counts the frame, adapts the work per frame, writes waiting screenshots.
    /// A launch submitted before a restart (`restarts` behind the viewer's) counts
    /// as a frame but not towards Mrays/s: its rays and time belong to the
    /// accumulation that was started over.
    fn frame_finished(&mut self, samples: u32, rows: u32, shown: Samples, took: Duration, restarts: u64) -> Result<()> {
        let current = restarts == self.restarts;
        self.displayed = shown;
        if current {
            self.frames_since_restart += 1;
        }
        self.show(current, false)?;
        self.frames += 1;
        let now = Instant::now();
        self.stats.frame(samples, current.then_some(took), now);
        if self.options.samples_per_frame.is_none() {
            self.adapt(samples, rows, took);
        }
        if current && self.rays_counted_at.is_none_or(|at| at.elapsed() > RAY_COUNT_PERIOD) {
            self.count_rays()?;
        }
        self.write_screenshots()
    }

    /// Runs the display pass on what the window shows: with a denoiser shown, the
    /// latest denoised picture since the last restart (denoising the current
    /// accumulation first when this frame is due one, when the last sample asked
    /// for is in, or when `now` asks for it and the latest is older), else the
    /// noisy accumulation. `current`: the displayed samples belong to the
    /// accumulation since the last restart. Call it with no launch in flight.
    fn show(&mut self, current: bool, now: bool) -> Result<()> {
        let id = (self.restarts, self.displayed);
        let exposure = self.options.exposure;
        if let Some(denoiser) = self.denoiser.as_mut().filter(|d| d.shown && current) {
            let finished = self.options.max_samples.is_some_and(|max| self.renderer.samples_done() >= max);
            let due = denoiser.due(self.frames_since_restart) || finished || now;
            if due && denoiser.radiance_of(id).is_none() {
                let ctx = self.renderer.context().clone();
                denoiser.denoise(&ctx, &self.renderer, self.display.size().0, id)?;
            }
            if let Some(picture) = denoiser.picture_since(self.restarts) {
                self.display.run(picture, Samples::whole(1), exposure)?;
                self.showing_denoised = true;
                return Ok(());
            }
        }
        self.display.run(self.renderer.accumulation(), self.displayed, exposure)?;
        self.showing_denoised = false;
        Ok(())
    }

    /// Counts the rays in the accumulation (its w) for the stats; call it while
    /// no launch is in flight (its rays would count, its time would not).
    fn count_rays(&mut self) -> Result<()> {
        let accumulation = self.renderer.accumulation().read()?;
        self.stats.rays_counted(accumulation.iter().map(|a| a.w as f64).sum::<f64>() as u64);
        self.rays_counted_at = Some(Instant::now());
        Ok(())
    }

    /// What the session ended with, presented by `presenter`. Unless a launch is
    /// in flight or none has finished since the last restart, counts the rays once
    /// more, so the summary's Mrays/s covers every frame since the last restart.
    pub fn summary(&mut self, presenter: &'static str) -> Result<Summary> {
        if self.in_flight.is_none() && self.stats.launch_seconds > 0.0 {
            self.count_rays()?;
        }
        Ok(Summary {
            frames: self.frames,
            stats: self.stats.clone(),
            camera: self.camera(),
            samples: self.displayed_samples(),
            size: self.display.size(),
            presenter,
        })
    }

    /// Sizes the next frame's work to the target frame time from the time a
    /// frame of `samples` samples over `rows` rows took: whole images of at most
    /// twice as many samples, or, when one sample of the whole image would take
    /// longer than the target and the renderer launches rows, bands of at most
    /// twice as many rows of one sample.
    fn adapt(&mut self, samples: u32, rows: u32, took: Duration) {
        let height = self.display.size().1;
        let target = self.options.target_frame_time.as_secs_f64();
        // Sample-rows the target frame time affords.
        let budget = (samples as f64 * rows as f64) * target / took.as_secs_f64().max(1e-6);
        if budget >= height as f64 || !self.renderer.launches_rows() {
            let limit = if self.band_rows.is_some() { 1.0 } else { (2 * samples).max(1) as f64 };
            self.band_rows = None;
            let next = (budget / height as f64).floor().clamp(1.0, limit);
            self.next_samples = (next as u32).min(MAX_SAMPLES_PER_FRAME);
        } else {
            let limit = (2 * rows).max(1) as f64;
            self.band_rows = Some((budget.floor().clamp(1.0, limit) as u32).min(height));
            self.next_samples = 1;
        }
    }

    /// Writes the screenshots asked for.
    fn write_screenshots(&mut self) -> Result<()> {
        for path in std::mem::take(&mut self.screenshots) {
            self.write_screenshot(&path)?;
        }
        Ok(())
    }

    /// Writes the displayed picture to `path` (PNG) and its linear radiance (the
    /// accumulation's mean, or the denoised picture) to `path` with `.exr`;
    /// finishes a launch in flight first, as a frame. With the denoiser shown,
    /// the picture is the denoised accumulation as it is now.
    pub fn write_screenshot(&mut self, path: &Path) -> Result<()> {
        if let Some(InFlight { launch, samples, rows, shown, submitted, restarts }) = self.in_flight.take() {
            // Its samples are in the accumulation once it is done: display them too.
            launch.wait()?;
            self.frame_finished(samples, rows, shown, submitted.elapsed(), restarts)?;
        }
        // A denoised screenshot is of the samples displayed now.
        let denoised = self.denoiser.as_ref().is_some_and(|d| d.shown);
        if denoised {
            self.show(true, true)?;
        }
        let (width, height) = self.display.size();
        let format = self.display.format();
        let pixels: Vec<u32> = self.display.pixels().read()?.into_iter().map(|p| format.to_rgba8(p)).collect();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|source| ViewerError::Directory { path: dir.to_path_buf(), source })?;
        }
        let screenshot_error = |source| ViewerError::Screenshot { path: path.to_path_buf(), source };
        raykit_scene::write_png_rgba8(path, width, height, &pixels).map_err(screenshot_error)?;
        let id = (self.restarts, self.displayed);
        let radiance: Vec<Vec3> = match self.denoiser.as_ref().and_then(|d| d.radiance_of(id)) {
            Some(radiance) if denoised => radiance.to_vec(),
            _ => mean(&self.renderer.accumulation().read()?, width, self.displayed),
        };
        let exr = path.with_extension("exr");
        raykit_scene::write_exr(&exr, width, height, &radiance)
            .map_err(|source| ViewerError::Screenshot { path: exr.clone(), source })?;
        println!(
            "screenshot: {} and {} ({width}x{height}, {} spp{}, camera {})",
            path.display(),
            exr.display(),
            self.displayed.below,
            if self.showing_denoised { ", denoised" } else { "" },
            format_camera(&self.rig.camera())
        );
        Ok(())
    }

    /// The stats line of the title: samples per pixel, samples per frame, frame
    /// time, Mrays/s, backend and device.
    pub fn stats_line(&self) -> String {
        let ctx = self.renderer.context();
        let frame_ms = self.stats.median_frame_time(15).map_or(String::from("-"), |t| format!("{:.1}", t * 1e3));
        let per_frame = match self.band_rows {
            Some(rows) => format!("{rows} rows/frame"),
            None => format!("{} spp/frame", self.stats.frame_samples.last().copied().unwrap_or(0)),
        };
        let denoised = if self.showing_denoised { " (denoised)" } else { "" };
        format!(
            "{} spp{denoised} · {per_frame} · {frame_ms} ms/frame · {:.2} Mrays/s · {:?}: {}",
            self.displayed.below,
            self.stats.mrays_per_second(),
            ctx.backend(),
            ctx.device_name()
        )
    }
}
