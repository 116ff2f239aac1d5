//! Sound lifetimes: objects dropped while the device still uses them are destroyed
//! only once that work has finished (the GPU timeline), so pending launches,
//! builds and refits never touch freed or recycled memory, and a launch's result
//! can still be read after everything it used was dropped.

use program_model_device::{pack, Params, Radiance, BACKGROUND, SPEC_COLORS};
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{
    BuildOptions, Context, DeviceBuffer, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt, Triangles,
};
use raykit_tests::with_context;

const WIDTH: u32 = 1920;
const HEIGHT: u32 = 1080;

/// A quad over `[-half, half]²` at z = 0 (two triangles), then `clutter`
/// triangles far outside the view (x ≥ 5), so the GAS is large while the picture
/// stays simple.
fn scene_vertices(half: f32, clutter: usize) -> Vec<Vec3> {
    let mut v = vec![
        Vec3::new(-half, -half, 0.0),
        Vec3::new(half, -half, 0.0),
        Vec3::new(half, half, 0.0),
        Vec3::new(-half, -half, 0.0),
        Vec3::new(half, half, 0.0),
        Vec3::new(-half, half, 0.0),
    ];
    for k in 0..clutter {
        let x = 5.0 + (k % 1000) as f32 * 0.01;
        let y = (k / 1000) as f32 * 0.01;
        v.extend([Vec3::new(x, y, 0.0), Vec3::new(x + 0.005, y, 0.0), Vec3::new(x, y + 0.005, 0.0)]);
    }
    v
}

/// The CPU reference of the program-model raygen (orthographic rays over
/// `[-1, 1]²` looking down -z) over the quad of half-size `half`: the
/// spec-constant colour inside, the background outside.
fn reference(half: f32) -> Vec<u32> {
    let (inside, outside) = (pack(SPEC_COLORS[0]), pack(BACKGROUND));
    let mut pixels = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let x = (i as f32 + 0.5) / WIDTH as f32 * 2.0 - 1.0;
            let y = 1.0 - (j as f32 + 0.5) / HEIGHT as f32 * 2.0;
            pixels.push(if x.abs() < half && y.abs() < half { inside } else { outside });
        }
    }
    pixels
}

/// The program-model radiance pipeline (raygen, miss, a closest-hit of one colour) and its SBT.
fn radiance_pipeline(ctx: &Context) -> anyhow::Result<(Pipeline<Params>, Sbt)> {
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SPEC_SHADE).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss_for::<Radiance, _>(&miss, ())
        .hit_for::<Radiance, _>(0, &hit, ())
        .build()?;
    Ok((pipeline, sbt))
}

fn params(image: &DeviceBuffer<u32>, spheres: &DeviceBuffer<Vec4>, scene: &Ias) -> Params {
    Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::new(WIDTH, HEIGHT), scene: scene.handle() }
}

/// Number of pixels where `got` and `want` differ.
fn mismatches(got: &[u32], want: &[u32]) -> usize {
    got.iter().zip(want).filter(|(a, b)| a != b).count() + got.len().abs_diff(want.len())
}

#[test]
fn dropping_everything_a_launch_in_flight_uses_keeps_new_objects_untouched_and_the_picture_right() -> anyhow::Result<()>
{
    with_context("dropping_everything_a_launch_in_flight_uses", |ctx| {
        let baseline = ctx.memory_usage();
        let pixels = (WIDTH * HEIGHT) as usize;
        let vertices = scene_vertices(0.5, 200_000);
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let gas = Gas::triangles(ctx, &vertices, None)?;
        let scene = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>(pixels)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;

        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        // A copy of the image into host memory the readback owns, ordered after the launch.
        let readback = image.read_async()?;
        assert!(!launch.is_done()?, "the launch finished before the drops: make it larger");
        let gas_size = gas.size();
        drop((image, spheres, scene, gas, sbt, pipeline));
        assert!(ctx.pending_retirements() > 0, "nothing was queued on the timeline while the launch runs");

        // New objects of the same sizes, with other data, while the launch runs.
        let pattern = vec![0xA5A5_A5A5u32; pixels];
        let fresh_image = ctx.buffer_from::<u32>(&pattern)?;
        let fresh_spheres = ctx.buffer_from::<Vec4>(&[Vec4::splat(7.0)])?;
        let other = scene_vertices(0.25, 200_000);
        let fresh_gas = Gas::builder().triangles(Triangles::new(&other)).submit(ctx)?;

        launch.wait()?;
        let picture = readback.wait()?;
        let want = reference(0.5);
        assert_eq!(mismatches(&picture, &want), 0, "the launch's picture differs from the CPU reference");
        assert_eq!(fresh_image.read()?, pattern, "the launch wrote into a buffer made after its image was dropped");
        assert_eq!(fresh_spheres.read()?, [Vec4::splat(7.0)]);

        // The new GAS is intact: it renders its own (smaller) quad.
        let fresh_gas = fresh_gas.wait()?;
        assert_eq!(fresh_gas.size(), gas_size, "the new GAS should be the same size as the dropped one");
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let scene = Ias::single(ctx, &fresh_gas)?;
        let image = ctx.buffer::<u32>(pixels)?;
        pipeline.launch(&sbt, &params(&image, &fresh_spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert_eq!(mismatches(&image.read()?, &reference(0.25)), 0, "the new GAS was damaged");

        drop((image, scene, sbt, pipeline, fresh_gas, fresh_image, fresh_spheres));
        ctx.wait_idle()?;
        assert_eq!(ctx.pending_retirements(), 0);
        let end = ctx.memory_usage();
        assert_eq!(
            (end.allocations, end.allocated_bytes),
            (baseline.allocations, baseline.allocated_bytes),
            "device memory leaked"
        );
        Ok(())
    })
}

#[test]
fn a_refit_and_a_build_while_a_launch_traces_the_gas_wait_for_it() -> anyhow::Result<()> {
    with_context("a_refit_and_a_build_while_a_launch_traces_the_gas_wait_for_it", |ctx| {
        let baseline = ctx.memory_usage();
        let pixels = (WIDTH * HEIGHT) as usize;
        let vertices = scene_vertices(0.5, 200_000);
        let options = BuildOptions::default().allow_update(true);
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let mut gas = Gas::builder().triangles(Triangles::new(&vertices)).options(options).build(ctx)?;
        let mut scene = Ias::builder(&[raykit::Instance::new(&gas)]).options(options).build(ctx)?;
        let image = ctx.buffer::<u32>(pixels)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;

        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert!(!launch.is_done()?, "the launch finished before the refit: make it larger");
        // A refit of the traced GAS, and a new build, while the launch runs: both
        // start on the device only after the launch has finished with the GAS.
        let smaller = scene_vertices(0.25, 200_000);
        gas.update(&[Triangles::new(&smaller).into()])?;
        let pending = Gas::builder().triangles(Triangles::new(&vertices)).submit(ctx)?;
        launch.wait()?;
        assert_eq!(mismatches(&image.read()?, &reference(0.5)), 0, "the refit changed the GAS under the launch");

        // The IAS follows the refit once updated.
        scene.update(&[raykit::Instance::new(&gas)])?;
        pipeline.launch(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert_eq!(mismatches(&image.read()?, &reference(0.25)), 0, "the refitted GAS renders wrong");
        // The build submitted meanwhile renders the full quad.
        let built = pending.wait()?;
        let other = Ias::single(ctx, &built)?;
        pipeline.launch(&sbt, &params(&image, &spheres, &other), [WIDTH, HEIGHT, 1])?;
        assert_eq!(mismatches(&image.read()?, &reference(0.5)), 0, "the build made during a launch renders wrong");

        drop((image, spheres, scene, other, built, gas, sbt, pipeline));
        ctx.wait_idle()?;
        let end = ctx.memory_usage();
        assert_eq!((end.allocations, end.allocated_bytes), (baseline.allocations, baseline.allocated_bytes));
        Ok(())
    })
}
