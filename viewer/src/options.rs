//! The viewer's command-line options, for renderers' own command lines
//! (`#[command(flatten)]`).

use std::path::PathBuf;
use std::time::Duration;

use raykit_scene::Camera;

use crate::camera::parse_camera;
use crate::error::Result;
use crate::script::Script;
use crate::session::Session;
use crate::viewer::FrameOptions;

/// `--view`, `--headless` and what they take.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct ViewerArgs {
    /// Open the interactive viewer: a window that refines the picture while the
    /// camera moves (drag, wheel, WASD/QE, Tab, R, F12/P, C, Esc).
    #[arg(long)]
    pub view: bool,
    /// Render what the viewer's window would show without a window: `--frames`
    /// frames from `--camera`, then the picture to the output file.
    #[arg(long, conflicts_with = "view")]
    pub headless: bool,
    /// Frames to render: in `--headless`, before the picture is written; in the
    /// window, after which it closes.
    #[arg(long)]
    pub frames: Option<u64>,
    /// The camera: eye x,y,z, look-at x,y,z, up x,y,z, vertical field of view in
    /// degrees (the viewer prints it on `C`, after a screenshot and at exit).
    #[arg(long, allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Samples per pixel of every frame (default: adapt to --frame-ms in the
    /// window, 1 in --headless). Fix it to make the window and --headless agree.
    #[arg(long)]
    pub spp_per_frame: Option<u32>,
    /// The frame time, in milliseconds, the samples per frame adapt to.
    #[arg(long, default_value_t = 33.0)]
    pub frame_ms: f64,
    /// Stop adding samples at this many per pixel.
    #[arg(long)]
    pub max_spp: Option<u32>,
    /// Replay an input script in the window (see `raykit_viewer::script`).
    #[arg(long)]
    pub script: Option<PathBuf>,
}

impl ViewerArgs {
    /// Whether the command line asks for the viewer (`--view` or `--headless`).
    pub fn wanted(&self) -> bool {
        self.view || self.headless
    }

    /// The camera `--camera` gives, else `default`.
    pub fn camera_or(&self, default: Camera) -> Result<Camera> {
        self.camera.as_deref().map_or(Ok(default), parse_camera)
    }

    /// The frame options these arguments ask for, with `exposure`.
    pub fn frame_options(&self, exposure: f32) -> FrameOptions {
        let samples_per_frame = match (self.spp_per_frame, self.headless) {
            (Some(n), _) => Some(n.max(1)),
            (None, true) => Some(1),
            (None, false) => None,
        };
        FrameOptions {
            samples_per_frame,
            target_frame_time: Duration::from_secs_f64((self.frame_ms / 1e3).clamp(1e-3, 10.0)),
            max_samples: self.max_spp,
            exposure,
        }
    }

    /// The input script `--script` names.
    pub fn script(&self) -> Result<Option<Script>> {
        self.script.as_deref().map(Script::from_file).transpose()
    }
}

/// A whole command line for a program whose only options are the viewer's: the
/// [`ViewerArgs`], the picture's size and `--headless`'s output file (the
/// new-project template's `--view`).
#[derive(clap::Parser, Clone, Debug)]
#[command(about = "raykit's interactive viewer (--view) or what its window would show (--headless --frames N)")]
pub struct ViewerCli {
    /// The viewer's options.
    #[command(flatten)]
    pub viewer: ViewerArgs,
    /// Width of the picture (the window's inner width) in pixels.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(1..))]
    pub width: u32,
    /// Height of the picture in pixels.
    #[arg(long, default_value_t = 480, value_parser = clap::value_parser!(u32).range(1..))]
    pub height: u32,
    /// Where `--headless` writes the picture (PNG; the mean radiance goes beside it as `.exr`).
    #[arg(long, short, default_value = "viewer.png")]
    pub output: PathBuf,
}

impl ViewerCli {
    /// The program's command line; on a bad one, prints what is wrong (or the
    /// help for `--help`) and exits, as command lines do.
    pub fn from_env() -> ViewerCli {
        <ViewerCli as clap::Parser>::parse()
    }

    /// The session these options describe, titled `title`, starting from `camera`
    /// unless `--camera` gives one.
    pub fn session(&self, title: &str, camera: Camera) -> Session {
        Session {
            title: title.to_owned(),
            width: self.width,
            height: self.height,
            camera,
            exposure: 1.0,
            output: self.output.clone(),
        }
    }
}
