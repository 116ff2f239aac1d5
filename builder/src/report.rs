//! Where the builder's messages go: a terminal (xtask) or cargo (build.rs).

use std::process::{Command, Stdio};

/// How the builder reports progress.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Report {
    /// Print `raykit-builder: ...` lines on stdout (an xtask, a terminal).
    Terminal,
    /// Speak to cargo from a build script: notable events as `cargo:warning=`,
    /// progress on stderr (shown with `cargo build -vv`), and the output of the
    /// commands run sent to stderr so it cannot be read as cargo directives.
    BuildScript,
    /// Print nothing but errors.
    Quiet,
}

impl Report {
    /// Something the user should see (a toolchain install, a long build).
    pub(crate) fn notable(self, message: &str) {
        match self {
            Report::Terminal => println!("raykit-builder: {message}"),
            Report::BuildScript => println!("cargo:warning=raykit: {message}"),
            Report::Quiet => {}
        }
    }

    /// Routine progress.
    pub(crate) fn progress(self, message: &str) {
        match self {
            Report::Terminal => println!("raykit-builder: {message}"),
            Report::BuildScript => eprintln!("raykit-builder: {message}"),
            Report::Quiet => {}
        }
    }

    /// Prepares a child process's stdout for this kind of report.
    pub(crate) fn route(self, cmd: &mut Command) {
        match self {
            Report::Terminal => {}
            Report::BuildScript => {
                cmd.stdout(Stdio::from(std::io::stderr()));
            }
            Report::Quiet => {
                cmd.stdout(Stdio::null());
            }
        }
    }
}
