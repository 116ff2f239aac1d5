//! The viewer's input API: what the keyboard and mouse do, as values a program
//! or a test can send too ([`crate::Viewer::input`]).

use std::path::PathBuf;

use raykit_scene::Camera;

use crate::camera::CameraMode;

/// One thing the user (or a script) does to the viewer.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewerInput {
    /// A mouse drag of `(dx, dy)` pixels with the left button: orbit, or look in fly mode.
    Drag {
        /// Pixels to the right.
        dx: f32,
        /// Pixels down.
        dy: f32,
    },
    /// Wheel steps (positive: towards the scene).
    Zoom(f32),
    /// The fly keys: W/S forward, D/A right, E/Q up, in scene units.
    Translate {
        /// Along the view.
        forward: f32,
        /// Across the view.
        right: f32,
        /// Along the up direction.
        up: f32,
    },
    /// Orbit or fly drags (`Tab` switches).
    Mode(CameraMode),
    /// Puts the camera somewhere.
    Camera(Camera),
    /// `R`: starts the accumulation over.
    Reset,
    /// `F12` or `P`: writes the displayed picture to this PNG, and the mean linear
    /// radiance to the same path with `.exr`.
    Screenshot(PathBuf),
    /// Resizes the window (the picture follows) to this inner size in pixels.
    Resize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
    /// Minimises (`true`) or restores the window.
    Minimize(bool),
    /// `N` (with `--denoise`): shows the denoised picture (`true`) or the noisy
    /// accumulation.
    ShowDenoised(bool),
    /// `C`: prints the camera as a `--camera` value.
    PrintCamera,
    /// Closes the viewer, also while a launch is running.
    Close,
}
