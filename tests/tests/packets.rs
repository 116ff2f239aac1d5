//! The CPU backend's packet traces against its one-ray traces: every ray gets
//! the same hit, bit for bit (distance, barycentrics, primitive, geometry,
//! instance, custom index, facing), whether sixteen invocations trace it
//! together or one traces it alone. Only which of two hits at exactly the same
//! distance is the closest may differ.
//!
//! The scenes are random triangles (one instance, placed or not; and several instances with
//! rotations, scales, a facing flip, a mask the ray's cull mask excludes and two
//! geometries); the rays come from a pinhole camera (coherent), with directions
//! scattered (incoherent: traced alone inside the packet code), and from two
//! origins per pixel (the second is not where the invocation first traced from,
//! so it is traced one ray at a time); and some rays are degenerate (a NaN or
//! infinite direction, traced alone; an empty or NaN interval, a miss).

use accel_test_device::{probe_interval_ray, PacketParams, HIT_WORDS};
use raykit::glam::{Affine3A, Quat, Vec3};
use raykit::{
    Backend, Context, ContextOptions, Gas, GeometryFlags, Ias, Instance, InstanceFlags, LinkOptions, Module, Pipeline,
    ProgramGroup, Sbt, Triangles,
};

const W: u32 = 64;
const H: u32 = 48;

/// Builds a scene: its GASes (kept alive) and the IAS over them.
type SceneBuilder = dyn Fn(&Context) -> anyhow::Result<(Vec<Gas>, Ias)>;

/// A deterministic stream of numbers in `[0, 1)`.
struct Random(u64);

impl Random {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
}

/// `count` random triangles of about `size` inside `[-1.5, 1.5]² × [z0, z1]`.
fn random_triangles(random: &mut Random, count: usize, size: f32, (z0, z1): (f32, f32)) -> Vec<Vec3> {
    let mut vertices = Vec::with_capacity(count * 3);
    for _ in 0..count {
        let centre = Vec3::new(random.range(-1.5, 1.5), random.range(-1.5, 1.5), random.range(z0, z1));
        for _ in 0..3 {
            let offset = Vec3::new(random.range(-size, size), random.range(-size, size), random.range(-size, size));
            vertices.push(centre + offset);
        }
    }
    vertices
}

fn cpu(packets: bool) -> anyhow::Result<Context> {
    Ok(Context::new(ContextOptions { backend: Some(Backend::Cpu), cpu_packets: Some(packets), ..Default::default() })?)
}

/// The hit records of `rays` rays per pixel into the scene `build` makes.
fn trace(
    ctx: &Context,
    build: &SceneBuilder,
    rays: u32,
    spread: f32,
    shift: f32,
    degenerate: bool,
) -> anyhow::Result<Vec<[u32; 8]>> {
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG_PROBE)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS_PROBE)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_PROBE).build()?;
    let pipeline = Pipeline::<PacketParams>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
    let (_gases, scene) = build(ctx)?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ());
    for _ in 0..scene.hit_records_for::<accel_test_device::Probe>() {
        sbt = sbt.hit(&hit, ());
    }
    let sbt = sbt.build()?;
    let hits = ctx.buffer::<u32>((W * H * rays * HIT_WORDS) as usize)?;
    let params = PacketParams {
        hits: hits.handle(),
        width: W,
        height: H,
        rays,
        eye: Vec3::new(0.05, -0.03, 0.0),
        spread,
        shift,
        degenerate: u32::from(degenerate),
        scene: scene.handle(),
    };
    pipeline.launch(&sbt, &params, [W, H, 1])?;
    Ok(hits.read()?.chunks_exact(HIT_WORDS as usize).map(|c| c.try_into().unwrap_or([0; 8])).collect())
}

/// One instance of 8,000 random triangles.
fn one_instance(ctx: &Context) -> anyhow::Result<(Vec<Gas>, Ias)> {
    let vertices = random_triangles(&mut Random(7), 8000, 0.15, (-4.0, -2.0));
    let gas = Gas::builder().triangles(Triangles::new(&vertices).flags(GeometryFlags::OPAQUE)).build(ctx)?;
    let ias = Ias::single(ctx, &gas)?;
    Ok((vec![gas], ias))
}

/// One instance of the same triangles, moved and rotated: its rays are walked
/// through its GAS alone, so none is found outside the scene by its bounds.
fn one_transformed_instance(ctx: &Context) -> anyhow::Result<(Vec<Gas>, Ias)> {
    let vertices = random_triangles(&mut Random(7), 8000, 0.15, (-1.0, 1.0));
    let gas = Gas::builder().triangles(Triangles::new(&vertices).flags(GeometryFlags::OPAQUE)).build(ctx)?;
    let place = Affine3A::from_rotation_translation(Quat::from_rotation_y(0.2), Vec3::new(0.1, 0.0, -3.0));
    let ias = Ias::new(ctx, &[Instance::new(&gas).transform(place)])?;
    Ok((vec![gas], ias))
}

/// Five instances of two GASes (one with two geometries), moved, rotated and
/// scaled; one flipped, one with a custom index, one invisible to the probe's
/// cull mask.
fn several_instances(ctx: &Context) -> anyhow::Result<(Vec<Gas>, Ias)> {
    let mut random = Random(11);
    let near = random_triangles(&mut random, 4000, 0.12, (-0.5, 0.5));
    let far = random_triangles(&mut random, 400, 0.3, (-0.5, 0.5));
    let big = random_triangles(&mut random, 60, 0.6, (-0.2, 0.2));
    let two = Gas::builder()
        .triangles(Triangles::new(&near).flags(GeometryFlags::OPAQUE))
        .triangles(Triangles::new(&far).flags(GeometryFlags::OPAQUE))
        .build(ctx)?;
    let one = Gas::builder().triangles(Triangles::new(&big).flags(GeometryFlags::OPAQUE)).build(ctx)?;
    let at = |z: f32| Affine3A::from_translation(Vec3::new(0.0, 0.0, z));
    let instances = [
        Instance::new(&two).transform(at(-3.0)),
        Instance::new(&two)
            .transform(
                at(-4.0)
                    * Affine3A::from_scale_rotation_translation(
                        Vec3::splat(0.7),
                        Quat::from_rotation_y(0.5) * Quat::from_rotation_x(0.3),
                        Vec3::new(0.4, -0.2, 0.0),
                    ),
            )
            .flags(InstanceFlags::FLIP_TRIANGLE_FACING)
            .custom_index(7),
        Instance::new(&one).transform(at(-2.5)).mask(0x02),
        Instance::new(&one).transform(at(-5.0) * Affine3A::from_rotation_z(1.0)).custom_index(3),
        Instance::new(&one).transform(at(-3.5) * Affine3A::from_rotation_x(std::f32::consts::PI)),
    ];
    let ias = Ias::new(ctx, &instances)?;
    Ok((vec![two, one], ias))
}

/// Traces with packets and without, and compares the records.
/// Returns the rays that hit, and those that went in packets or were found
/// outside the scene before a packet took them.
fn compare(build: &SceneBuilder, rays: u32, spread: f32, shift: f32, degenerate: bool) -> anyhow::Result<(usize, u64)> {
    let (hits, packed, outside) = compare_counted(build, rays, spread, shift, degenerate)?;
    Ok((hits, packed + outside))
}

/// [`compare`], with the rays that went in packets and those found outside the
/// scene apart.
fn compare_counted(
    build: &SceneBuilder,
    rays: u32,
    spread: f32,
    shift: f32,
    degenerate: bool,
) -> anyhow::Result<(usize, u64, u64)> {
    let packed = cpu(true)?;
    let alone = cpu(false)?;
    let a = trace(&packed, build, rays, spread, shift, degenerate)?;
    let b = trace(&alone, build, rays, spread, shift, degenerate)?;
    anyhow::ensure!(
        alone.packet_rays() == 0,
        "a context without packets traced {} rays in packets",
        alone.packet_rays()
    );
    let mut hits = 0;
    let mut ties = 0;
    for (i, (p, q)) in a.iter().zip(&b).enumerate() {
        if f32::from_bits(q[0]) >= 0.0 {
            hits += 1;
        }
        if p == q {
            continue;
        }
        // Two triangles at exactly the same distance: either may be the closest.
        let same_triangle = p[3..6] == q[3..6];
        anyhow::ensure!(
            p[0] == q[0] && f32::from_bits(p[0]) >= 0.0 && !same_triangle,
            "ray {} of pixel {}: in a packet {p:?}, alone {q:?}",
            i as u32 % rays,
            i as u32 / rays
        );
        ties += 1;
    }
    anyhow::ensure!(ties <= a.len() / 1000, "{ties} of {} rays differ at equal distances", a.len());
    anyhow::ensure!(hits > a.len() / 8, "only {hits} of {} rays hit anything", a.len());
    anyhow::ensure!(
        alone.rays_outside_scene() == 0,
        "a context without packets counted {} rays outside the scene instead of in packets",
        alone.rays_outside_scene()
    );
    Ok((hits, packed.packet_rays(), packed.rays_outside_scene()))
}

#[test]
fn camera_rays_in_packets_hit_what_they_hit_alone() -> anyhow::Result<()> {
    let (hits, packed) = compare(&one_instance, 2, 0.0, 0.0, false)?;
    let rays = u64::from(W * H * 2);
    // Every ray starts at the camera: all go in packets.
    anyhow::ensure!(packed == rays, "{packed} of {rays} rays went in packets or were found outside the scene");
    eprintln!("one instance, camera rays: {hits} of {rays} hit");
    // Rays past the scene's edge miss without waiting for a packet; the others
    // go in packets.
    let (_, packed, outside) = compare_counted(&one_instance, 2, 0.0, 0.0, false)?;
    anyhow::ensure!(
        outside > rays / 20 && packed > rays / 2,
        "{outside} of {rays} rays found outside the scene, {packed} in packets"
    );
    let (hits, packed, outside) = compare_counted(&one_transformed_instance, 2, 0.0, 0.0, false)?;
    anyhow::ensure!(
        outside == 0 && packed == rays,
        "one transformed instance: {outside} of {rays} rays found outside the scene, {packed} in packets"
    );
    eprintln!("one transformed instance, camera rays: {hits} of {rays} hit");
    let (hits, packed) = compare(&several_instances, 2, 0.0, 0.0, false)?;
    anyhow::ensure!(packed == rays, "{packed} of {rays} rays went in packets or were found outside the scene");
    eprintln!("several instances, camera rays: {hits} of {rays} hit");
    Ok(())
}

#[test]
fn scattered_rays_in_packets_hit_what_they_hit_alone() -> anyhow::Result<()> {
    let rays = u64::from(W * H * 4);
    for build in [&one_instance as &SceneBuilder, &several_instances] {
        let (hits, packed) = compare(build, 4, 1.5, 0.0, false)?;
        anyhow::ensure!(packed == rays, "{packed} of {rays} rays went in packets or were found outside the scene");
        eprintln!("scattered rays: {hits} of {rays} hit");
    }
    Ok(())
}

#[test]
fn rays_from_elsewhere_than_the_first_are_traced_alone_with_the_same_hits() -> anyhow::Result<()> {
    let rays = u64::from(W * H * 4);
    for build in [&one_instance as &SceneBuilder, &several_instances] {
        let (hits, packed) = compare(build, 4, 0.02, 0.25, false)?;
        // Rays 0 and 2 of each pixel start at the camera; 1 and 3 elsewhere.
        anyhow::ensure!(
            packed == rays / 2,
            "{packed} of {rays} rays went in packets or were found outside the scene, not half"
        );
        eprintln!("two origins: {hits} of {rays} hit");
    }
    Ok(())
}

#[test]
fn degenerate_rays_get_in_packets_what_they_get_alone() -> anyhow::Result<()> {
    let rays = 2;
    // The packets take every camera ray with a finite direction (those with an
    // empty or NaN interval miss there); the others are traced alone.
    let taken = (0..W * H)
        .flat_map(|pixel| (0..rays).map(move |k| (pixel, k)))
        .filter(|&(pixel, k)| probe_interval_ray(pixel, k, 1, Vec3::ZERO, Vec3::NEG_Z).direction.is_finite())
        .count() as u64;
    let all = u64::from(W * H * rays);
    for build in [&one_instance as &SceneBuilder, &several_instances] {
        let (hits, packed) = compare(build, rays, 0.0, 0.0, true)?;
        anyhow::ensure!(
            packed == taken && taken < all,
            "{packed} of {all} rays went in packets or were found outside the scene, not {taken}"
        );
        eprintln!("degenerate rays: {hits} of {all} hit");
    }
    Ok(())
}
