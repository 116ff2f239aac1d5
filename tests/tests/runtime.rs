//! OptiX's host-side runtime model on raykit: parameter specialization.

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
