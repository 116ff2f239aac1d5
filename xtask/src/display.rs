//! A virtual X display for the viewer's window tests: Xvfb (Debian's `xvfb`) and
//! the X client libraries winit opens at run time, installed as root with apt like
//! the other system parts; Xvfb is started for the test run on a free display
//! number and stopped afterwards.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _};

/// How long Xvfb may take to open its socket.
const START_TIMEOUT: Duration = Duration::from_secs(20);

/// Xvfb and the libraries winit's X11 backend loads (Xlib, its XCB bridge,
/// Xcursor, XRandR, XInput 2, XRender, xkbcommon's X11 part), as Debian packages.
const PACKAGES: [&str; 7] =
    ["xvfb", "libx11-xcb1", "libxcursor1", "libxrandr2", "libxi6", "libxrender1", "libxkbcommon-x11-0"];

/// Whether dpkg has `package` installed.
fn installed(package: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", package])
        .output()
        .is_ok_and(|out| out.status.success() && String::from_utf8_lossy(&out.stdout).ends_with("installed"))
}

/// Makes sure Xvfb and winit's X11 libraries are installed (as root with apt,
/// else the command to run).
pub fn ensure_xvfb() -> anyhow::Result<()> {
    let missing = || -> Vec<&str> { PACKAGES.into_iter().filter(|package| !installed(package)).collect() };
    let absent = missing();
    if absent.is_empty() {
        return Ok(());
    }
    if !(crate::setup::is_root() && Path::new("/usr/bin/apt-get").exists()) {
        bail!(
            "the viewer's tests open windows on Xvfb, and {} are not installed. On Debian, as root: \
             apt-get install -y {}",
            absent.join(", "),
            absent.join(" ")
        );
    }
    println!("xtask: installing {} for the viewer's window tests", absent.join(" "));
    let mut install = vec!["install", "-y"];
    install.extend(&absent);
    if crate::setup::apt_get(&install).is_err() {
        crate::setup::apt_get(&["update"])?;
        crate::setup::apt_get(&install)?;
    }
    let still = missing();
    if !still.is_empty() {
        bail!("installed {} but {} still missing", absent.join(" "), still.join(", "));
    }
    Ok(())
}

/// A running Xvfb; stopped when dropped.
pub struct VirtualDisplay {
    child: Child,
    /// The `DISPLAY` value, e.g. `:99`.
    pub display: String,
}

impl VirtualDisplay {
    /// Starts Xvfb on the first display number from 99 whose lock file is free
    /// (other test runs on the machine may hold some) and waits for its socket.
    pub fn start() -> anyhow::Result<VirtualDisplay> {
        for number in 99..199 {
            if Path::new(&format!("/tmp/.X{number}-lock")).exists() {
                continue;
            }
            let display = format!(":{number}");
            let mut child = Command::new("/usr/bin/Xvfb")
                .args([&display, "-screen", "0", "1920x1080x24", "-nolisten", "tcp"])
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .context("starting Xvfb")?;
            let socket = format!("/tmp/.X11-unix/X{number}");
            let started = Instant::now();
            loop {
                if let Some(status) = child.try_wait()? {
                    // Another run took this number first: try the next.
                    println!("xtask: Xvfb {display} exited ({status}); trying the next display");
                    break;
                }
                if Path::new(&socket).exists() {
                    println!("xtask: Xvfb on DISPLAY={display} for the window tests");
                    return Ok(VirtualDisplay { child, display });
                }
                if started.elapsed() > START_TIMEOUT {
                    let _ = child.kill();
                    let _ = child.wait();
                    bail!("Xvfb {display} did not open {socket} within {START_TIMEOUT:?}");
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        bail!("no free X display number between :99 and :198 for Xvfb")
    }
}

impl Drop for VirtualDisplay {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
