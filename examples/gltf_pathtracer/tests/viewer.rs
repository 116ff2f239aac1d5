//! `gltf_pathtracer --view` on a real display (Xvfb under `cargo xtask test`): a
//! generated glTF scene, a scripted orbit, frames and a screenshot equal bit for
//! bit to the `--headless` render of the same camera and samples.

use std::path::Path;
use std::process::{Command, Output};

fn text(out: &Output) -> String {
    format!("stdout:\n{}\nstderr:\n{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

fn run(cmd: &mut Command) -> anyhow::Result<Output> {
    let out = cmd.output()?;
    anyhow::ensure!(out.status.success(), "{cmd:?} failed ({}):\n{}", out.status, text(&out));
    Ok(out)
}

fn gltf_pathtracer(scene: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gltf_pathtracer"));
    cmd.arg("--scene").arg(scene).args(["--width", "40", "--height", "30", "--spp-per-frame", "1"]);
    cmd
}

#[test]
fn the_window_shows_the_headless_render_of_its_camera() -> anyhow::Result<()> {
    if std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
        anyhow::ensure!(
            std::env::var("RAYKIT_REQUIRE_DISPLAY").as_deref() != Ok("1"),
            "no DISPLAY, and RAYKIT_REQUIRE_DISPLAY=1; run `cargo xtask test` (it starts Xvfb) or set DISPLAY"
        );
        eprintln!("SKIPPED: no DISPLAY (`cargo xtask test` starts Xvfb for this test)");
        return Ok(());
    }
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH)?.as_nanos();
    let dir = std::env::temp_dir().join(format!("raykit-gltf-viewer-{}-{nanos}", std::process::id()));
    let scene = gltf_pathtracer::demo_scene::write_grid(&dir, 4)?;
    let (window_png, headless_png) = (dir.join("window.png"), dir.join("headless.png"));
    let script = dir.join("orbit.txt");
    std::fs::write(&script, format!("drag -60 25\nframes 3\nscreenshot {}\nclose\n", window_png.display()))?;
    let out = run(gltf_pathtracer(&scene).arg("--view").arg("--script").arg(&script))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout.lines().find(|l| l.starts_with("screenshot:")).ok_or(anyhow::anyhow!("{}", text(&out)))?;
    assert!(line.contains("(40x30, 3 spp, camera "), "{line}");
    let camera = line.split("camera ").nth(1).and_then(|c| c.strip_suffix(')')).ok_or(anyhow::anyhow!("{line}"))?;
    run(gltf_pathtracer(&scene).args(["--headless", "--frames", "3", "--camera", camera, "-o"]).arg(&headless_png))?;
    assert!(std::fs::read(&window_png)? == std::fs::read(&headless_png)?, "the window differs from --headless");
    let exr = |png: &Path| std::fs::read(png.with_extension("exr"));
    assert!(exr(&window_png)? == exr(&headless_png)?, "the radiance differs from --headless");
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}
