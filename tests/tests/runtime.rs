//! OptiX's host-side runtime model on raykit: parameter specialization, async
//! launches, the compile cache, thread safety, logs and pipeline libraries.

use program_model_device::{pack, Params, Radiance, SHADE_MODE_SPEC_ID, SPEC_COLORS};
use raykit::glam::{Affine3A, UVec2, Vec3, Vec4};
use raykit::{Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt, Specialization};
use raykit_tests::with_context;

#[test]
fn two_pipelines_from_one_module_specialized_differently_render_differently() -> anyhow::Result<()> {
    with_context("two_pipelines_from_one_module_specialized_differently_render_differently", |ctx| {
        let gas = Gas::triangles(ctx, &program_model::QUAD, None)?;
        let scene = Ias::new(ctx, &[Instance::new(&gas).transform(Affine3A::from_translation(Vec3::new(-0.25, -0.25, 0.0)))])?;
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SPEC_SHADE).build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let params = Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(16), scene: scene.handle() };
        let centre = 8 * 16 + 8;
        let mut seen = Vec::new();
        for constants in [Specialization::new(), Specialization::new().set(SHADE_MODE_SPEC_ID, 1)] {
            let pipeline = Pipeline::<Params>::with_specialization(ctx, &[&raygen, &miss, &hit], LinkOptions::default(), &constants)?;
            let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss_for::<Radiance, _>(&miss, ()).hit_for::<Radiance, _>(0, &hit, ()).build()?;
            pipeline.launch(&sbt, &params, [16, 16, 1])?;
            seen.push(image.read()?[centre]);
        }
        assert_eq!(seen, [pack(SPEC_COLORS[0]), pack(SPEC_COLORS[1])]);
        Ok(())
    })
}

#[test]
fn two_async_launches_in_flight_give_correct_results() -> anyhow::Result<()> {
    with_context("two_async_launches_in_flight_give_correct_results", |ctx| {
        let gas = Gas::triangles(ctx, &program_model::QUAD, None)?;
        let scene = Ias::new(ctx, &[Instance::new(&gas).transform(Affine3A::from_translation(Vec3::new(-0.25, -0.25, 0.0)))])?;
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SPEC_SHADE).build()?;
        let pipelines = [Specialization::new(), Specialization::new().set(SHADE_MODE_SPEC_ID, 1)]
            .iter()
            .map(|c| Pipeline::<Params>::with_specialization(ctx, &[&raygen, &miss, &hit], LinkOptions::default(), c))
            .collect::<raykit::Result<Vec<_>>>()?;
        let sbts = pipelines
            .iter()
            .map(|p| Sbt::builder(p).raygen(&raygen, ()).miss_for::<Radiance, _>(&miss, ()).hit_for::<Radiance, _>(0, &hit, ()).build())
            .collect::<raykit::Result<Vec<_>>>()?;
        let size = 64u32;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        // Three launches: two of one pipeline (different images), one of the other.
        let images = (0..3).map(|_| ctx.buffer::<u32>((size * size) as usize)).collect::<raykit::Result<Vec<_>>>()?;
        let params = |i: usize| Params { image: images[i].handle(), spheres: spheres.handle(), size: UVec2::splat(size), scene: scene.handle() };
        let launches = [
            pipelines[0].launch_async(&sbts[0], &params(0), [size, size, 1])?,
            pipelines[1].launch_async(&sbts[1], &params(1), [size, size, 1])?,
            pipelines[0].launch_async(&sbts[0], &params(2), [size, size, 1])?,
        ];
        // While launches use the SBT, updating it is refused.
        let mut spare = Sbt::builder(&pipelines[0]).raygen(&raygen, ()).miss_for::<Radiance, _>(&miss, ()).hit_for::<Radiance, _>(0, &hit, ()).build()?;
        let held = pipelines[0].launch_async(&spare, &params(0), [1, 1, 1])?;
        assert!(spare.update(raykit::SbtRegion::Raygen, 0, ()).is_err(), "an SBT in use by a launch was updated");
        held.wait()?;
        spare.update(raykit::SbtRegion::Raygen, 0, ())?;
        // Poll the last one, then wait for all.
        while !launches[2].is_done()? {
            std::thread::yield_now();
        }
        for launch in launches {
            launch.wait()?;
        }
        let centre = ((size / 2) * size + size / 2) as usize;
        let corner = 0usize;
        let bg = pack(program_model_device::BACKGROUND);
        let got: Vec<Vec<u32>> = images.iter().map(|i| i.read()).collect::<raykit::Result<_>>()?;
        assert_eq!([got[0][centre], got[1][centre], got[2][centre]], [pack(SPEC_COLORS[0]), pack(SPEC_COLORS[1]), pack(SPEC_COLORS[0])]);
        assert_eq!([got[0][corner], got[1][corner], got[2][corner]], [bg, bg, bg]);
        assert_eq!(got[0], got[2]);
        Ok(())
    })
}

#[test]
fn async_launches_report_their_own_user_exceptions() -> anyhow::Result<()> {
    with_context("async_launches_report_their_own_user_exceptions", |ctx| {
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let throwing = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&throwing], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&throwing, ()).build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let p = |size: u32| Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(size), scene: raykit::Traversable::NULL };
        // The first launch covers both throwing pixels, the second neither.
        let a = pipeline.launch_async(&sbt, &p(16), [16, 16, 1])?;
        let b = pipeline.launch_async(&sbt, &p(1), [1, 1, 1])?;
        b.wait()?;
        match a.wait() {
            Err(raykit::Error::UserExceptions { total, .. }) => assert_eq!(total, 2),
            other => anyhow::bail!("expected two user exceptions, got {other:?}"),
        }
        Ok(())
    })
}
