//! The viewer's errors: each names what went wrong and what to do.

use std::path::PathBuf;

/// An error the renderer behind the viewer reported (any error type).
pub type RenderError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// What can go wrong in the viewer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewerError {
    /// No window system to open a window on.
    #[error(
        "no display to open a window on ({reason}); set DISPLAY to a running X server (e.g. `Xvfb :99 &` and \
         DISPLAY=:99), or render without a window: `--headless --frames N [--camera ...] -o FILE.png`"
    )]
    NoDisplay {
        /// Why: no `DISPLAY`, or what the window system said.
        reason: String,
    },
    /// The window system refused a window or its event loop.
    #[error("the window system failed: {0}")]
    Window(String),
    /// The Vulkan device cannot present to the window.
    #[error(
        "the Vulkan device cannot present to this window: {0}; use a driver with VK_KHR_swapchain and X11 \
         surfaces (Mesa's lavapipe has both), or run with the CPU backend (`--backend cpu`)"
    )]
    Presentation(String),
    /// A Vulkan call of the presentation failed.
    #[error("{call} failed: {result}")]
    Vulkan {
        /// The call.
        call: &'static str,
        /// What it returned.
        result: raykit::ash::vk::Result,
    },
    /// Presenting through softbuffer (the CPU backend's windows) failed.
    #[error("softbuffer: {0}")]
    Softbuffer(String),
    /// raykit refused or failed (the display pass, a buffer, a launch).
    #[error(transparent)]
    Raykit(#[from] raykit::Error),
    /// The denoiser could not be loaded or failed (its message says what to do).
    #[error("denoising: {0}")]
    Denoise(#[from] raykit_denoise::Error),
    /// The renderer behind the viewer failed.
    #[error("the renderer failed: {0}")]
    Render(RenderError),
    /// A `--camera` value that is not ten numbers.
    #[error(
        "--camera {value:?}: {reason}; give ten comma-separated numbers: eye x,y,z, look-at x,y,z, up x,y,z and \
         the vertical field of view in degrees (the viewer prints the current camera this way on `C` and at exit)"
    )]
    Camera {
        /// The value given.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A `--frame-ms` value that is not a frame time the viewer can aim at.
    #[error(
        "--frame-ms {value}: give the frame time the samples per frame adapt to, in milliseconds: a number from \
         {min} to {max}"
    )]
    FrameTime {
        /// The value given.
        value: String,
        /// The shortest frame time accepted, in milliseconds.
        min: f64,
        /// The longest frame time accepted, in milliseconds.
        max: f64,
    },
    /// `--headless` without `--frames`.
    #[error("--headless renders a number of frames and writes the last: give it `--frames N`")]
    HeadlessFrames,
    /// A line of an input script that the viewer does not understand.
    #[error("input script line {line}: {reason} (in {text:?}); see `raykit_viewer::script` for the commands")]
    Script {
        /// Line number, from 1.
        line: usize,
        /// The line.
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Reading a file (an input script).
    #[error("reading {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Making the directory of a screenshot.
    #[error("creating the directory {path}: {source}")]
    Directory {
        /// The directory.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Writing a screenshot.
    #[error("writing the screenshot {path}: {source}")]
    Screenshot {
        /// The file.
        path: PathBuf,
        /// The error.
        source: raykit_scene::ImageError,
    },
}

impl ViewerError {
    /// A failed Vulkan call of the presentation.
    pub(crate) fn vk(call: &'static str) -> impl FnOnce(raykit::ash::vk::Result) -> ViewerError {
        move |result| ViewerError::Vulkan { call, result }
    }
}

/// The viewer's result type.
pub type Result<T, E = ViewerError> = std::result::Result<T, E>;
