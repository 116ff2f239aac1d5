//! The viewer's window on a real display (Xvfb under `cargo xtask test`): a
//! scripted camera move through the input API, frames, a screenshot that equals
//! the `--headless` render of the same camera and samples bit for bit (on
//! lavapipe and on the CPU backend); resizing to 1×1 and back, minimising and
//! closing while a launch runs without a crash or a validation message; and hot
//! reload of a copied device crate: a broken edit prints rustc's message once
//! while the window goes on with the old programs, then a good edit reaches it.
#![cfg(feature = "viewer")]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Generous: debug builds on a loaded 2-core machine.
const RUN_BOUND: Duration = Duration::from_secs(300);
/// A rebuild of the copied device crate may compile it from scratch.
const RELOAD_BOUND: Duration = Duration::from_secs(600);

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;

/// Whether a display is there; without one the test fails when
/// `RAYKIT_REQUIRE_DISPLAY=1` (as `cargo xtask test` sets, with Xvfb started) and
/// says it skips otherwise.
fn display(test: &str) -> anyhow::Result<bool> {
    if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
        return Ok(true);
    }
    anyhow::ensure!(
        std::env::var("RAYKIT_REQUIRE_DISPLAY").as_deref() != Ok("1"),
        "{test}: no DISPLAY, and RAYKIT_REQUIRE_DISPLAY=1; run `cargo xtask test` (it starts Xvfb) or set DISPLAY"
    );
    eprintln!("{test}: SKIPPED: no DISPLAY (`cargo xtask test` starts Xvfb for these tests)");
    Ok(false)
}

/// A fresh directory for one test's files.
fn scratch(test: &str) -> anyhow::Result<PathBuf> {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH)?.as_nanos();
    let dir = std::env::temp_dir().join(format!("raykit-viewer-{test}-{}-{nanos}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn path_tracer() -> Command {
    Command::new(env!("CARGO_BIN_EXE_path_tracer"))
}

/// Runs `cmd` to its end within `bound`, and fails with its output unless it succeeded.
fn run(mut cmd: Command, bound: Duration) -> anyhow::Result<Output> {
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn()?;
    let started = Instant::now();
    while child.try_wait()?.is_none() {
        if started.elapsed() > bound {
            child.kill()?;
            let out = child.wait_with_output()?;
            anyhow::bail!("{cmd:?} ran past {bound:?}:\n{}", text(&out));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output()?;
    anyhow::ensure!(out.status.success(), "{cmd:?} failed ({}):\n{}", out.status, text(&out));
    Ok(out)
}

fn text(out: &Output) -> String {
    format!("stdout:\n{}\nstderr:\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// The camera a `screenshot:` line of the viewer printed.
fn screenshot_camera(stdout: &str) -> anyhow::Result<String> {
    let line = stdout.lines().find(|l| l.starts_with("screenshot:")).ok_or(anyhow::anyhow!("no screenshot line"))?;
    let camera = line.split("camera ").nth(1).and_then(|c| c.strip_suffix(')'));
    Ok(camera.ok_or(anyhow::anyhow!("no camera in {line:?}"))?.to_owned())
}

fn rgba(path: &Path) -> anyhow::Result<image::RgbaImage> {
    Ok(image::open(path)?.to_rgba8())
}

fn size_args(cmd: &mut Command, backend: &str) {
    cmd.args(["--width", &WIDTH.to_string(), "--height", &HEIGHT.to_string(), "--backend", backend]);
}

/// The scripted window's screenshot and the headless render of its camera.
fn window_equals_headless(test: &str, backend: &str) -> anyhow::Result<()> {
    if !display(test)? {
        return Ok(());
    }
    let dir = scratch(test)?;
    let (window_png, headless_png, default_png) =
        (dir.join("window.png"), dir.join("headless.png"), dir.join("default.png"));
    let script = dir.join("move.txt");
    std::fs::write(
        &script,
        format!(
            "drag 90 -35\nzoom 1.5\nfly-mode\nmove 40 -25 10\nframes 6\nscreenshot {}\nclose\n",
            window_png.display()
        ),
    )?;
    let mut window = path_tracer();
    size_args(&mut window, backend);
    window.args(["--view", "--spp-per-frame", "2", "--script"]).arg(&script);
    let out = run(window, RUN_BOUND)?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(&format!("({WIDTH}x{HEIGHT}, 12 spp, camera ")), "{}", text(&out));
    let camera = screenshot_camera(&stdout)?;

    let headless = |camera: Option<&str>, png: &Path| -> anyhow::Result<()> {
        let mut cmd = path_tracer();
        size_args(&mut cmd, backend);
        cmd.args(["--headless", "--frames", "6", "--spp-per-frame", "2", "-o"]).arg(png);
        if let Some(camera) = camera {
            cmd.args(["--camera", camera]);
        }
        run(cmd, RUN_BOUND).map(|_| ())
    };
    headless(Some(&camera), &headless_png)?;
    headless(None, &default_png)?;

    let (shown, rendered, unmoved) = (rgba(&window_png)?, rgba(&headless_png)?, rgba(&default_png)?);
    assert_eq!(shown.dimensions(), (WIDTH, HEIGHT));
    assert!(shown.as_raw() == rendered.as_raw(), "{test}: the window's picture differs from the headless render");
    let exr = |png: &Path| std::fs::read(png.with_extension("exr"));
    assert!(exr(&window_png)? == exr(&headless_png)?, "{test}: the radiance differs from the headless render");
    let moved = shown.pixels().zip(unmoved.pixels()).filter(|(a, b)| a != b).count();
    assert!(moved > (WIDTH * HEIGHT / 4) as usize, "{test}: the scripted move changed only {moved} pixels");
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

#[test]
fn the_window_on_vulkan_shows_the_headless_render_of_its_camera() -> anyhow::Result<()> {
    window_equals_headless("window_vulkan", "vulkan")
}

#[test]
fn the_window_on_the_cpu_backend_shows_the_headless_render_of_its_camera() -> anyhow::Result<()> {
    window_equals_headless("window_cpu", "cpu")
}

/// `--denoise` in the window: after 6 frames of 2 paths, denoised every 3
/// frames with guides, the window's screenshot equals a `--headless --denoise`
/// render of the same frames byte for byte (PNG and radiance); `noisy` (the `N`
/// key) shows the noisy accumulation, which equals the headless render without
/// `--denoise`; the two differ.
fn denoised_window_equals_headless(test: &str, backend: &str) -> anyhow::Result<()> {
    if !display(test)? {
        return Ok(());
    }
    let dir = scratch(test)?;
    let (denoised_png, noisy_png) = (dir.join("denoised.png"), dir.join("noisy.png"));
    let (headless_denoised, headless_noisy) = (dir.join("headless-denoised.png"), dir.join("headless-noisy.png"));
    let script = dir.join("denoise.txt");
    std::fs::write(
        &script,
        format!("frames 6\nscreenshot {}\nnoisy\nscreenshot {}\nclose\n", denoised_png.display(), noisy_png.display()),
    )?;
    const DENOISE: [&str; 5] = ["--denoise", "--denoise-device", "cpu", "--denoise-every", "3"];
    let mut window = path_tracer();
    size_args(&mut window, backend);
    window.args(["--view", "--spp-per-frame", "2", "--max-spp", "12"]).args(DENOISE).arg("--script").arg(&script);
    let out = run(window, RUN_BOUND)?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("albedo and normal guides"), "{test}: {}", text(&out));
    assert!(stdout.contains(&format!("({WIDTH}x{HEIGHT}, 12 spp, denoised, camera ")), "{test}: {}", text(&out));
    assert!(stdout.contains(&format!("({WIDTH}x{HEIGHT}, 12 spp, camera ")), "{test}: {}", text(&out));

    let headless = |denoise: bool, png: &Path| -> anyhow::Result<()> {
        let mut cmd = path_tracer();
        size_args(&mut cmd, backend);
        cmd.args(["--headless", "--frames", "6", "--spp-per-frame", "2", "-o"]).arg(png);
        if denoise {
            cmd.args(DENOISE);
        }
        run(cmd, RUN_BOUND).map(|_| ())
    };
    headless(true, &headless_denoised)?;
    headless(false, &headless_noisy)?;
    let exr = |png: &Path| std::fs::read(png.with_extension("exr"));
    for (shown, rendered, what) in
        [(&denoised_png, &headless_denoised, "denoised"), (&noisy_png, &headless_noisy, "noisy")]
    {
        assert!(
            rgba(shown)?.as_raw() == rgba(rendered)?.as_raw(),
            "{test}: the window's {what} picture differs from the headless render"
        );
        assert!(exr(shown)? == exr(rendered)?, "{test}: the window's {what} radiance differs from the headless render");
    }
    let (denoised, noisy) = (rgba(&denoised_png)?, rgba(&noisy_png)?);
    let changed = denoised.pixels().zip(noisy.pixels()).filter(|(a, b)| a != b).count();
    assert!(changed > (WIDTH * HEIGHT / 2) as usize, "{test}: denoising changed only {changed} pixels");
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

#[test]
fn the_denoised_window_on_vulkan_shows_the_headless_denoised_render() -> anyhow::Result<()> {
    denoised_window_equals_headless("denoise_vulkan", "vulkan")
}

#[test]
fn the_denoised_window_on_the_cpu_backend_shows_the_headless_denoised_render() -> anyhow::Result<()> {
    denoised_window_equals_headless("denoise_cpu", "cpu")
}

/// Resizes to 1×1 and back, minimises, restores, and closes while a launch runs.
fn resize_minimise_close(test: &str, backend: &str) -> anyhow::Result<()> {
    if !display(test)? {
        return Ok(());
    }
    let dir = scratch(test)?;
    let png = dir.join("after.png");
    let script = dir.join("resize.txt");
    std::fs::write(
        &script,
        format!(
            "frames 2\nresize 1 1\nframes 3\nresize 96 64\nframes 3\nminimize\nrestore\nframes 2\nscreenshot {}\n\
             close\n",
            png.display()
        ),
    )?;
    let mut window = path_tracer();
    size_args(&mut window, backend);
    // Validation on: the viewer fails on any message, leaks at destruction included.
    window.env("RAYKIT_VALIDATION", "1").args(["--view", "--script"]).arg(&script);
    let out = run(window, RUN_BOUND)?;
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("viewer: closing while a launch runs"), "{}", text(&out));
    assert!(!stderr.contains("validation:"), "{}", text(&out));
    assert_eq!(rgba(&png)?.dimensions(), (96, 64), "the picture follows the window back from 1x1");
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

#[test]
fn resizing_to_one_pixel_minimising_and_closing_mid_launch_on_vulkan_are_clean() -> anyhow::Result<()> {
    resize_minimise_close("resize_vulkan", "vulkan")
}

#[test]
fn resizing_to_one_pixel_minimising_and_closing_mid_launch_on_the_cpu_backend_are_clean() -> anyhow::Result<()> {
    resize_minimise_close("resize_cpu", "cpu")
}

/// The path tracer's device crate, copied to `to` as a crate of its own.
fn copy_device_crate(to: &Path) -> anyhow::Result<()> {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = here.join("..").join("..").canonicalize()?;
    std::fs::create_dir_all(to.join("src"))?;
    for entry in std::fs::read_dir(here.join("device").join("src"))? {
        let entry = entry?;
        std::fs::copy(entry.path(), to.join("src").join(entry.file_name()))?;
    }
    std::fs::write(
        to.join("Cargo.toml"),
        format!(
            "[package]\nname = \"path-tracer-device\"\nversion = \"0.1.0\"\nedition = \"2021\"\npublish = false\n\n\
             [dependencies]\nraykit-device = {{ path = \"{}\" }}\nbytemuck = {{ version = \"1.23\", features = [\"derive\"] }}\n\n\
             [lints.rust]\nunexpected_cfgs = {{ level = \"warn\", check-cfg = ['cfg(target_arch, values(\"spirv\"))'] }}\n",
            root.join("device").display()
        ),
    )?;
    // The workspace's versions of every dependency, so the build reuses its artifacts.
    std::fs::copy(root.join("Cargo.lock"), to.join("Cargo.lock"))?;
    Ok(())
}

/// Mean red and green of a picture.
fn mean_red_green(image: &image::RgbaImage) -> (f64, f64) {
    let n = image.pixels().len() as f64;
    let (r, g) = image.pixels().fold((0.0, 0.0), |(r, g), p| (r + p[0] as f64, g + p[1] as f64));
    (r / n, g / n)
}

/// Waits, within `bound` of `started`, until `path` exists, failing if the viewer ends first.
fn wait_for_file(
    child: &mut std::process::Child,
    path: &Path,
    started: Instant,
    bound: Duration,
) -> anyhow::Result<()> {
    while !path.exists() {
        anyhow::ensure!(child.try_wait()?.is_none(), "the viewer ended before writing {}", path.display());
        if started.elapsed() > bound {
            child.kill()?;
            anyhow::bail!("no {} within {bound:?}", path.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

/// `error` with what the viewer printed: it is stopped first, so that its pipes end.
fn with_viewer_output(
    error: anyhow::Error,
    child: &mut std::process::Child,
    stdout: std::thread::JoinHandle<Vec<String>>,
    stderr: std::thread::JoinHandle<Vec<String>>,
) -> anyhow::Error {
    let _ = child.kill();
    let _ = child.wait();
    let (out, err) = (stdout.join().unwrap_or_default().join("\n"), stderr.join().unwrap_or_default().join("\n"));
    error.context(format!("the viewer's stdout:\n{out}\nits stderr:\n{err}"))
}

/// Reads a child's pipe to its end on a thread of its own, line by line.
fn collect_lines(pipe: impl std::io::Read + Send + 'static) -> std::thread::JoinHandle<Vec<String>> {
    std::thread::spawn(move || BufReader::new(pipe).lines().map_while(Result::ok).collect())
}

/// The samples per pixel of the screenshot `png` that the viewer's stdout reports.
fn screenshot_samples(stdout: &str, png: &Path) -> anyhow::Result<u32> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(&format!("screenshot: {} ", png.display())))
        .ok_or(anyhow::anyhow!("no screenshot line for {}", png.display()))?;
    let spp = line.split(" spp").next().and_then(|l| l.rsplit(' ').next()).and_then(|n| n.parse().ok());
    spp.ok_or(anyhow::anyhow!("no samples in {line:?}"))
}

#[test]
fn a_broken_edit_keeps_the_old_pipeline_and_a_good_edit_then_reaches_the_window() -> anyhow::Result<()> {
    let test = "hot_reload_window";
    if !display(test)? {
        return Ok(());
    }
    let dir = scratch(test)?;
    let device = dir.join("device");
    copy_device_crate(&device)?;
    let (before, kept, after) = (dir.join("before.png"), dir.join("kept.png"), dir.join("after.png"));
    let script = dir.join("reload.txt");
    std::fs::write(
        &script,
        format!(
            "frames 2\nscreenshot {}\nwait-reload-error\nframes 3\nscreenshot {}\nwait-reload\nframes 2\n\
             screenshot {}\nclose\n",
            before.display(),
            kept.display(),
            after.display()
        ),
    )?;
    let mut window = path_tracer();
    window
        .args(["--width", "32", "--height", "32", "--view", "--spp-per-frame", "4"])
        .args(["--watch", "--device-dir"])
        .arg(&device)
        .arg("--script")
        .arg(&script)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = window.spawn()?;
    let stdout = collect_lines(child.stdout.take().ok_or(anyhow::anyhow!("no stdout"))?);
    let stderr = collect_lines(child.stderr.take().ok_or(anyhow::anyhow!("no stderr"))?);
    let started = Instant::now();
    if let Err(e) = wait_for_file(&mut child, &before, started, RUN_BOUND) {
        return Err(with_viewer_output(e, &mut child, stdout, stderr));
    }
    // A type error: the build fails, the window keeps the programs it has.
    let lib = device.join("src").join("lib.rs");
    let source = std::fs::read_to_string(&lib)?;
    std::fs::write(&lib, format!("{source}\nconst WRONG: u32 = 1.5;\n"))?;
    if let Err(e) = wait_for_file(&mut child, &kept, started, RELOAD_BOUND) {
        return Err(with_viewer_output(e, &mut child, stdout, stderr));
    }
    // A colour edit: the radiance of every path is tinted red.
    let line = "        sums.radiance += state.radiance;\n";
    assert!(source.contains(line), "the raygen program's accumulation line changed");
    std::fs::write(
        &lib,
        source.replace(line, "        sums.radiance += state.radiance * Vec3::new(1.0, 0.2, 0.2);\n"),
    )?;
    while child.try_wait()?.is_none() {
        if started.elapsed() > RELOAD_BOUND {
            child.kill()?;
            anyhow::bail!("the reload did not reach the window within {RELOAD_BOUND:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let status = child.wait()?;
    let stdout = stdout.join().unwrap_or_default().join("\n");
    let stderr = stderr.join().unwrap_or_default().join("\n");
    anyhow::ensure!(status.success(), "{stdout}\n{stderr}");

    // rustc's message, once, in the terminal; frames went on with the old picture.
    assert_eq!(stderr.matches("keeping the previous pipeline").count(), 1, "{stderr}");
    assert_eq!(stderr.matches("error[E0308]").count(), 1, "rustc's message is not printed once:\n{stderr}");
    assert!(stderr.contains("const WRONG: u32 = 1.5;"), "{stderr}");
    let (spp_before, spp_kept) = (screenshot_samples(&stdout, &before)?, screenshot_samples(&stdout, &kept)?);
    assert!(spp_kept >= spp_before + 12, "frames stopped after the failed build: {spp_before} then {spp_kept} spp");
    let old = dir.join("old-programs.png");
    let mut headless = path_tracer();
    headless.args(["--width", "32", "--height", "32", "--headless", "--spp-per-frame", "4", "--frames"]);
    headless.arg((spp_kept / 4).to_string()).arg("-o").arg(&old);
    run(headless, RUN_BOUND)?;
    assert!(
        rgba(&kept)?.as_raw() == rgba(&old)?.as_raw(),
        "after the failed build the window shows something other than the old programs' {spp_kept} spp"
    );

    // The good edit landed.
    assert!(stdout.contains("reloaded in"), "{stdout}");
    let (r0, g0) = mean_red_green(&rgba(&before)?);
    let (r1, g1) = mean_red_green(&rgba(&after)?);
    assert!(
        g1 / r1 < 0.8 * (g0 / r0),
        "green/red went from {:.3} to {:.3}: the edit did not reach the window",
        g0 / r0,
        g1 / r1
    );
    // A rebuild the watcher started (the build rewrites the copied Cargo.lock) may
    // still be writing the crate's target directory for a moment.
    remove_when_quiet(&dir);
    Ok(())
}

/// Removes `dir`, retrying while another process still writes into it; says so
/// if it cannot (a temporary directory left behind is not the test's subject).
fn remove_when_quiet(dir: &Path) {
    for _ in 0..30 {
        if std::fs::remove_dir_all(dir).is_ok() || !dir.exists() {
            return;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    eprintln!("left {} behind: something still writes into it", dir.display());
}

#[test]
fn without_a_display_the_viewer_says_so_and_names_headless() -> anyhow::Result<()> {
    let mut cmd = path_tracer();
    cmd.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY").args(["--view", "--backend", "cpu"]);
    let out = cmd.output()?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{}", text(&out));
    assert!(stderr.contains("no display to open a window on (DISPLAY is not set)"), "{stderr}");
    assert!(stderr.contains("--headless --frames N"), "{stderr}");
    Ok(())
}
