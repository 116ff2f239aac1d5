//! Sound lifetimes: objects dropped while the device still uses them are destroyed
//! only once that work has finished (the GPU timeline), so pending launches,
//! builds and refits never touch freed or recycled memory, and a launch's result
//! can still be read after everything it used was dropped.
//!
//! The in-flight cases hold their work on the device with the submission gate of
//! the `fault-injection` feature (`Context::close_submission_gate`), so the work is
//! surely pending at the drops, updates and refits however fast the GPU is.

use program_model_device::{pack, Params, Radiance, BACKGROUND, SPEC_COLORS};
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{
    Backend, BuildOptions, Context, DeviceBuffer, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt, Triangles,
};
use raykit_tests::with_each_backend;

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
    with_each_backend("dropping_everything_a_launch_in_flight_uses", |ctx, backend| {
        let baseline = ctx.memory_usage();
        let pixels = (WIDTH * HEIGHT) as usize;
        let vertices = scene_vertices(0.5, 20_000);
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let gas = Gas::triangles(ctx, &vertices, None)?;
        let scene = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>(pixels)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;

        // The gate holds the launch (and everything after it) on the device until
        // it opens, so the drops below surely happen while the work is pending.
        let gate = ctx.close_submission_gate()?;
        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        // A copy of the image into host memory the readback owns, ordered after the launch.
        let readback = image.read_async()?;
        let gas_size = gas.size();
        drop((image, spheres, scene, gas, sbt, pipeline));
        // On Vulkan the drops wait on the GPU timeline; on the CPU the launch holds
        // what it uses itself.
        if backend == Backend::Vulkan {
            assert!(ctx.pending_retirements() > 0, "nothing was queued on the timeline while the launch is pending");
        }

        // New objects of the same sizes, with other data, while the launch is pending.
        let pattern = vec![0xA5A5_A5A5u32; pixels];
        let fresh_image = ctx.buffer_from::<u32>(&pattern)?;
        let fresh_spheres = ctx.buffer_from::<Vec4>(&[Vec4::splat(7.0)])?;
        let other = scene_vertices(0.25, 20_000);
        let fresh_gas = Gas::builder().triangles(Triangles::new(&other)).submit(ctx)?;
        assert!(!gate.is_open(), "a drop or an allocation waited for the device");
        assert!(!launch.is_done()? && !readback.is_done()?, "the gate let the launch run");

        gate.open()?;
        launch.wait()?;
        let picture = readback.wait()?;
        let want = reference(0.5);
        assert_eq!(mismatches(&picture, &want), 0, "the launch's picture differs from the CPU reference");
        assert_eq!(fresh_image.read()?, pattern, "the launch wrote into a buffer made after its image was dropped");
        assert_eq!(fresh_spheres.read()?, [Vec4::splat(7.0)]);

        // The new GAS is intact: it renders its own (smaller) quad.
        let fresh_gas = fresh_gas.wait()?;
        // (On Vulkan, so that its memory may be the dropped one's; a CPU tree's size
        // follows its geometry.)
        if backend == Backend::Vulkan {
            assert_eq!(fresh_gas.size(), gas_size, "the new GAS should be the same size as the dropped one");
        }
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
    with_each_backend("a_refit_and_a_build_while_a_launch_traces_the_gas_wait_for_it", |ctx, backend| {
        let baseline = ctx.memory_usage();
        let pixels = (WIDTH * HEIGHT) as usize;
        let vertices = scene_vertices(0.5, 20_000);
        let options = BuildOptions::default().allow_update(true);
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let mut gas = Gas::builder().triangles(Triangles::new(&vertices)).options(options).build(ctx)?;
        let mut scene = Ias::builder(&[raykit::Instance::new(&gas)]).options(options).build(ctx)?;
        let image = ctx.buffer::<u32>(pixels)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;

        let gate = ctx.close_submission_gate()?;
        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        // A build while the launch is pending, itself pending behind the gate.
        let pending = Gas::builder().triangles(Triangles::new(&vertices)).submit(ctx)?;
        // CPU builds finish before they return; only the launch waits at the gate.
        assert!(!launch.is_done()? && (backend == Backend::Cpu || !pending.is_ready()?), "the gate let the work run");
        // A refit of the traced GAS while the launch is pending: it starts on the
        // device only after the launch has finished with the GAS. (The refit blocks
        // until it is done, which opens the gate.)
        let smaller = scene_vertices(0.25, 20_000);
        gas.update(&[Triangles::new(&smaller).into()])?;
        // (The CPU backend's refit builds a new tree and leaves the launch its old one.)
        assert!(gate.is_open() || backend == Backend::Cpu);
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

#[test]
fn a_build_in_flight_survives_dropping_its_traced_predecessor_and_a_closed_gate_never_deadlocks() -> anyhow::Result<()>
{
    with_each_backend("a_build_in_flight_survives_dropping_its_traced_predecessor", |ctx, backend| {
        let baseline = ctx.memory_usage();
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let old = Gas::triangles(ctx, &scene_vertices(0.5, 20_000), None)?;
        let old_scene = Ias::single(ctx, &old)?;
        let image = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;

        let gate = ctx.close_submission_gate()?;
        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &old_scene), [WIDTH, HEIGHT, 1])?;
        // A build and a refit-capable build of the same size while the launch is
        // pending; the structures the launch traces are dropped meanwhile.
        let build = Gas::builder()
            .triangles(Triangles::new(&scene_vertices(0.25, 20_000)))
            .options(BuildOptions::default().allow_update(true))
            .submit(ctx)?;
        drop((old_scene, old));
        assert!(
            !gate.is_open() && (backend == Backend::Cpu || !build.is_ready()?) && !launch.is_done()?,
            "the gate let the work run"
        );
        // A host wait opens the gate rather than waiting forever.
        launch.wait()?;
        assert!(gate.is_open(), "the launch's wait did not open the gate");
        assert_eq!(mismatches(&image.read()?, &reference(0.5)), 0, "the launch's picture is wrong");
        let mut built = build.wait()?;

        // A refit pending behind a closed gate, while the IAS over the GAS is
        // dropped: the refit's own wait opens the gate.
        let gate = ctx.close_submission_gate()?;
        let scene = Ias::single(ctx, &built)?;
        assert!(gate.is_open() || backend == Backend::Cpu, "a blocking build waits, and opens the gate");
        let gate = ctx.close_submission_gate()?;
        let launch = pipeline.launch_async(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        drop(scene);
        built.update(&[Triangles::new(&scene_vertices(0.5, 20_000)).into()])?;
        assert!(gate.is_open() || backend == Backend::Cpu);
        launch.wait()?;
        assert_eq!(mismatches(&image.read()?, &reference(0.25)), 0, "the launch saw the refit made after it");
        let scene = Ias::single(ctx, &built)?;
        pipeline.launch(&sbt, &params(&image, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert_eq!(mismatches(&image.read()?, &reference(0.5)), 0, "the refit renders wrong");

        drop((scene, built, image, spheres, sbt, pipeline));
        ctx.wait_idle()?;
        assert_eq!(ctx.pending_retirements(), 0);
        let end = ctx.memory_usage();
        assert_eq!((end.allocations, end.allocated_bytes), (baseline.allocations, baseline.allocated_bytes));
        Ok(())
    })
}

/// The quad scene, its pipeline and buffers, for the handle checks.
struct Quad {
    pipeline: Pipeline<Params>,
    sbt: Sbt,
    gas: Gas,
    scene: Ias,
    image: DeviceBuffer<u32>,
    spheres: DeviceBuffer<Vec4>,
}

impl Quad {
    fn new(ctx: &Context) -> anyhow::Result<Quad> {
        let (pipeline, sbt) = radiance_pipeline(ctx)?;
        let options = BuildOptions::default().allow_update(true);
        let gas = Gas::builder().triangles(Triangles::new(&scene_vertices(0.5, 0))).options(options).build(ctx)?;
        let scene = Ias::single(ctx, &gas)?;
        Ok(Quad { pipeline, sbt, gas, scene, image: ctx.buffer(16 * 16)?, spheres: ctx.buffer(1)? })
    }

    fn params(&self) -> Params {
        Params {
            image: self.image.handle(),
            spheres: self.spheres.handle(),
            size: UVec2::splat(16),
            scene: self.scene.handle(),
        }
    }

    fn launch(&self, params: &Params) -> raykit::Result<()> {
        self.pipeline.launch(&self.sbt, params, [16, 16, 1])
    }
}

/// Asserts `result` is `LaunchError::InvalidHandle` for `field`, mentioning `says`.
fn assert_invalid(result: raykit::Result<()>, field: &str, says: &str) {
    match result {
        Err(raykit::Error::Launch(raykit::LaunchError::InvalidHandle { record: None, field: f, problem, fix })) => {
            assert_eq!(f, field);
            let text = format!("{problem}; {fix}");
            assert!(text.contains(says), "the error should say {says:?}: {text}");
        }
        other => panic!("expected InvalidHandle for `{field}`, got {other:?}"),
    }
}

#[test]
fn stale_recycled_and_foreign_buffer_handles_are_refused_naming_the_field() -> anyhow::Result<()> {
    with_each_backend("stale_recycled_and_foreign_buffer_handles_are_refused_naming_the_field", |ctx, _backend| {
        let quad = Quad::new(ctx)?;
        quad.launch(&quad.params())?;
        let centre = quad.image.read()?[8 * 16 + 8];
        assert_eq!(centre, pack(SPEC_COLORS[0]), "the valid launch renders the quad");

        // Stale: the handle of a dropped buffer.
        let dropped = ctx.buffer::<u32>(16 * 16)?;
        let stale = Params { image: dropped.handle(), ..quad.params() };
        drop(dropped);
        assert_invalid(quad.launch(&stale), "image", "dropped");
        // Still refused once its slot is free again.
        ctx.wait_idle()?;
        assert_invalid(quad.launch(&stale), "image", "dropped");

        // Recycled slot: a handle naming the slot of a live buffer with the
        // generation of the buffer that held the slot before.
        let live = ctx.buffer::<u32>(16 * 16)?;
        let slot = live.handle().table_index();
        let old_generation = stale.image.raw() >> 12;
        let recycled = raykit::Buffer::<u32>::from_table_index(slot | (old_generation << 12));
        assert_ne!(recycled, live.handle());
        assert_invalid(quad.launch(&Params { image: recycled, ..quad.params() }), "image", "slot reused");
        // The live buffer's own handle is accepted.
        quad.launch(&Params { image: live.handle(), ..quad.params() })?;
        assert_eq!(live.read()?[8 * 16 + 8], pack(SPEC_COLORS[0]));

        // Foreign: a buffer of another context.
        let other = Context::new(raykit::ContextOptions {
            validation: Some(std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1")),
            pipeline_cache: raykit::PipelineCacheLocation::Off,
            ..Default::default()
        })?;
        let foreign = other.buffer::<Vec4>(1)?;
        assert_invalid(
            quad.launch(&Params { spheres: foreign.handle(), ..quad.params() }),
            "spheres",
            "another Context",
        );
        drop(foreign);
        assert!(other.messages().take().is_empty());
        drop(other);

        // Nothing was written by the refused launches.
        assert_eq!(quad.image.read()?[8 * 16 + 8], pack(SPEC_COLORS[0]));
        Ok(())
    })
}

#[test]
fn a_dropped_ias_and_an_ias_over_a_refitted_gas_are_refused_at_launch() -> anyhow::Result<()> {
    with_each_backend("a_dropped_ias_and_an_ias_over_a_refitted_gas_are_refused_at_launch", |ctx, _backend| {
        let mut quad = Quad::new(ctx)?;
        let dropped = Ias::single(ctx, &quad.gas)?;
        let params = Params { scene: dropped.handle(), ..quad.params() };
        drop(dropped);
        assert_invalid(quad.launch(&params), "scene", "no live IAS");

        // Refit the GAS: the IAS over it is stale until updated.
        quad.gas.update(&[Triangles::new(&scene_vertices(0.25, 0)).into()])?;
        assert_invalid(quad.launch(&quad.params()), "scene", "update the IAS");
        let scene = Ias::single(ctx, &quad.gas)?;
        quad.scene = scene;
        quad.launch(&quad.params())?;
        let image = quad.image.read()?;
        // The quad now spans [-0.25, 0.25]²: the centre is inside, pixel (3, 8) outside.
        assert_eq!([image[8 * 16 + 8], image[8 * 16 + 3]], [pack(SPEC_COLORS[0]), pack(BACKGROUND)]);
        // The null traversable is accepted (it traces nothing on the device).
        assert_eq!(raykit::Traversable::NULL.device_address(), 0);
        Ok(())
    })
}

/// Renders the program-model spheres (three AABBs) with `spheres` as the sphere buffer handle.
fn render_spheres(ctx: &Context, spheres: raykit::Buffer<Vec4>) -> anyhow::Result<Vec<u32>> {
    use raykit::{Aabb, Aabbs, GeometryFlags};
    let boxes: Vec<Aabb> =
        program_model::SPHERES.iter().map(|s| Aabb::new(s.truncate() - s.w, s.truncate() + s.w)).collect();
    let gas = Gas::builder().aabbs(Aabbs::new(&boxes).flags(GeometryFlags::OPAQUE)).build(ctx)?;
    let scene = Ias::single(ctx, &gas)?;
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
    let hit = ProgramGroup::hit_group(&module)
        .intersection(program_model_device::SPHERE)
        .closest_hit(program_model_device::SPHERE_SHADE)
        .build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss_for::<Radiance, _>(&miss, ())
        .hit_for::<Radiance, _>(0, &hit, ())
        .build()?;
    let image = ctx.buffer::<u32>(64 * 64)?;
    let params = Params { image: image.handle(), spheres, size: UVec2::splat(64), scene: scene.handle() };
    pipeline.launch(&sbt, &params, [64, 64, 1])?;
    Ok(image.read()?)
}

#[test]
fn device_reads_through_the_null_handle_and_past_a_buffers_end_give_zero() -> anyhow::Result<()> {
    with_each_backend("device_reads_through_the_null_handle_and_past_a_buffers_end_give_zero", |ctx, _backend| {
        let all = ctx.buffer_from::<Vec4>(&program_model::SPHERES)?;
        let full = render_spheres(ctx, all.handle())?;
        let background = pack(BACKGROUND);
        assert!(full.iter().filter(|&&p| p != background).count() > 500, "the three spheres cover the picture");

        // The null handle (a zeroed Buffer, never written): every load gives a
        // zero sphere, which no ray hits: only background.
        let null = render_spheres(ctx, raykit::Buffer::from_table_index(0))?;
        assert!(null.iter().all(|&p| p == background), "reads through the null handle were not zero");

        // One sphere in the buffer, three primitives: loads past the end give
        // zero, exactly as a buffer holding zeros there.
        let first = ctx.buffer_from::<Vec4>(&program_model::SPHERES[..1])?;
        let past_end = render_spheres(ctx, first.handle())?;
        let zeros = ctx.buffer_from::<Vec4>(&[program_model::SPHERES[0], Vec4::ZERO, Vec4::ZERO])?;
        let want = render_spheres(ctx, zeros.handle())?;
        assert_eq!(mismatches(&past_end, &want), 0, "reads past the buffer's end were not zero");
        assert_ne!(past_end, full);
        assert!(past_end.iter().any(|&p| p != background), "the first sphere is drawn");
        Ok(())
    })
}

#[test]
fn sbt_updates_are_typed_and_allowed_while_launches_use_the_sbt() -> anyhow::Result<()> {
    use program_model_device::ColorRecord;
    with_each_backend("sbt_updates_are_typed_and_allowed_while_launches_use_the_sbt", |ctx, _backend| {
        let (red, green) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::RECORD_COLOR).build()?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
        let mut sbt = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss_for::<Radiance, _>(&miss, ())
            .hit_for::<Radiance, _>(0, &hit, ColorRecord { color: red })
            .build()?;
        let gas = Gas::triangles(ctx, &scene_vertices(0.5, 20_000), None)?;
        let scene = Ias::single(ctx, &gas)?;
        let spheres = ctx.buffer::<Vec4>(1)?;
        let first = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
        let second = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;

        // The gate holds the launch on the device, so it is surely pending at the update.
        let gate = ctx.close_submission_gate()?;
        let launch = pipeline.launch_async(&sbt, &params(&first, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert!(!launch.is_done()?, "the gate let the launch run");
        // Data of another type than the record was built with is refused, even if it fits.
        match sbt.update(raykit::SbtRegion::Hit, 0, 7u32) {
            Err(raykit::Error::Sbt(raykit::SbtError::Update { reason, .. })) => {
                assert!(reason.contains("ColorRecord") && reason.contains("u32"), "{reason}")
            }
            other => panic!("a u32 into a ColorRecord record was not refused: {other:?}"),
        }
        // An update while the launch is pending goes into a copy the next launch uses.
        sbt.update(raykit::SbtRegion::Hit, 0, ColorRecord { color: green })?;
        let next = pipeline.launch_async(&sbt, &params(&second, &spheres, &scene), [WIDTH, HEIGHT, 1])?;
        assert!(!gate.is_open(), "the update waited for the device");
        gate.open()?;
        launch.wait()?;
        next.wait()?;
        let centre = ((HEIGHT / 2) * WIDTH + WIDTH / 2) as usize;
        assert_eq!(first.read()?[centre], pack(red), "the launch in flight saw the update");
        assert_eq!(second.read()?[centre], pack(green), "the launch after the update did not see it");
        Ok(())
    })
}

#[test]
fn a_record_holding_a_dropped_buffer_handle_is_refused_at_launch_naming_the_record_and_field() -> anyhow::Result<()> {
    use program_model_device::PaletteRecord;
    with_each_backend("a_record_holding_a_dropped_buffer_handle_is_refused_at_launch", |ctx, _backend| {
        let (red, green, blue) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0));
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::PALETTE_COLOR).build()?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
        let palette = ctx.buffer_from::<Vec4>(&[red.extend(0.0), green.extend(0.0)])?;
        let mut sbt = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss_for::<Radiance, _>(&miss, ())
            .hit_for::<Radiance, _>(0, &hit, PaletteRecord { palette: palette.handle(), index: 1 })
            .build()?;
        let gas = Gas::triangles(ctx, &scene_vertices(0.5, 0), None)?;
        let scene = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer::<Vec4>(1)?;
        let params =
            Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(16), scene: scene.handle() };
        let (centre, corner) = (8 * 16 + 8, 0);

        // A live handle in the record: the closest-hit program reads the colour through it.
        pipeline.launch(&sbt, &params, [16, 16, 1])?;
        let picture = image.read()?;
        assert_eq!([picture[centre], picture[corner]], [pack(green), pack(BACKGROUND)]);

        // The record's buffer dropped: the launch is refused, naming the record and the field.
        drop(palette);
        match pipeline.launch(&sbt, &params, [16, 16, 1]) {
            Err(
                e @ raykit::Error::Launch(raykit::LaunchError::InvalidHandle {
                    record: Some((raykit::SbtRegion::Hit, 0)),
                    ..
                }),
            ) => {
                let text = e.to_string();
                let raykit::Error::Launch(raykit::LaunchError::InvalidHandle { field, problem, .. }) = e else {
                    unreachable!()
                };
                assert_eq!(field, "palette");
                assert!(problem.contains("dropped"), "{problem}");
                assert!(text.contains("field `palette` of hit record 0"), "{text}");
                assert!(text.contains("Sbt::update"), "the error should say how to fix it: {text}");
            }
            other => panic!("a record naming a dropped buffer was not refused: {other:?}"),
        }
        // Once the slot is free (and maybe reused) it is still refused.
        ctx.wait_idle()?;
        let reused = ctx.buffer_from::<Vec4>(&[blue.extend(0.0), blue.extend(0.0)])?;
        assert!(matches!(
            pipeline.launch(&sbt, &params, [16, 16, 1]),
            Err(raykit::Error::Launch(raykit::LaunchError::InvalidHandle {
                record: Some((raykit::SbtRegion::Hit, 0)),
                ..
            }))
        ));
        assert_eq!(image.read()?, picture, "a refused launch wrote the image");

        // Updated to a live buffer's handle, the record renders again.
        sbt.update(raykit::SbtRegion::Hit, 0, PaletteRecord { palette: reused.handle(), index: 0 })?;
        pipeline.launch(&sbt, &params, [16, 16, 1])?;
        assert_eq!(image.read()?[centre], pack(blue));
        Ok(())
    })
}
