//! # raykit-viewer
//!
//! An interactive viewer for raykit renderers, as every OptiX SDK sample has one:
//! a window (winit, X11) that refines the picture while the camera moves, on
//! Vulkan and on the CPU backend alike.
//!
//! A renderer implements [`Render`]: a progressive accumulation buffer it launches
//! into a few samples at a time ([`raykit::Pipeline::launch_async`]), aimed with a
//! [`raykit_scene::Camera`]. The [`Viewer`] keeps one launch in flight, so input is
//! never blocked behind a long one, and adapts the samples per frame to a target
//! frame time. Each finished launch goes through the display pass
//! ([`display::DisplayPass`], a raykit raygen program: mean, exposure, Reinhard,
//! sRGB, packed in the window's byte order) into a device-local pixel buffer, which
//! the [`present`]er copies into a swapchain image on raykit's own device, or
//! hands to softbuffer on the CPU backend.
//!
//! [`window::run`] opens the window; [`headless::run`] renders the same frames
//! without one; [`run`] does whichever the command line's [`ViewerArgs`] ask for
//! (`--view` or `--headless`), so a program's viewer is a [`Render`] and one call.
//! [`script`]s replay inputs through [`ViewerInput`] for tests and demos. With
//! `--denoise` the window shows the accumulation denoised by Open Image Denoise
//! ([`denoise`]), guided by the renderer's albedo and normals when it writes them.
#![deny(missing_docs)]

pub mod camera;
pub mod denoise;
pub mod display;
pub mod error;
pub mod headless;
pub mod input;
pub mod options;
pub mod present;
pub mod render;
pub mod script;
pub mod session;
pub mod stats;
pub mod viewer;
pub mod window;

pub use camera::{format_camera, parse_camera, CameraMode, CameraRig};
pub use denoise::DenoiseOptions;
pub use error::{RenderError, Result, ViewerError};
pub use input::ViewerInput;
pub use options::{ViewerArgs, ViewerCli};
pub use render::{DenoiseGuides, Render};
pub use script::Script;
pub use session::{run, Session};
pub use stats::Stats;
pub use viewer::{FrameOptions, Tick, Viewer};
pub use window::{Summary, WindowOptions};
