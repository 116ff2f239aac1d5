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

pub mod gltf_fixture;
pub mod own_project;

use raykit::{Backend, Context, ContextOptions, Error, PipelineCacheLocation};

/// Runs `test` with a fresh context; checks the validation log afterwards. The
/// context's disk compile cache is off: tests never touch the user's cache.
pub fn with_context(name: &str, test: impl FnOnce(&Context) -> anyhow::Result<()>) -> anyhow::Result<()> {
    with_context_options(
        name,
        ContextOptions { pipeline_cache: PipelineCacheLocation::Off, ..Default::default() },
        test,
    )
}

/// Runs `test` once on each backend: on a Vulkan context as [`with_context`]
/// does, then on a CPU-backend context (see `raykit::cpu`). `RAYKIT_TEST_BACKENDS`
/// (`vulkan`, `cpu`, or both, comma-separated; both by default) limits the runs,
/// for running the suite on a machine without one of them. The test gets the
/// context and the backend it is on.
pub fn with_each_backend(name: &str, test: impl Fn(&Context, Backend) -> anyhow::Result<()>) -> anyhow::Result<()> {
    for backend in test_backends()? {
        let options = ContextOptions { backend: Some(backend), ..test_options() };
        let label = format!("{name} [{backend:?}]");
        run(&label, options, |ctx| {
            anyhow::ensure!(ctx.backend() == backend, "{label}: made a {:?} context", ctx.backend());
            test(ctx, backend).map_err(|e| e.context(label.clone()))
        })?;
    }
    Ok(())
}

/// The error variant of `err` as `Enum::Variant` (`Sbt::Incomplete`), read
/// from its `Debug` form.
pub fn variant_name(err: &raykit::Error) -> String {
    let text = format!("{err:?}");
    let ident = |s: &str| s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect::<String>();
    let outer = ident(&text);
    match text[outer.len()..].strip_prefix('(') {
        Some(rest) => format!("{outer}::{}", ident(rest)),
        None => outer,
    }
}

/// Notes that the bad-input case `case` was refused on `backend` with `err`,
/// and for a case of one backend only, `why`: one line
/// `variant<TAB>backend<TAB>case<TAB>why` appended to the file
/// `RAYKIT_REFUSAL_LOG` names, when it is set (`cargo xtask refusals` reads it).
pub fn note_refusal(case: &str, backend: Backend, err: &raykit::Error, why: &str) {
    let Ok(path) = std::env::var("RAYKIT_REFUSAL_LOG") else { return };
    let line = format!("{}\t{backend:?}\t{case}\t{why}\n", variant_name(err));
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .and_then(|mut f| std::io::Write::write_all(&mut f, line.as_bytes()));
    if let Err(e) = written {
        panic!("RAYKIT_REFUSAL_LOG {path}: {e}");
    }
}

/// The backends [`with_each_backend`] runs on: `RAYKIT_TEST_BACKENDS`, else both.
pub fn test_backends() -> anyhow::Result<Vec<Backend>> {
    let Ok(list) = std::env::var("RAYKIT_TEST_BACKENDS") else { return Ok(vec![Backend::Vulkan, Backend::Cpu]) };
    list.split(',')
        .map(|b| match b.trim() {
            "vulkan" => Ok(Backend::Vulkan),
            "cpu" => Ok(Backend::Cpu),
            other => anyhow::bail!("RAYKIT_TEST_BACKENDS: unknown backend {other:?} (vulkan, cpu)"),
        })
        .collect()
}

/// Runs `test` with one fresh context per entry of `options` (contexts of one
/// device share it, as contexts do), then destroys them and checks each one's
/// validation log as [`with_context`] does. Without a ray-tracing device it
/// fails or skips loudly as [`with_context`] does.
pub fn with_contexts(
    name: &str,
    options: Vec<ContextOptions>,
    test: impl FnOnce(&[Context]) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut contexts = Vec::with_capacity(options.len());
    for options in options {
        let Some(ctx) = context_or_skip(name, options)? else { return Ok(()) };
        contexts.push(ctx);
    }
    let logs: Vec<raykit::MessageLog> = contexts.iter().map(Context::messages).collect();
    let result = test(&contexts);
    drop(contexts);
    let mut problems = Vec::new();
    for (i, log) in logs.iter().enumerate() {
        if !log.context_destroyed() {
            problems
                .push(format!("context {i} was not destroyed at the end of the test: a raykit object still holds it"));
        }
        problems.extend(log.take().iter().map(|m| format!("context {i}: validation message: {m}")));
    }
    result?;
    anyhow::ensure!(problems.is_empty(), "{name}: {}", problems.join("\n"));
    Ok(())
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

/// A context made with `options`, or `None` (after a loud SKIPPED line) when there
/// is no ray-tracing device and `RAYKIT_REQUIRE_DEVICE` is not `1`.
pub fn context_or_skip(name: &str, options: ContextOptions) -> anyhow::Result<Option<Context>> {
    match Context::new(options) {
        Ok(ctx) => Ok(Some(ctx)),
        Err(
            e @ (Error::Device(raykit::DeviceError::NoRayTracingDevice { .. })
            | Error::Device(raykit::DeviceError::LoaderMissing(_))),
        ) => {
            if std::env::var("RAYKIT_REQUIRE_DEVICE").is_ok_and(|v| v == "1") {
                anyhow::bail!("{name}: RAYKIT_REQUIRE_DEVICE=1 and no usable device: {e}");
            }
            eprintln!(
                "SKIPPED {name}: no ray-tracing device ({e}); set RAYKIT_REQUIRE_DEVICE=1 to make this a failure"
            );
            Ok(None)
        }
        Err(e) => Err(e.into()),
    }
}

/// The options tests use: validation as `RAYKIT_VALIDATION` says, no disk cache.
pub fn test_options() -> ContextOptions {
    ContextOptions {
        validation: Some(validation_on()),
        pipeline_cache: PipelineCacheLocation::Off,
        ..Default::default()
    }
}

/// Whether `RAYKIT_VALIDATION=1` (as `cargo xtask test` sets it).
pub fn validation_on() -> bool {
    std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1")
}

/// Makes the validation layer report an error naming an object of `ctx` called
/// `name`: a buffer made without `SHADER_DEVICE_ADDRESS` usage (and without memory)
/// is asked for its device address. Only with validation on, where the layer stops
/// the invalid call before the driver; returns whether it did anything.
pub fn provoke_validation_error(ctx: &Context, name: &str) -> anyhow::Result<bool> {
    use raykit::ash::vk;
    if !validation_on() {
        return Ok(false);
    }
    let device = ctx.raw_device().expect("a Vulkan context");
    let info = vk::BufferCreateInfo::default().size(256).usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: a valid create info on the context's live device.
    let buffer = unsafe { device.create_buffer(&info, None) }?;
    ctx.set_debug_name(buffer, name);
    // SAFETY: invalid on purpose (VUID-VkBufferDeviceAddressInfo-buffer-02601): the
    // validation layer is on, reports it and does not pass the call to the driver.
    let _ = unsafe { device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer)) };
    // SAFETY: the buffer was made above and never used.
    unsafe { device.destroy_buffer(buffer, None) };
    Ok(true)
}

/// Whether `message` names an object called `name`.
pub fn names_object(message: &raykit::ValidationMessage, name: &str) -> bool {
    message.objects.iter().any(|o| o.name.as_deref() == Some(name))
}

fn run(name: &str, options: ContextOptions, test: impl FnOnce(&Context) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let Some(ctx) = context_or_skip(name, options)? else { return Ok(()) };
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

/// Distance of the barycentrics of the ray's hit with `tri`'s plane from the
/// triangle's edges (negative outside).
fn edge_margin(origin: raykit::glam::Vec3, dir: raykit::glam::Vec3, tri: [raykit::glam::Vec3; 3]) -> f32 {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    let s = origin - tri[0];
    let u = s.dot(p) / det;
    let v = dir.dot(s.cross(e1)) / det;
    u.min(v).min(1.0 - u - v)
}

/// Checks an optixTriangle picture (`triangle::render`) against the CPU reference
/// of the same scene: the barycentric colour inside the triangle (99.5% of its
/// pixels within 2/255), exactly the miss record's colour outside (rays grazing an
/// edge may go either way).
pub fn check_triangle_picture(pixels: &[u32], width: u32, height: u32) -> anyhow::Result<()> {
    use raykit::glam::UVec2;
    use triangle::{BG_COLOR, VERTICES};
    use triangle_device::{barycentric_color, camera_ray, make_color, Params};
    anyhow::ensure!(pixels.len() == (width * height) as usize, "{} pixels for {width}x{height}", pixels.len());
    let params: Params =
        triangle::params(width, height, raykit::Buffer::from_table_index(0), raykit::Traversable::NULL);
    let bg = make_color(BG_COLOR);
    let (mut bg_pixels, mut tri_pixels, mut tri_close) = (0usize, 0usize, 0usize);
    let mut bg_wrong = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let got = pixels[(y * width + x) as usize];
            let (origin, dir) = camera_ray(UVec2::new(x, y), UVec2::new(width, height), &params);
            match ray_triangle(origin, dir, VERTICES, 0.0, f32::INFINITY) {
                Some((_, bary)) => {
                    tri_pixels += 1;
                    if channel_distance(got, make_color(barycentric_color(bary))) <= 2 {
                        tri_close += 1;
                    }
                }
                None => {
                    if edge_margin(origin, dir, VERTICES) < -1e-3 {
                        bg_pixels += 1;
                        if got != bg {
                            bg_wrong.push((x, y, got));
                        }
                    }
                }
            }
        }
    }
    let total = (width * height) as usize;
    anyhow::ensure!(tri_pixels > total / 10, "the triangle covers only {tri_pixels} of {total} pixels");
    anyhow::ensure!(bg_pixels > total / 10, "only {bg_pixels} background pixels");
    anyhow::ensure!(
        bg_wrong.is_empty(),
        "{} background pixels differ from bg_color {bg:#010x}, e.g. {:?}",
        bg_wrong.len(),
        &bg_wrong[..bg_wrong.len().min(5)]
    );
    let ratio = tri_close as f64 / tri_pixels as f64;
    anyhow::ensure!(
        ratio >= 0.995,
        "only {tri_close} of {tri_pixels} triangle pixels ({:.3}%) within 2/255",
        ratio * 100.0
    );
    Ok(())
}
