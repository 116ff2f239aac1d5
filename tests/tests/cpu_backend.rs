//! What only the CPU backend does: device programs that print and panic as
//! ordinary Rust, and contexts that need no Vulkan driver.
//!
//! The tests that need a process of their own (to read its output, or to hide
//! every Vulkan driver from it) run this test binary again with
//! `RAYKIT_CPU_CHILD` set to their name.

use std::process::Command;

use accel_test_device::{pixel_position, ColorData, Params};
use raykit::glam::{UVec2, Vec2, Vec3};
use raykit::{
    Backend, Context, ContextOptions, Error, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt,
    Specialization, Traversable,
};

const W: u32 = 32;
const H: u32 = 24;
const TRIANGLE: [Vec3; 3] = [Vec3::new(-0.8, -0.6, 0.0), Vec3::new(0.8, -0.6, 0.0), Vec3::new(0.0, 0.7, 0.0)];
const HIT: Vec3 = Vec3::new(1.0, 0.0, 0.0);
const BG: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// The environment variable naming the child test to run.
const CHILD: &str = "RAYKIT_CPU_CHILD";

fn params(scene: Traversable, image: raykit::Buffer<u32>) -> Params {
    Params { image, width: W, height: H, _pad: 0, x0: -1.0, y0: -1.0, x1: 1.0, y1: 1.0, scene }
}

/// Whether the ray of pixel `(x, y)` hits [`TRIANGLE`] (orthographic, along -z).
fn covers(x: u32, y: u32) -> bool {
    let p = pixel_position(UVec2::new(x, y), &params(Traversable::NULL, raykit::Buffer::from_table_index(0)));
    let [a, b, c] = TRIANGLE.map(|v| v.truncate());
    let side = |u: Vec2, v: Vec2| (v - u).perp_dot(p - u);
    let (s0, s1, s2) = (side(a, b), side(b, c), side(c, a));
    (s0 > 0.0 && s1 > 0.0 && s2 > 0.0) || (s0 < 0.0 && s1 < 0.0 && s2 < 0.0)
}

/// Renders the triangle with `ch_checked` refusing primitive `refused`.
fn render(ctx: &Context, refused: Option<u32>) -> raykit::Result<Vec<u32>> {
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_CHECKED).build()?;
    let constants = refused.map_or_else(Specialization::new, |p| Specialization::new().set(7, p));
    let pipeline =
        Pipeline::<Params>::with_specialization(ctx, &[&raygen, &miss, &hit], LinkOptions::default(), &constants)?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, ColorData { color: BG })
        .hit(&hit, ColorData { color: HIT })
        .build()?;
    let gas = Gas::triangles(ctx, &TRIANGLE, None)?;
    let scene = Ias::single(ctx, &gas)?;
    let image = ctx.buffer::<u32>((W * H) as usize)?;
    pipeline.launch(&sbt, &params(scene.handle(), image.handle()), [W, H, 1])?;
    image.read()
}

fn cpu() -> anyhow::Result<Context> {
    Ok(Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?)
}

/// The first pixel, in launch order, that the triangle covers.
fn first_covered() -> [u32; 3] {
    let (x, y) = (0..H).flat_map(|y| (0..W).map(move |x| (x, y))).find(|&(x, y)| covers(x, y)).unwrap_or((0, 0));
    [x, y, 0]
}

/// Runs this binary's test `name` again in a child process with `env`; returns
/// its standard output. Fails when the child does.
fn run_child(name: &str, env: &[(&str, &str)]) -> anyhow::Result<String> {
    let exe = std::env::current_exe()?;
    let mut command = Command::new(exe);
    command.args(["--exact", name, "--nocapture", "--test-threads=1"]).env(CHILD, name);
    for (key, value) in env {
        command.env(key, value);
    }
    let output = command.output()?;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr);
    anyhow::ensure!(output.status.success(), "child {name} failed ({}):\n{stdout}\n{stderr}", output.status);
    anyhow::ensure!(stdout.contains("1 passed"), "child {name} ran no test:\n{stdout}");
    Ok(stdout)
}

fn is_child(name: &str) -> bool {
    std::env::var(CHILD).is_ok_and(|v| v == name)
}

#[test]
fn a_panic_in_a_device_program_is_a_typed_error_naming_the_program_and_launch_index() -> anyhow::Result<()> {
    let ctx = cpu()?;
    // Without the refusal the picture is right: the assertion holds everywhere.
    let pixels = render(&ctx, None)?;
    let hit = accel_test_device::pack_unorm(HIT);
    let bg = accel_test_device::pack_unorm(BG);
    for y in 0..H {
        for x in 0..W {
            let want = if covers(x, y) { hit } else { bg };
            assert_eq!(pixels[(y * W + x) as usize], want, "pixel ({x}, {y})");
        }
    }
    // Refusing the triangle's primitive makes every covered pixel panic: the
    // launch stops and names the program and the first such pixel.
    match render(&ctx, Some(0)) {
        Err(Error::Launch(raykit::LaunchError::ProgramPanicked { program, launch_index, message })) => {
            assert_eq!(program, "__closesthit__ch_checked");
            assert_eq!(launch_index, first_covered());
            assert!(message.contains("the ray hit the refused primitive"), "{message}");
        }
        other => anyhow::bail!("expected ProgramPanicked, got {other:?}"),
    }
    // The context goes on working after the panic.
    assert_eq!(render(&ctx, None)?, pixels);
    Ok(())
}

#[test]
fn println_in_a_device_program_reaches_standard_output() -> anyhow::Result<()> {
    const NAME: &str = "println_in_a_device_program_reaches_standard_output";
    if is_child(NAME) {
        // One thread, so that the first covered pixel prints first.
        let ctx =
            Context::new(ContextOptions { backend: Some(Backend::Cpu), cpu_threads: Some(1), ..Default::default() })?;
        let result = render(&ctx, Some(0));
        anyhow::ensure!(
            matches!(result, Err(Error::Launch(raykit::LaunchError::ProgramPanicked { .. }))),
            "{result:?}"
        );
        return Ok(());
    }
    let stdout = run_child(NAME, &[])?;
    let [x, y, _] = first_covered();
    let line = format!("ch_checked: primitive 0 hit at launch index ({x}, {y})");
    anyhow::ensure!(stdout.contains(&line), "`{line}` is not in the child's output:\n{stdout}");
    Ok(())
}

#[test]
fn the_cpu_backend_runs_without_any_vulkan_driver() -> anyhow::Result<()> {
    const NAME: &str = "the_cpu_backend_runs_without_any_vulkan_driver";
    if is_child(NAME) {
        // No driver is visible: a Vulkan context cannot be made...
        match Context::new(ContextOptions { backend: Some(Backend::Vulkan), ..Default::default() }) {
            Err(
                Error::Device(raykit::DeviceError::NoRayTracingDevice { .. })
                | Error::Device(raykit::DeviceError::LoaderMissing(_)),
            ) => {}
            other => anyhow::bail!("a Vulkan context without drivers: {other:?}"),
        }
        // ...and RAYKIT_BACKEND=cpu makes the default context a CPU one, which
        // renders optixTriangle like the reference.
        let ctx = Context::new(ContextOptions::default())?;
        anyhow::ensure!(ctx.backend() == Backend::Cpu, "{ctx:?}");
        let (width, height) = (64, 48);
        let pixels = triangle::render(&ctx, width, height)?;
        raykit_tests::check_triangle_picture(&pixels, width, height)?;
        return Ok(());
    }
    let missing = "/nonexistent/raykit-no-driver.json";
    run_child(
        NAME,
        &[
            ("VK_DRIVER_FILES", missing),
            ("VK_ICD_FILENAMES", missing),
            ("VK_ADD_DRIVER_FILES", missing),
            ("RAYKIT_BACKEND", "cpu"),
        ],
    )?;
    Ok(())
}

#[test]
fn every_pixel_is_the_same_whatever_the_number_of_threads() -> anyhow::Result<()> {
    use path_tracer::{Programs, Renderer, Scene};
    let render = |threads: usize| -> anyhow::Result<path_tracer::Image> {
        let ctx = Context::new(ContextOptions {
            backend: Some(Backend::Cpu),
            cpu_threads: Some(threads),
            ..Default::default()
        })?;
        let scene = Scene::new(&ctx)?;
        let mut renderer = Renderer::new(&ctx, &Programs::rust(&ctx)?, &scene, 48, 40)?;
        renderer.launch(2)?;
        renderer.launch(2)?;
        Ok(renderer.image()?)
    };
    let one = render(1)?;
    for threads in [2, 3, 5] {
        let many = render(threads)?;
        anyhow::ensure!(one.rays == many.rays, "{} rays on 1 thread, {} on {threads}", one.rays, many.rays);
        let bits = |i: &path_tracer::Image| -> Vec<[u32; 3]> {
            i.radiance.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
        };
        anyhow::ensure!(bits(&one) == bits(&many), "the picture on {threads} threads differs from the one on 1");
    }
    anyhow::ensure!(one.radiance.iter().any(|c| c.max_element() > 0.0), "the picture is black");
    Ok(())
}
