//! Input scripts (`--script FILE`): what a test or a demo does in the window,
//! replayed through the input API, one command a line (`#` starts a comment):
//!
//! | command | does |
//! | --- | --- |
//! | `drag DX DY` | a left-button drag of DX, DY pixels (orbit, or look in fly mode) |
//! | `zoom STEPS` | wheel steps |
//! | `move FORWARD RIGHT UP` | the fly keys, in scene units |
//! | `orbit-mode`, `fly-mode` | the camera mode |
//! | `camera E,E,E,L,L,L,U,U,U,FOV` | puts the camera there (the `--camera` form) |
//! | `reset` | starts the accumulation over |
//! | `frames N` | waits until N more frames are displayed |
//! | `wait-reload` | waits until hot reload has swapped in new device programs |
//! | `wait-reload-error` | waits until a hot-reload build has failed (the old programs keep rendering) |
//! | `screenshot FILE.png` | writes the picture (and `FILE.exr`) |
//! | `resize W H` | resizes the window |
//! | `minimize`, `restore` | minimises or restores the window |
//! | `print-camera` | prints the camera as a `--camera` value |
//! | `denoised`, `noisy` | with `--denoise`: shows the denoised picture, or the noisy one (the `N` key) |
//! | `close` | closes the viewer once the next launch is submitted, so while it runs |
//!
//! After its last line the script has nothing more to do and the viewer stays open
//! (unless the last line closed it).

use std::path::{Path, PathBuf};

use crate::camera::{parse_camera, CameraMode};
use crate::error::{Result, ViewerError};
use crate::input::ViewerInput;

/// One step of a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Sent at once.
    Input(ViewerInput),
    /// Waits for this many more displayed frames.
    Frames(u32),
    /// Waits for the next hot reload.
    WaitReload,
    /// Waits for the next hot-reload build that fails.
    WaitReloadError,
}

/// A parsed input script, replayed step by step.
#[derive(Clone, Debug, Default)]
pub struct Script {
    steps: Vec<Step>,
    next: usize,
    /// Frames still to wait for before the next step.
    waiting: u32,
    /// Whether the next step waits for a hot reload.
    waiting_reload: bool,
    /// Whether the next step waits for a failed hot-reload build.
    waiting_reload_error: bool,
}

impl Script {
    /// Reads and parses a script file.
    pub fn from_file(path: &Path) -> Result<Script> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ViewerError::Read { path: path.to_path_buf(), source })?;
        Script::parse(&text)
    }

    /// Parses a script's text.
    pub fn parse(text: &str) -> Result<Script> {
        let mut steps = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let error = |reason: String| ViewerError::Script { line: index + 1, text: raw.to_owned(), reason };
            let mut words = line.split_whitespace();
            let command = words.next().unwrap_or("");
            let args: Vec<&str> = words.collect();
            let numbers = |count: usize| -> Result<Vec<f32>> {
                if args.len() != count {
                    return Err(error(format!("`{command}` takes {count} number(s), got {}", args.len())));
                }
                args.iter()
                    .map(|a| a.parse::<f32>().ok().filter(|n| n.is_finite()))
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| error(format!("`{command}` takes finite numbers")))
            };
            let whole = |count: usize| -> Result<Vec<u32>> {
                if args.len() != count {
                    return Err(error(format!("`{command}` takes {count} whole number(s), got {}", args.len())));
                }
                args.iter()
                    .map(|a| a.parse::<u32>().ok())
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| error(format!("`{command}` takes whole numbers")))
            };
            let bare = |input: ViewerInput| -> Result<Step> {
                if !args.is_empty() {
                    return Err(error(format!("`{command}` takes nothing after it")));
                }
                Ok(Step::Input(input))
            };
            let step = match command {
                "drag" => numbers(2).map(|n| Step::Input(ViewerInput::Drag { dx: n[0], dy: n[1] }))?,
                "zoom" => numbers(1).map(|n| Step::Input(ViewerInput::Zoom(n[0])))?,
                "move" => {
                    numbers(3).map(|n| Step::Input(ViewerInput::Translate { forward: n[0], right: n[1], up: n[2] }))?
                }
                "orbit-mode" => bare(ViewerInput::Mode(CameraMode::Orbit))?,
                "fly-mode" => bare(ViewerInput::Mode(CameraMode::Fly))?,
                "camera" => match args[..] {
                    [value] => Step::Input(ViewerInput::Camera(parse_camera(value).map_err(|e| error(e.to_string()))?)),
                    _ => return Err(error("`camera` takes one value of ten comma-separated numbers".into())),
                },
                "reset" => bare(ViewerInput::Reset)?,
                "frames" => whole(1).map(|n| Step::Frames(n[0]))?,
                "wait-reload" | "wait-reload-error" => {
                    if !args.is_empty() {
                        return Err(error(format!("`{command}` takes nothing after it")));
                    }
                    if command == "wait-reload" {
                        Step::WaitReload
                    } else {
                        Step::WaitReloadError
                    }
                }
                "screenshot" => match args[..] {
                    [path] => Step::Input(ViewerInput::Screenshot(PathBuf::from(path))),
                    _ => return Err(error("`screenshot` takes one file name".into())),
                },
                "resize" => whole(2).map(|n| Step::Input(ViewerInput::Resize { width: n[0], height: n[1] }))?,
                "minimize" => bare(ViewerInput::Minimize(true))?,
                "restore" => bare(ViewerInput::Minimize(false))?,
                "print-camera" => bare(ViewerInput::PrintCamera)?,
                "denoised" => bare(ViewerInput::ShowDenoised(true))?,
                "noisy" => bare(ViewerInput::ShowDenoised(false))?,
                "close" => bare(ViewerInput::Close)?,
                other => return Err(error(format!("unknown command `{other}`"))),
            };
            steps.push(step);
        }
        Ok(Script { steps, next: 0, waiting: 0, waiting_reload: false, waiting_reload_error: false })
    }

    /// The steps.
    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    /// Whether every step has run.
    pub fn is_done(&self) -> bool {
        self.next == self.steps.len() && !self.is_waiting()
    }

    /// Whether a wait has not passed yet.
    fn is_waiting(&self) -> bool {
        self.waiting > 0 || self.waiting_reload || self.waiting_reload_error
    }

    /// Counts one displayed frame.
    pub fn frame_displayed(&mut self) {
        self.waiting = self.waiting.saturating_sub(1);
    }

    /// Counts one hot reload.
    pub fn reloaded(&mut self) {
        self.waiting_reload = false;
    }

    /// Counts one failed hot-reload build.
    pub fn reload_failed(&mut self) {
        self.waiting_reload_error = false;
    }

    /// The inputs to send now: the steps up to the next wait that has not passed.
    pub fn due(&mut self) -> Vec<ViewerInput> {
        let mut due = Vec::new();
        while !self.is_waiting() && self.next < self.steps.len() {
            match &self.steps[self.next] {
                Step::Input(input) => due.push(input.clone()),
                Step::Frames(n) => self.waiting = *n,
                Step::WaitReload => self.waiting_reload = true,
                Step::WaitReloadError => self.waiting_reload_error = true,
            }
            self.next += 1;
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_script_runs_its_inputs_between_its_waits() {
        let mut script =
            Script::parse("drag 10 -2 # turn\n\nzoom 1.5\nframes 2\nwait-reload\nscreenshot a.png\nclose\n").unwrap();
        assert_eq!(script.due(), [ViewerInput::Drag { dx: 10.0, dy: -2.0 }, ViewerInput::Zoom(1.5)]);
        assert!(script.due().is_empty());
        script.frame_displayed();
        assert!(script.due().is_empty());
        script.frame_displayed();
        assert!(script.due().is_empty(), "waits for a reload");
        script.frame_displayed();
        assert!(script.due().is_empty(), "frames do not end the wait for a reload");
        script.reloaded();
        assert_eq!(script.due(), [ViewerInput::Screenshot("a.png".into()), ViewerInput::Close]);
        assert!(script.is_done());
    }

    #[test]
    fn a_wait_for_a_failed_reload_ends_on_a_failure_only() {
        let mut script = Script::parse(
            "wait-reload-error
reset
",
        )
        .unwrap();
        assert!(script.due().is_empty());
        script.reloaded();
        assert!(script.due().is_empty(), "a reload that worked is not a failure");
        script.reload_failed();
        assert_eq!(script.due(), [ViewerInput::Reset]);
        assert!(script.is_done());
        let message = Script::parse("wait-reload-error now").unwrap_err().to_string();
        assert!(message.contains("`wait-reload-error` takes nothing after it"), "{message}");
    }

    #[test]
    fn bad_lines_name_the_line_and_the_problem() {
        for (text, expected) in [
            ("drag 1", "line 1: `drag` takes 2 number(s), got 1"),
            ("\nfly 1", "line 2: unknown command `fly`"),
            ("frames -1", "whole numbers"),
            ("zoom inf", "finite numbers"),
            ("reset now", "takes nothing"),
            ("camera 1,2", "2 numbers"),
        ] {
            let message = Script::parse(text).unwrap_err().to_string();
            assert!(message.contains(expected), "{text:?}: {message}");
        }
    }
}
