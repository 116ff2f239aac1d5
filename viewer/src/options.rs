//! The viewer's command-line options, for renderers' own command lines
//! (`#[command(flatten)]`).

use std::path::PathBuf;
use std::time::Duration;

use raykit_denoise::DenoiseArgs;

use raykit_scene::Camera;

use crate::camera::parse_camera;
use crate::denoise::{DenoiseOptions, DEFAULT_EVERY};
use crate::error::{Result, ViewerError};
use crate::script::Script;
use crate::session::Session;
use crate::viewer::FrameOptions;

/// `--view`, `--headless` and what they take. `Default` is the command line's
/// default (no options).
#[derive(clap::Args, Clone, Debug)]
pub struct ViewerArgs {
    /// Open the interactive viewer: a window that refines the picture while the
    /// camera moves (drag, wheel, WASD/QE, Tab, R, F12/P, C, N, Esc).
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
    /// The frame time, in milliseconds (1 to 10000), the samples per frame adapt to.
    #[arg(long, default_value_t = DEFAULT_FRAME_MS, value_parser = parse_frame_ms, allow_hyphen_values = true)]
    pub frame_ms: f64,
    /// Stop adding samples at this many per pixel.
    #[arg(long)]
    pub max_spp: Option<u32>,
    /// Replay an input script in the window (see `raykit_viewer::script`).
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// With `--denoise`: denoise every N frames of one camera (so N frames after
    /// it stops), besides at `--max-spp` and for screenshots.
    #[arg(long, default_value_t = DEFAULT_EVERY, value_parser = clap::value_parser!(u32).range(1..))]
    pub denoise_every: u32,
}

impl Default for ViewerArgs {
    fn default() -> Self {
        ViewerArgs {
            view: false,
            headless: false,
            frames: None,
            camera: None,
            spp_per_frame: None,
            frame_ms: DEFAULT_FRAME_MS,
            max_spp: None,
            script: None,
            denoise_every: DEFAULT_EVERY,
        }
    }
}

/// `--frame-ms`'s default.
const DEFAULT_FRAME_MS: f64 = 33.0;

impl ViewerArgs {
    /// Whether the command line asks for the viewer (`--view` or `--headless`).
    pub fn wanted(&self) -> bool {
        self.view || self.headless
    }

    /// The camera `--camera` gives, else `default`.
    pub fn camera_or(&self, default: Camera) -> Result<Camera> {
        self.camera.as_deref().map_or(Ok(default), parse_camera)
    }

    /// The frame options these arguments ask for, with `exposure` and, when
    /// `denoise` asks for it (`--denoise`), the denoiser; a `frame_ms` outside
    /// [`FRAME_MS_RANGE`] (NaN included) is [`ViewerError::FrameTime`].
    pub fn frame_options(&self, exposure: f32, denoise: &DenoiseArgs) -> Result<FrameOptions> {
        let samples_per_frame = match (self.spp_per_frame, self.headless) {
            (Some(n), _) => Some(n.max(1)),
            (None, true) => Some(1),
            (None, false) => None,
        };
        let frame_ms = check_frame_ms(self.frame_ms, || self.frame_ms.to_string())?;
        Ok(FrameOptions {
            samples_per_frame,
            target_frame_time: Duration::from_secs_f64(frame_ms / 1e3),
            max_samples: self.max_spp,
            exposure,
            denoise: denoise.denoise.then_some(DenoiseOptions {
                device: denoise.denoise_device,
                guides: denoise.guides(),
                every: self.denoise_every,
            }),
        })
    }

    /// The input script `--script` names.
    pub fn script(&self) -> Result<Option<Script>> {
        self.script.as_deref().map(Script::from_file).transpose()
    }
}

/// The frame times, in milliseconds, that `--frame-ms` accepts.
pub const FRAME_MS_RANGE: std::ops::RangeInclusive<f64> = 1.0..=10_000.0;

/// `--frame-ms`'s parser: a number of milliseconds in [`FRAME_MS_RANGE`], else
/// [`ViewerError::FrameTime`] (NaN, infinities, negative, absurdly large).
pub fn parse_frame_ms(value: &str) -> Result<f64> {
    let frame_ms = value.trim().parse::<f64>().unwrap_or(f64::NAN);
    check_frame_ms(frame_ms, || value.to_owned())
}

/// `frame_ms` if it lies in [`FRAME_MS_RANGE`] (which NaN does not).
fn check_frame_ms(frame_ms: f64, value: impl FnOnce() -> String) -> Result<f64> {
    if FRAME_MS_RANGE.contains(&frame_ms) {
        Ok(frame_ms)
    } else {
        Err(ViewerError::FrameTime { value: value(), min: *FRAME_MS_RANGE.start(), max: *FRAME_MS_RANGE.end() })
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
    /// `--denoise` and its options.
    #[command(flatten)]
    pub denoise: DenoiseArgs,
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
            denoise: self.denoise.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> std::result::Result<ViewerCli, clap::Error> {
        <ViewerCli as clap::Parser>::try_parse_from(std::iter::once("viewer").chain(args.iter().copied()))
    }

    #[test]
    fn frame_times_outside_the_range_are_refused_naming_the_option_and_the_range() {
        for value in ["nan", "NaN", "inf", "-inf", "-5", "0", "0.5", "1e300", "10000.5", "fast", ""] {
            let err = parse(&["--frame-ms", value]).expect_err(value).to_string();
            assert!(err.contains("--frame-ms") && err.contains("from 1 to 10000"), "{value}: {err}");
        }
        for (value, ms) in [("1", 1.0), ("16.7", 16.7), ("10000", 10_000.0)] {
            let cli = parse(&["--frame-ms", value]).expect(value);
            let options = cli.viewer.frame_options(1.0, &DenoiseArgs::default()).expect(value);
            assert_eq!(options.target_frame_time, Duration::from_secs_f64(ms / 1e3), "{value}");
        }
        let default = parse(&[]).expect("no options");
        assert_eq!(
            default.viewer.frame_options(1.0, &DenoiseArgs::default()).expect("default").target_frame_time,
            Duration::from_millis(33)
        );
        assert_eq!(ViewerArgs::default().frame_ms, default.viewer.frame_ms);
    }

    #[test]
    fn frame_times_set_in_code_are_checked_too() {
        for frame_ms in [f64::NAN, f64::INFINITY, -1.0, 1e300] {
            let args = ViewerArgs { frame_ms, ..ViewerArgs::default() };
            let err = args.frame_options(1.0, &DenoiseArgs::default()).expect_err("refused");
            assert!(matches!(err, ViewerError::FrameTime { .. }), "{frame_ms}: {err}");
        }
    }
}
