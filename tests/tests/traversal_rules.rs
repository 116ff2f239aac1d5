//! Vulkan's traversal rules on both backends: the CPU backend must draw, pixel for
//! pixel, what the Vulkan driver draws for every kind of ray (facing and its
//! culling, opacity from geometry, instance and ray flags, any-hit rejection,
//! first-hit shadow rays, cull masks, skipped triangles).

use accel_test_device::{pack_unorm, ColorData, Params, RULE_MODES};
use raykit::glam::{Affine3A, Vec3};
use raykit::{
    Backend, Context, ContextOptions, Gas, Ias, Instance, InstanceFlags, LinkOptions, Module, Pipeline, ProgramGroup,
    Sbt, Specialization, Traversable,
};
use raykit_tests::{test_backends, test_options, with_context};

const W: u32 = 96;
const H: u32 = 32;
const BG: Vec3 = Vec3::new(0.0, 0.0, 0.0);

fn params(scene: Traversable, image: raykit::Buffer<u32>) -> Params {
    Params { image, width: W, height: H, _pad: 0, x0: -4.8, y0: -1.0, x1: 4.8, y1: 1.0, scene }
}

/// Two triangles: one counter-clockwise and one clockwise as seen from +z.
fn triangles() -> [Vec3; 6] {
    [
        Vec3::new(-0.9, -0.8, 0.0),
        Vec3::new(-0.1, -0.8, 0.0),
        Vec3::new(-0.5, 0.8, 0.0),
        Vec3::new(0.1, -0.8, 0.0),
        Vec3::new(0.5, 0.8, 0.0),
        Vec3::new(0.9, -0.8, 0.0),
    ]
}

/// Six instances of the pair: four side by side with other flags, and two
/// behind them (one visible only to mask 0x02).
fn instances(gas: &Gas) -> Vec<Instance> {
    let at = |x: f32, z: f32| Affine3A::from_translation(Vec3::new(x, 0.0, z));
    vec![
        Instance::new(gas).transform(at(-3.6, 0.0)),
        Instance::new(gas).transform(at(-1.2, 0.0)).flags(InstanceFlags::FLIP_TRIANGLE_FACING),
        Instance::new(gas).transform(at(1.2, 0.0)).flags(InstanceFlags::DISABLE_TRIANGLE_CULLING),
        Instance::new(gas).transform(at(3.6, 0.0)).flags(InstanceFlags::FORCE_OPAQUE),
        Instance::new(gas).transform(at(3.6, -1.0)).flags(InstanceFlags::FORCE_NON_OPAQUE).mask(0x02),
        Instance::new(gas).transform(at(-3.6, -1.0)).mask(0x01),
    ]
}

/// The picture of ray type `mode` on `ctx`.
fn render(ctx: &Context, mode: u32) -> anyhow::Result<Vec<u32>> {
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG_RULES)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS)?;
    let hit = ProgramGroup::hit_group(&module)
        .closest_hit(accel_test_device::CH_RULES)
        .any_hit(accel_test_device::AH_RULES)
        .build()?;
    let constants = Specialization::new().set(8, mode);
    let pipeline =
        Pipeline::<Params>::with_specialization(ctx, &[&raygen, &miss, &hit], LinkOptions::default(), &constants)?;
    let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ColorData { color: BG }).hit(&hit, ()).build()?;
    let gas = Gas::triangles(ctx, &triangles(), None)?;
    let scene = Ias::new(ctx, &instances(&gas))?;
    let image = ctx.buffer::<u32>((W * H) as usize)?;
    pipeline.launch(&sbt, &params(scene.handle(), image.handle()), [W, H, 1])?;
    Ok(image.read()?)
}

/// The pixel at the centre of triangle `tri` (0 or 1) of column `column` (0..4).
fn centre(picture: &[u32], column: usize, tri: usize) -> u32 {
    let x_world = -3.6 + 2.4 * column as f32 + if tri == 0 { -0.5 } else { 0.5 };
    let x = ((x_world + 4.8) / 9.6 * W as f32) as u32;
    picture[((H / 2) * W + x) as usize]
}

#[test]
fn the_cpu_backend_draws_what_the_vulkan_driver_draws_for_every_kind_of_ray() -> anyhow::Result<()> {
    let name = "the_cpu_backend_draws_what_the_vulkan_driver_draws_for_every_kind_of_ray";
    if test_backends()?.len() < 2 {
        anyhow::ensure!(
            std::env::var("RAYKIT_REQUIRE_DEVICE").map_or(true, |v| v != "1"),
            "{name} compares the two backends; RAYKIT_TEST_BACKENDS names only one"
        );
        eprintln!("SKIPPED {name}: it compares the two backends, and RAYKIT_TEST_BACKENDS names only one");
        return Ok(());
    }
    with_context(name, |vulkan| {
        let cpu = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..test_options() })?;
        let mut pictures = Vec::new();
        for mode in 0..RULE_MODES {
            let (want, got) = (render(vulkan, mode)?, render(&cpu, mode)?);
            let differing: Vec<(u32, u32, u32, u32)> = (0..W * H)
                .filter(|&i| want[i as usize] != got[i as usize])
                .map(|i| (i % W, i / W, want[i as usize], got[i as usize]))
                .collect();
            anyhow::ensure!(
                differing.is_empty(),
                "ray type {mode}: {} pixels differ from Vulkan's, e.g. (x, y, Vulkan, CPU) {:x?}",
                differing.len(),
                &differing[..differing.len().min(6)]
            );
            pictures.push(got);
        }
        // The rules had something to decide: the pictures are not all alike.
        let plain = &pictures[0];
        anyhow::ensure!(plain.iter().any(|&p| p != pack_unorm(BG)), "ray type 0 hit nothing");
        // Flipping an instance's facing flips what the closest-hit program sees.
        anyhow::ensure!(centre(plain, 0, 0) != centre(plain, 1, 0), "the flipped instance has the same facing");
        // Culling back faces and culling front faces remove different triangles.
        anyhow::ensure!(pictures[1] != pictures[2] && pictures[1] != pictures[0], "culling changed nothing");
        // The any-hit program rejects primitive 1 of instance 2, unless rays are opaque.
        anyhow::ensure!(centre(plain, 2, 1) == pack_unorm(BG), "instance 2's rejected triangle was drawn");
        anyhow::ensure!(centre(&pictures[3], 2, 1) != pack_unorm(BG), "an opaque ray ran the any-hit program");
        // A shadow ray that hits keeps the green it started with.
        anyhow::ensure!(centre(&pictures[7], 0, 0) == pack_unorm(Vec3::new(0.0, 1.0, 0.0)), "the shadow ray");
        // Skipping triangles hits nothing.
        anyhow::ensure!(pictures[9].iter().all(|&p| p == pack_unorm(BG)), "SKIP_TRIANGLES hit something");
        Ok(())
    })
}
