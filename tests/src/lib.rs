//! Shared harness of raykit's integration tests.
//!
//! [`with_context`] creates a [`Context`] with the Khronos validation layer on
//! (when `RAYKIT_VALIDATION=1`, as `cargo xtask test` sets it), runs the test,
//! destroys the context and fails if the layer said anything — during the test or
//! at destruction, where it reports Vulkan objects left alive (the debug messenger
//! is destroyed after the device for this reason). It also fails when the context
//! could not be destroyed because a raykit object still holds it (leaked with
//! `std::mem::forget`, or kept past the test). Without a ray-tracing device the
//! test fails when `RAYKIT_REQUIRE_DEVICE=1` (CI and `cargo xtask test`), and
//! otherwise prints a loud SKIPPED line.

use raykit::{Context, ContextOptions, Error, PipelineCacheLocation};

/// Runs `test` with a fresh context; checks the validation log afterwards. The
/// context's disk compile cache is off: tests never touch the user's cache.
pub fn with_context(name: &str, test: impl FnOnce(&Context) -> anyhow::Result<()>) -> anyhow::Result<()> {
    with_context_options(
        name,
        ContextOptions { pipeline_cache: PipelineCacheLocation::Off, ..Default::default() },
        test,
    )
}

/// [`with_context`] with `options` (validation as `RAYKIT_VALIDATION` says).
pub fn with_context_options(
    name: &str,
    options: ContextOptions,
    test: impl FnOnce(&Context) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let validation = std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1");
    run(name, ContextOptions { validation: Some(validation), ..options }, test)
}

/// [`with_context`] with validation on or off whatever the environment says.
pub fn with_context_validation(
    name: &str,
    validation: bool,
    test: impl FnOnce(&Context) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    run(
        name,
        ContextOptions {
            validation: Some(validation),
            pipeline_cache: PipelineCacheLocation::Off,
            ..Default::default()
        },
        test,
    )
}

fn run(name: &str, options: ContextOptions, test: impl FnOnce(&Context) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let ctx = match Context::new(options) {
        Ok(ctx) => ctx,
        Err(e @ (Error::NoRayTracingDevice { .. } | Error::LoaderMissing(_))) => {
            if std::env::var("RAYKIT_REQUIRE_DEVICE").is_ok_and(|v| v == "1") {
                anyhow::bail!("{name}: RAYKIT_REQUIRE_DEVICE=1 and no usable device: {e}");
            }
            eprintln!(
                "SKIPPED {name}: no ray-tracing device ({e}); set RAYKIT_REQUIRE_DEVICE=1 to make this a failure"
            );
            return Ok(());
        }
        Err(e) => return Err(e.into()),
    };
    let log = ctx.messages();
    let result = test(&ctx);
    drop(ctx);
    let destroyed = log.context_destroyed();
    let messages = log.take();
    result?;
    if !destroyed {
        anyhow::bail!(
            "{name}: the context was not destroyed at the end of the test: a raykit object still holds it \
             (leaked with std::mem::forget, kept in a static or past the test, or in a reference cycle)"
        );
    }
    if !messages.is_empty() {
        let text: Vec<String> = messages.iter().map(|m| m.to_string()).collect();
        anyhow::bail!("{name}: {} validation message(s):\n{}", messages.len(), text.join("\n"));
    }
    Ok(())
}

/// Unpacks RGBA8 into `[r, g, b, a]`.
pub fn rgba(pixel: u32) -> [u8; 4] {
    pixel.to_le_bytes()
}

/// Largest per-channel difference between two RGBA8 pixels.
pub fn channel_distance(a: u32, b: u32) -> u8 {
    rgba(a).iter().zip(rgba(b)).map(|(x, y)| x.abs_diff(y)).max().unwrap_or(0)
}

/// A fresh, empty directory under the system's temp dir for test `name`; removed
/// when the returned guard drops.
pub fn temp_dir(name: &str) -> anyhow::Result<TempDir> {
    let path = std::env::temp_dir().join(format!("raykit-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&path);
    std::fs::create_dir_all(&path)?;
    Ok(TempDir(path))
}

/// A directory removed on drop.
pub struct TempDir(pub std::path::PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Möller–Trumbore, the CPU references' ray–triangle test: `(t, (u, v))` of the
/// hit of the ray with `tri` for `t` in `(t_min, t_max)`, with OptiX's
/// barycentric convention (hit = (1-u-v)·v0 + u·v1 + v·v2).
pub fn ray_triangle(
    origin: raykit::glam::Vec3,
    dir: raykit::glam::Vec3,
    tri: [raykit::glam::Vec3; 3],
    t_min: f32,
    t_max: f32,
) -> Option<(f32, raykit::glam::Vec2)> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = origin - tri[0];
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > t_min && t < t_max).then_some((t, raykit::glam::Vec2::new(u, v)))
}
