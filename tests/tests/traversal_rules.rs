//! Vulkan's traversal rules on both backends: the CPU backend must draw, pixel for
//! pixel, what the Vulkan driver draws for every kind of ray (facing and its
//! culling, opacity from geometry, instance and ray flags, any-hit rejection,
//! first-hit shadow rays, cull masks, skipped triangles), and the SBT records a
//! ray type selects when its offset, stride and miss index exceed the bits a
//! trace reads.

use accel_test_device::{pack_unorm, ColorData, Params, RULE_MODES};
use raykit::glam::{Affine3A, Vec3};
use raykit::{
    Backend, Context, ContextOptions, Gas, Ias, Instance, InstanceFlags, LinkOptions, Module, Pipeline, ProgramGroup,
    Sbt, Specialization, Traversable, Triangles,
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

/// The picture of the [`accel_test_device::Wide`] ray type (SBT offset 17,
/// stride 18, miss index `0x1_0001`) on `ctx`: one instance of a GAS with two
/// geometries (the two triangles), four hit records and two miss records, each
/// its own colour.
fn render_wide(ctx: &Context) -> anyhow::Result<Vec<u32>> {
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG_WIDE)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS_WIDE)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_WIDE).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ());
    for (index, color) in WIDE_MISS.iter().enumerate() {
        sbt = sbt.miss_at(index, &miss, ColorData { color: *color });
    }
    for (index, color) in WIDE_HIT.iter().enumerate() {
        sbt = sbt.hit_at(index, &hit, ColorData { color: *color });
    }
    let sbt = sbt.build()?;
    let [a, b, c, d, e, f] = triangles();
    let (left, right) = ([a, b, c], [d, e, f]);
    let gas = Gas::builder().triangles(Triangles::new(&left)).triangles(Triangles::new(&right)).build(ctx)?;
    let scene = Ias::new(ctx, &[Instance::new(&gas)])?;
    let image = ctx.buffer::<u32>((W_WIDE * H_WIDE) as usize)?;
    let params = Params {
        image: image.handle(),
        width: W_WIDE,
        height: H_WIDE,
        _pad: 0,
        x0: -1.0,
        y0: -1.0,
        x1: 1.0,
        y1: 1.0,
        scene: scene.handle(),
    };
    pipeline.launch(&sbt, &params, [W_WIDE, H_WIDE, 1])?;
    Ok(image.read()?)
}

const W_WIDE: u32 = 32;
const H_WIDE: u32 = 32;
/// Miss records 0 and 1: black and grey.
const WIDE_MISS: [Vec3; 2] = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.5, 0.5)];
/// Hit records 0 to 3: red, green, blue, white.
const WIDE_HIT: [Vec3; 4] =
    [Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 1.0)];

#[test]
fn ray_types_past_four_bits_select_records_as_vulkan_does_on_both_backends() -> anyhow::Result<()> {
    // Offset 17 & 0xf = 1 and stride 18 & 0xf = 2: geometry 0 takes hit record
    // 1 (green), geometry 1 takes 1 + 1 × 2 = 3 (white); miss index
    // 0x1_0001 & 0xffff = 1 (grey). Unmasked, they would be records 17 and 35
    // and miss 65537, which do not exist.
    let name = "ray_types_past_four_bits_select_records_as_vulkan_does_on_both_backends";
    let pictures = std::sync::Mutex::new(Vec::new());
    raykit_tests::with_each_backend(name, |ctx, backend| {
        let picture = render_wide(ctx)?;
        let at = |x: f32, y: f32| {
            let px = ((x + 1.0) / 2.0 * W_WIDE as f32) as u32;
            let py = ((1.0 - y) / 2.0 * H_WIDE as f32) as u32;
            picture[(py * W_WIDE + px) as usize]
        };
        let (green, white, grey) = (pack_unorm(WIDE_HIT[1]), pack_unorm(WIDE_HIT[3]), pack_unorm(WIDE_MISS[1]));
        anyhow::ensure!(at(-0.5, 0.0) == green, "geometry 0 drew {:x}, not hit record 1's green", at(-0.5, 0.0));
        anyhow::ensure!(at(0.5, 0.0) == white, "geometry 1 drew {:x}, not hit record 3's white", at(0.5, 0.0));
        anyhow::ensure!(at(0.0, 0.95) == grey, "a miss drew {:x}, not miss record 1's grey", at(0.0, 0.95));
        let others: Vec<u32> = picture.iter().copied().filter(|p| ![green, white, grey].contains(p)).collect();
        anyhow::ensure!(
            others.is_empty(),
            "{} pixels of other records' colours, e.g. {:x?}",
            others.len(),
            &others[..1]
        );
        pictures.lock().map_err(|_| anyhow::anyhow!("a backend's run panicked"))?.push((backend, picture));
        Ok(())
    })?;
    let pictures = pictures.into_inner().map_err(|_| anyhow::anyhow!("a backend's run panicked"))?;
    if let [(_, vulkan), (_, cpu)] = pictures.as_slice() {
        let differing = (0..vulkan.len()).filter(|&i| vulkan[i] != cpu[i]).count();
        anyhow::ensure!(differing == 0, "{differing} pixels differ between the backends");
    }
    Ok(())
}
