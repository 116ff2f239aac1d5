//! The window: winit's event loop (X11), the presenter, and the keyboard and
//! mouse turned into [`ViewerInput`]s.
//!
//! | input | does |
//! | --- | --- |
//! | left drag | orbit (fly mode: look around) |
//! | wheel | move closer or away (fly mode: forward) |
//! | W A S D, Q E | fly forward, left, back, right, down, up (Shift: four times as fast) |
//! | Tab | switch between orbit and fly |
//! | R | start the accumulation over |
//! | F12, P | screenshot: `viewer-N.png` and `viewer-N.exr` in the working directory |
//! | C | print the camera as a `--camera` value |
//! | Esc | close |

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use raykit_scene::Camera;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::camera::{format_camera, CameraMode};
use crate::error::{Result, ViewerError};
use crate::input::ViewerInput;
use crate::present::{Presented, Presenter};
use crate::render::Render;
use crate::script::Script;
use crate::stats::Stats;
use crate::viewer::{FrameOptions, Tick, Viewer};

/// How often the title's stats line changes.
const TITLE_PERIOD: Duration = Duration::from_millis(250);
/// How long the event loop sleeps while a launch runs before it polls it again.
const POLL_PERIOD: Duration = Duration::from_millis(1);

/// What to open.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// The title, before the stats line.
    pub title: String,
    /// Inner width in pixels.
    pub width: u32,
    /// Inner height in pixels.
    pub height: u32,
    /// The camera to start from.
    pub camera: Camera,
    /// Frames, samples per frame, exposure.
    pub frames: FrameOptions,
    /// Inputs to replay.
    pub script: Option<Script>,
    /// Close after this many displayed frames.
    pub frame_limit: Option<u64>,
}

/// What a viewer session ended with.
#[derive(Clone, Debug)]
pub struct Summary {
    /// Frames displayed.
    pub frames: u64,
    /// Frame times and throughput.
    pub stats: Stats,
    /// The camera at the end.
    pub camera: Camera,
    /// Samples per pixel displayed last.
    pub samples: u32,
    /// Width and height of the picture at the end.
    pub size: (u32, u32),
    /// What presented: `swapchain`, `softbuffer`, or `headless`.
    pub presenter: &'static str,
}

impl Summary {
    /// One line for the terminal: frames, the median frame time and samples per
    /// frame, Mrays/s.
    pub fn line(&self) -> String {
        let mut times = self.stats.frame_times.clone();
        times.sort_by(f64::total_cmp);
        let median = times.get(times.len() / 2).map_or(0.0, |t| t * 1e3);
        let mean_samples = self.stats.frame_samples.iter().map(|&s| s as f64).sum::<f64>()
            / self.stats.frame_samples.len().max(1) as f64;
        format!(
            "{} frames at {}x{} ({}), median frame time {median:.1} ms, {mean_samples:.1} spp/frame on average, \
             {} spp shown, {:.2} Mrays/s; camera {}",
            self.frames,
            self.size.0,
            self.size.1,
            self.presenter,
            self.samples,
            self.stats.mrays_per_second(),
            format_camera(&self.camera)
        )
    }
}

/// Opens a window on `renderer` and runs until it is closed (or the frame limit
/// or the script closes it). [`ViewerError::NoDisplay`] when there is no display,
/// naming `--headless`.
pub fn run<R: Render>(renderer: R, options: WindowOptions) -> Result<Summary> {
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        return Err(ViewerError::NoDisplay { reason: "DISPLAY is not set".into() });
    }
    let event_loop = EventLoop::new().map_err(|e| ViewerError::NoDisplay { reason: e.to_string() })?;
    let mut app = App {
        setup: Some((renderer, options.clone())),
        running: None,
        script: options.script.unwrap_or_default(),
        frame_limit: options.frame_limit,
        title: options.title,
        held: Vec::new(),
        shift: false,
        dragging: false,
        cursor: None,
        last_move: Instant::now(),
        title_at: Instant::now(),
        minimized: false,
        screenshots: 0,
        reloads_seen: 0,
        failed_reloads_seen: 0,
        close_when_launching: false,
        error: None,
        summary: None,
    };
    event_loop.run_app(&mut app).map_err(|e| ViewerError::Window(e.to_string()))?;
    app.finish();
    if let Some(e) = app.error {
        return Err(e);
    }
    app.summary.ok_or_else(|| ViewerError::Window("the event loop ended before the window opened".into()))
}

/// The open window.
struct Running<R: Render> {
    // Dropped in this order: the viewer (waits for its launch), the presenter
    // (its swapchain and surface), then the window.
    viewer: Viewer<R>,
    presenter: Presenter,
    window: Arc<Window>,
}

struct App<R: Render> {
    setup: Option<(R, WindowOptions)>,
    running: Option<Running<R>>,
    script: Script,
    frame_limit: Option<u64>,
    title: String,
    /// Fly keys held.
    held: Vec<KeyCode>,
    shift: bool,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    last_move: Instant,
    title_at: Instant,
    minimized: bool,
    screenshots: u32,
    /// Hot reloads the script has seen.
    reloads_seen: u64,
    /// Failed hot-reload builds the script has seen.
    failed_reloads_seen: u64,
    /// The script closes the window once the next launch is submitted.
    close_when_launching: bool,
    error: Option<ViewerError>,
    summary: Option<Summary>,
}

impl<R: Render> App<R> {
    /// Opens the window and makes the presenter and the viewer.
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let Some((renderer, options)) = self.setup.take() else { return Ok(()) };
        let attributes = Window::default_attributes()
            .with_title(&self.title)
            .with_inner_size(PhysicalSize::new(options.width.max(1), options.height.max(1)));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| ViewerError::Window(e.to_string()))?);
        let (presenter, format) = Presenter::new(renderer.context(), window.clone())?;
        let size = window.inner_size();
        let (width, height) =
            if size.width > 0 && size.height > 0 { (size.width, size.height) } else { (options.width, options.height) };
        let viewer = Viewer::new(renderer, options.camera, width, height, format, options.frames)?;
        println!(
            "viewer: {}x{} on {:?} ({}), presenting through {}",
            width,
            height,
            viewer.renderer().context().backend(),
            viewer.renderer().context().device_name(),
            presenter.name()
        );
        self.running = Some(Running { viewer, presenter, window });
        // The script's first inputs come before the first launch.
        self.run_script(event_loop)?;
        Ok(())
    }

    /// Sends the script's inputs that are due.
    fn run_script(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        for input in self.script.due() {
            if input == ViewerInput::Close {
                // Closing while a launch runs is what the script tests.
                self.close_when_launching = true;
                continue;
            }
            self.send(event_loop, input)?;
        }
        Ok(())
    }

    /// Sends one input to the viewer or the window.
    fn send(&mut self, event_loop: &ActiveEventLoop, input: ViewerInput) -> Result<()> {
        let Some(running) = &mut self.running else { return Ok(()) };
        match input {
            ViewerInput::Resize { width, height } => {
                let _ = running.window.request_inner_size(PhysicalSize::new(width.max(1), height.max(1)));
            }
            ViewerInput::Minimize(minimized) => {
                running.window.set_minimized(minimized);
                self.minimized = minimized;
                running.viewer.set_paused(minimized);
            }
            ViewerInput::Close => self.close(event_loop),
            other => running.viewer.input(other)?,
        }
        Ok(())
    }

    /// Closes the window, also while a launch runs (dropping the viewer waits for it).
    fn close(&mut self, event_loop: &ActiveEventLoop) {
        self.finish();
        event_loop.exit();
    }

    /// Records the summary and drops the window.
    fn finish(&mut self) {
        if let Some(mut running) = self.running.take() {
            match running.viewer.summary(running.presenter.name()) {
                Ok(summary) => self.summary = Some(summary),
                Err(e) => {
                    self.error.get_or_insert(e);
                }
            }
        }
    }

    /// Fly keys held: moves the camera by the time since the last move.
    fn fly(&mut self) -> Result<()> {
        let dt = self.last_move.elapsed().as_secs_f32().min(0.25);
        self.last_move = Instant::now();
        let Some(running) = &mut self.running else { return Ok(()) };
        if self.held.is_empty() {
            return Ok(());
        }
        let axis = |plus: KeyCode, minus: KeyCode| {
            (self.held.contains(&plus) as i32 - self.held.contains(&minus) as i32) as f32
        };
        let step = running.viewer.rig().fly_speed() * dt * if self.shift { 4.0 } else { 1.0 };
        let (forward, right, up) = (
            axis(KeyCode::KeyW, KeyCode::KeyS),
            axis(KeyCode::KeyD, KeyCode::KeyA),
            axis(KeyCode::KeyE, KeyCode::KeyQ),
        );
        if (forward, right, up) != (0.0, 0.0, 0.0) {
            running.viewer.input(ViewerInput::Translate {
                forward: forward * step,
                right: right * step,
                up: up * step,
            })?;
        }
        Ok(())
    }

    /// Ticks the viewer until a launch is running or there is nothing to do,
    /// presenting each finished frame; returns the last tick.
    fn render(&mut self, event_loop: &ActiveEventLoop) -> Result<Tick> {
        loop {
            let Some(running) = &mut self.running else { return Ok(Tick::Idle) };
            let tick = running.viewer.tick()?;
            let (reloads, failed_reloads) = (running.viewer.reloads(), running.viewer.failed_reloads());
            let launching = running.viewer.is_launching();
            if reloads > self.reloads_seen {
                self.reloads_seen = reloads;
                self.script.reloaded();
                self.run_script(event_loop)?;
            }
            if failed_reloads > self.failed_reloads_seen {
                self.failed_reloads_seen = failed_reloads;
                self.script.reload_failed();
                self.run_script(event_loop)?;
            }
            if tick != Tick::Displayed {
                if self.close_when_launching && (launching || tick == Tick::Idle) {
                    println!(
                        "viewer: closing {}",
                        if launching { "while a launch runs" } else { "with nothing running" }
                    );
                    self.close(event_loop);
                }
                return Ok(tick);
            }
            self.show(event_loop)?;
        }
    }

    /// Presents the frame the viewer just displayed, refreshes the title and
    /// runs the script's steps that were waiting for it.
    fn show(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let Some(running) = &mut self.running else { return Ok(()) };
        if !self.minimized {
            if let Presented::Resize(width, height) = running.presenter.present(running.viewer.display())? {
                running.viewer.resize(width, height)?;
            }
        }
        if self.title_at.elapsed() >= TITLE_PERIOD {
            running.window.set_title(&format!("{} — {}", self.title, running.viewer.stats_line()));
            self.title_at = Instant::now();
        }
        let frames = running.viewer.frames();
        self.script.frame_displayed();
        self.run_script(event_loop)?;
        if self.frame_limit.is_some_and(|limit| frames >= limit) {
            self.close(event_loop);
        }
        Ok(())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, code: KeyCode, pressed: bool) -> Result<()> {
        let fly_key = matches!(
            code,
            KeyCode::KeyW | KeyCode::KeyA | KeyCode::KeyS | KeyCode::KeyD | KeyCode::KeyQ | KeyCode::KeyE
        );
        if fly_key {
            self.held.retain(|k| *k != code);
            if pressed {
                self.held.push(code);
                self.last_move = Instant::now();
            }
            return Ok(());
        }
        if !pressed {
            return Ok(());
        }
        let input = match code {
            KeyCode::KeyR => ViewerInput::Reset,
            KeyCode::F12 | KeyCode::KeyP => {
                self.screenshots += 1;
                ViewerInput::Screenshot(PathBuf::from(format!("viewer-{}.png", self.screenshots)))
            }
            KeyCode::KeyC => ViewerInput::PrintCamera,
            KeyCode::KeyN => {
                let Some(running) = &self.running else { return Ok(()) };
                let Some(denoised) = running.viewer.shows_denoised() else {
                    println!("viewer: N toggles the denoised picture; start the viewer with --denoise");
                    return Ok(());
                };
                println!("viewer: {} picture", if denoised { "noisy" } else { "denoised" });
                ViewerInput::ShowDenoised(!denoised)
            }
            KeyCode::Tab => {
                let mode = match self.running.as_ref().map(|r| r.viewer.rig().mode) {
                    Some(CameraMode::Orbit) => CameraMode::Fly,
                    _ => CameraMode::Orbit,
                };
                println!("viewer: {mode:?} camera");
                ViewerInput::Mode(mode)
            }
            KeyCode::Escape => ViewerInput::Close,
            _ => return Ok(()),
        };
        self.send(event_loop, input)
    }

    fn event(&mut self, event_loop: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => self.close(event_loop),
            WindowEvent::Resized(size) => {
                let Some(running) = &mut self.running else { return Ok(()) };
                running.presenter.resized();
                if size.width == 0 || size.height == 0 {
                    running.viewer.set_paused(true);
                } else {
                    running.viewer.set_paused(self.minimized);
                    running.viewer.resize(size.width, size.height)?;
                }
            }
            WindowEvent::Occluded(occluded) => {
                if let Some(running) = &mut self.running {
                    running.viewer.set_paused(occluded || self.minimized);
                }
            }
            WindowEvent::ModifiersChanged(modifiers) => self.shift = modifiers.state().shift_key(),
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    if !event.repeat {
                        self.key(event_loop, code, event.state == ElementState::Pressed)?;
                    }
                }
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.dragging = state == ElementState::Pressed;
            }
            WindowEvent::CursorMoved { position, .. } => {
                let now = (position.x, position.y);
                if let (true, Some(before)) = (self.dragging, self.cursor) {
                    let input = ViewerInput::Drag { dx: (now.0 - before.0) as f32, dy: (now.1 - before.1) as f32 };
                    self.send(event_loop, input)?;
                }
                self.cursor = Some(now);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.send(event_loop, ViewerInput::Zoom(steps))?;
            }
            _ => {}
        }
        Ok(())
    }

    /// Keeps the first error and ends the event loop with it.
    fn fail(&mut self, event_loop: &ActiveEventLoop, result: Result<()>) {
        if let Err(e) = result {
            if self.error.is_none() {
                self.error = Some(e);
            }
            self.finish();
            event_loop.exit();
        }
    }
}

impl<R: Render> ApplicationHandler for App<R> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let opened = self.open(event_loop);
        self.fail(event_loop, opened);
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _window: WindowId, event: WindowEvent) {
        let handled = self.event(event_loop, event);
        self.fail(event_loop, handled);
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let flown = self.fly();
        self.fail(event_loop, flown);
        match self.render(event_loop) {
            Err(e) => self.fail(event_loop, Err(e)),
            Ok(tick) => {
                let flying = !self.held.is_empty();
                event_loop.set_control_flow(match tick {
                    Tick::Working | Tick::Displayed => ControlFlow::WaitUntil(Instant::now() + POLL_PERIOD),
                    Tick::Idle if flying => ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(16)),
                    Tick::Idle => ControlFlow::Wait,
                });
            }
        }
    }
}
