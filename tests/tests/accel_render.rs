//! Acceleration structures rendered on the device and checked against CPU
//! references: indexed and non-indexed meshes, AABBs through an intersection
//! program, instances (transforms, masks, SBT offsets, custom indices), refit,
//! and compaction.

use accel_test_device::{
    barycentric_color, hit_sphere, pack_unorm, pixel_position, sphere, ColorData, Params, CAMERA_Z,
};
use raykit::accel::BuildOptions;
use raykit::glam::{Affine3A, Quat, UVec2, Vec2, Vec3};
use raykit::{
    Aabb, BuildInput, Context, Error, Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt,
    Traversable, Triangles,
};
use raykit_tests::{channel_distance, with_each_backend};

const W: u32 = 96;
const H: u32 = 64;
/// The orthographic window: x in [-1.5, 1.5], y in [-1, 1].
const WINDOW: [f32; 4] = [-1.5, -1.0, 1.5, 1.0];
const BG: Vec3 = Vec3::new(0.1, 0.2, 0.3);

fn params(scene: Traversable, image: raykit::Buffer<u32>) -> Params {
    Params { image, width: W, height: H, _pad: 0, x0: WINDOW[0], y0: WINDOW[1], x1: WINDOW[2], y1: WINDOW[3], scene }
}

/// The world `(x, y)` of every pixel, row-major.
fn pixel_positions() -> Vec<Vec2> {
    let p = params(Traversable::NULL, raykit::Buffer::from_table_index(0));
    (0..H).flat_map(|y| (0..W).map(move |x| (x, y))).map(|(x, y)| pixel_position(UVec2::new(x, y), &p)).collect()
}

/// Which hit group a hit record uses.
#[derive(Copy, Clone)]
enum Hit {
    Record,
    Barycentric,
    CustomIndex,
    Sphere,
}

/// Renders `scene` with one hit record per entry of `records`.
fn render(ctx: &Context, scene: &Ias, records: &[(Hit, Vec3)]) -> anyhow::Result<Vec<u32>> {
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS)?;
    let record = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_RECORD).build()?;
    let bary = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_BARY).build()?;
    let custom = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_CUSTOM_INDEX).build()?;
    let sphere = ProgramGroup::hit_group(&module)
        .intersection(accel_test_device::IS_SPHERE)
        .closest_hit(accel_test_device::CH_RECORD)
        .build()?;
    let pipeline = Pipeline::<Params>::new(
        ctx,
        &[&raygen, &miss, &record, &bary, &custom, &sphere],
        LinkOptions { max_trace_depth: 1 },
    )?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ColorData { color: BG });
    for &(hit, color) in records {
        let group = match hit {
            Hit::Record => &record,
            Hit::Barycentric => &bary,
            Hit::CustomIndex => &custom,
            Hit::Sphere => &sphere,
        };
        sbt = sbt.hit(group, ColorData { color });
    }
    let sbt = sbt.build()?;
    let image = ctx.buffer::<u32>((W * H) as usize)?;
    pipeline.launch(&sbt, &params(scene.handle(), image.handle()), [W, H, 1])?;
    Ok(image.read()?)
}

/// 2-D barycentrics `(u, v)` of `p` in triangle `t` (projected along z), and the
/// distance-like margin to its nearest edge (negative outside).
fn barycentrics(p: Vec2, t: [Vec3; 3]) -> (Vec2, f32) {
    let (a, b, c) = (t[0].truncate(), t[1].truncate(), t[2].truncate());
    let (e1, e2, d) = (b - a, c - a, p - a);
    let det = e1.perp_dot(e2);
    let u = d.perp_dot(e2) / det;
    let v = e1.perp_dot(d) / det;
    (Vec2::new(u, v), u.min(v).min(1.0 - u - v))
}

/// A small mesh: a fan of six triangles around `(0.1, 0.05)`, wound both ways.
fn fan() -> (Vec<Vec3>, Vec<u32>) {
    let mut vertices = vec![Vec3::new(0.1, 0.05, 0.0)];
    for k in 0..6 {
        let a = k as f32 / 6.0 * std::f32::consts::TAU + 0.3;
        let r = if k % 2 == 0 { 0.9 } else { 0.6 };
        vertices.push(Vec3::new(0.1 + r * 1.3 * a.cos(), 0.05 + r * a.sin(), 0.1 * k as f32));
    }
    let mut indices = Vec::new();
    for k in 0..6u32 {
        let (b, c) = (1 + k, 1 + (k + 1) % 6);
        if k % 2 == 0 {
            indices.extend_from_slice(&[0, b, c]);
        } else {
            indices.extend_from_slice(&[c, 0, b]);
        }
    }
    (vertices, indices)
}

fn expand(vertices: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    indices.iter().map(|&i| vertices[i as usize]).collect()
}

fn differing(a: &[u32], b: &[u32], tolerance: u8) -> usize {
    a.iter().zip(b).filter(|(x, y)| channel_distance(**x, **y) > tolerance).count()
}

/// A vertex struct with the position in the middle, for the strided input.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct FatVertex {
    normal: [f32; 3],
    position: [f32; 3],
    uv: [f32; 2],
}

#[test]
fn indexed_and_non_indexed_meshes_render_identically() -> anyhow::Result<()> {
    with_each_backend("indexed_and_non_indexed_meshes_render_identically", |ctx, _backend| {
        let (vertices, indices) = fan();
        let expanded = expand(&vertices, &indices);
        let indices16: Vec<u16> = indices.iter().map(|&i| i as u16).collect();
        let fat: Vec<FatVertex> = vertices
            .iter()
            .map(|v| FatVertex { normal: [0.0, 0.0, 1.0], position: v.to_array(), uv: [0.5, 0.5] })
            .collect();
        let shift = Affine3A::from_translation(Vec3::new(0.25, -0.125, 0.5));
        let shifted: Vec<Vec3> = expanded.iter().map(|&v| shift.inverse().transform_point3(v)).collect();
        let inputs: Vec<(&str, BuildInput<'_>)> = vec![
            ("non-indexed", Triangles::new(&expanded).into()),
            ("u32 indices", Triangles::new(&vertices).indices_u32(&indices).into()),
            ("u16 indices", Triangles::new(&vertices).indices_u16(&indices16).into()),
            ("strided u32", Triangles::from_vertex_structs(&fat, 12).indices_u32(&indices).into()),
            ("pre-transformed", Triangles::new(&shifted).transform(shift).into()),
        ];
        let records = [(Hit::Barycentric, Vec3::ZERO)];
        let mut pictures = Vec::new();
        for (name, input) in &inputs {
            let gas = Gas::builder().input(*input).build(ctx)?;
            let ias = Ias::single(ctx, &gas)?;
            pictures.push((*name, render(ctx, &ias, &records)?));
        }
        let reference = &pictures[0].1;
        for (name, picture) in &pictures[1..4] {
            assert_eq!(differing(reference, picture, 0), 0, "{name} differs from the non-indexed mesh");
        }
        // The build-time transform rounds differently: allow a few edge pixels.
        let d = differing(reference, &pictures[4].1, 2);
        assert!(d <= (W * H / 200) as usize, "pre-transformed mesh: {d} pixels differ");

        // CPU reference: barycentric colour inside each triangle, background outside.
        let (mut inside, mut close, mut wrong_bg) = (0, 0, 0);
        for (p, &got) in pixel_positions().iter().zip(reference) {
            let hit =
                expanded.chunks(3).map(|t| barycentrics(*p, [t[0], t[1], t[2]])).find(|(_, margin)| *margin > 0.0);
            let nearest = expanded.chunks(3).map(|t| barycentrics(*p, [t[0], t[1], t[2]]).1).fold(f32::MIN, f32::max);
            match hit {
                Some((b, margin)) if margin > 0.01 => {
                    inside += 1;
                    close += usize::from(channel_distance(got, pack_unorm(barycentric_color(b))) <= 2);
                }
                None if nearest < -0.01 => wrong_bg += usize::from(got != pack_unorm(BG)),
                _ => {}
            }
        }
        assert!(inside > (W * H / 8) as usize, "only {inside} pixels inside the mesh");
        assert!(close as f64 >= inside as f64 * 0.995, "{close} of {inside} mesh pixels match the CPU barycentrics");
        assert_eq!(wrong_bg, 0, "background pixels differ from the miss colour");
        Ok(())
    })
}

#[test]
fn aabbs_are_hit_through_the_intersection_program() -> anyhow::Result<()> {
    with_each_backend("aabbs_are_hit_through_the_intersection_program", |ctx, _backend| {
        let boxes: Vec<Aabb> = (0..3)
            .map(|i| {
                let (c, r) = sphere(i);
                Aabb::new(c - Vec3::splat(r), c + Vec3::splat(r))
            })
            .collect();
        let gas = Gas::aabbs(ctx, &boxes)?;
        let ias = Ias::single(ctx, &gas)?;
        let color = Vec3::new(1.0, 0.5, 0.0);
        let picture = render(ctx, &ias, &[(Hit::Sphere, color)])?;
        let (mut disc, mut corner) = (0, 0);
        for (p, &got) in pixel_positions().iter().zip(&picture) {
            let origin = p.extend(CAMERA_Z);
            let d = (0..3).map(|i| (p.extend(0.0) - sphere(i).0).length() - sphere(i).1).fold(f32::MAX, f32::min);
            let hit = (0..3).any(|i| hit_sphere(origin, Vec3::NEG_Z, sphere(i).0, sphere(i).1, 0.0, 1e16) >= 0.0);
            let in_box = boxes.iter().any(|b| p.x > b.min[0] && p.x < b.max[0] && p.y > b.min[1] && p.y < b.max[1]);
            if hit && d < -0.02 {
                disc += 1;
                assert_eq!(got, pack_unorm(color), "pixel at {p} inside a sphere");
            } else if !hit && d > 0.02 {
                corner += usize::from(in_box);
                assert_eq!(got, pack_unorm(BG), "pixel at {p} outside the spheres (in a box: {in_box})");
            }
        }
        assert!(disc > 200 && corner > 20, "{disc} sphere pixels, {corner} box-corner pixels");
        Ok(())
    })
}

/// Instances of a unit square: transforms, SBT offsets, and a masked-out one in front.
fn square_instances(gas: &Gas) -> Vec<Instance> {
    let rot = Quat::from_rotation_z(0.6);
    vec![
        Instance::new(gas)
            .transform(Affine3A::from_translation(Vec3::new(-1.0, 0.2, 0.0)))
            .sbt_offset(0)
            .custom_index(10),
        Instance::new(gas)
            .transform(Affine3A::from_scale_rotation_translation(Vec3::splat(0.8), rot, Vec3::new(0.0, -0.3, 0.0)))
            .sbt_offset(1)
            .custom_index(20),
        Instance::new(gas)
            .transform(Affine3A::from_translation(Vec3::new(1.0, 0.0, 0.5)))
            .sbt_offset(2)
            .custom_index(30),
        // In front of everything, but its mask lacks the ray's bit 0x01.
        Instance::new(gas)
            .transform(Affine3A::from_scale_rotation_translation(
                Vec3::splat(4.0),
                Quat::IDENTITY,
                Vec3::new(0.0, 0.0, 2.0),
            ))
            .mask(0x02)
            .sbt_offset(3)
            .custom_index(40),
    ]
}

/// Which instance the ray at `p` hits first (CPU reference), with its edge margin.
fn instance_hit(instances: &[(Affine3A, u8)], p: Vec2) -> (Option<usize>, f32) {
    let mut best: Option<(usize, f32)> = None;
    let mut margin = f32::MAX;
    for (i, (m, mask)) in instances.iter().enumerate() {
        if mask & 0x01 == 0 {
            continue;
        }
        let inv = m.inverse();
        let local = inv.transform_point3(p.extend(0.0));
        let edge = 0.5 - local.x.abs().max(local.y.abs());
        margin = margin.min(edge.abs() * m.matrix3.x_axis.length());
        if edge > 0.0 {
            let z = m.translation.z;
            if best.is_none_or(|(_, bz)| z > bz) {
                best = Some((i, z));
            }
        }
    }
    (best.map(|(i, _)| i), margin)
}

#[test]
fn instances_hit_the_right_records() -> anyhow::Result<()> {
    with_each_backend("instances_hit_the_right_records", |ctx, _backend| {
        let square = [
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::new(0.5, -0.5, 0.0),
            Vec3::new(-0.5, 0.5, 0.0),
            Vec3::new(0.5, 0.5, 0.0),
        ];
        let gas = Gas::triangles(ctx, &square, Some(&[0, 1, 2, 1, 3, 2]))?;
        let instances = square_instances(&gas);
        let ias = Ias::new(ctx, &instances)?;
        let colors = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
        let by_record = render(ctx, &ias, &colors.map(|c| (Hit::Record, c)))?;
        let by_index = render(ctx, &ias, &colors.map(|_| (Hit::CustomIndex, Vec3::ZERO)))?;

        let placed: Vec<(Affine3A, u8)> = vec![
            (Affine3A::from_translation(Vec3::new(-1.0, 0.2, 0.0)), 0xff),
            (
                Affine3A::from_scale_rotation_translation(
                    Vec3::splat(0.8),
                    Quat::from_rotation_z(0.6),
                    Vec3::new(0.0, -0.3, 0.0),
                ),
                0xff,
            ),
            (Affine3A::from_translation(Vec3::new(1.0, 0.0, 0.5)), 0xff),
            (
                Affine3A::from_scale_rotation_translation(Vec3::splat(4.0), Quat::IDENTITY, Vec3::new(0.0, 0.0, 2.0)),
                0x02,
            ),
        ];
        let mut seen = [0usize; 4];
        for (p, (&record, &index)) in pixel_positions().iter().zip(by_record.iter().zip(&by_index)) {
            let (hit, margin) = instance_hit(&placed, *p);
            if margin < 0.02 {
                continue;
            }
            match hit {
                Some(i) => {
                    seen[i] += 1;
                    assert_eq!(record, pack_unorm(colors[i]), "pixel at {p}: instance {i} with SBT offset {i}");
                    let custom = [10, 20, 30, 40][i];
                    assert_eq!(
                        index,
                        pack_unorm(Vec3::new(custom as f32 / 255.0, 0.0, 1.0)),
                        "pixel at {p}: custom index"
                    );
                }
                None => {
                    assert_eq!(record, pack_unorm(BG), "pixel at {p} hits nothing (the masked instance is invisible)");
                }
            }
        }
        assert!(seen[..3].iter().all(|&n| n > 100) && seen[3] == 0, "pixels per instance: {seen:?}");
        Ok(())
    })
}

/// Coverage of one triangle by the pixels, with edge pixels left out (`None`).
fn triangle_coverage(t: [Vec3; 3]) -> Vec<Option<bool>> {
    pixel_positions()
        .iter()
        .map(|p| {
            let (_, margin) = barycentrics(*p, t);
            (margin.abs() > 0.01).then_some(margin > 0.0)
        })
        .collect()
}

fn check_coverage(picture: &[u32], expected: &[Option<bool>], color: Vec3) -> usize {
    let mut covered = 0;
    for (i, (&got, want)) in picture.iter().zip(expected).enumerate() {
        match want {
            Some(true) => {
                covered += 1;
                assert_eq!(got, pack_unorm(color), "pixel {i} should be inside the triangle");
            }
            Some(false) => assert_eq!(got, pack_unorm(BG), "pixel {i} should be background"),
            None => {}
        }
    }
    covered
}

#[test]
fn refit_moves_the_picture_as_the_cpu_reference_says() -> anyhow::Result<()> {
    with_each_backend("refit_moves_the_picture_as_the_cpu_reference_says", |ctx, _backend| {
        let before = [Vec3::new(-1.2, -0.8, 0.0), Vec3::new(0.2, -0.8, 0.0), Vec3::new(-0.5, 0.7, 0.0)];
        let after = [Vec3::new(-0.2, -0.5, 0.3), Vec3::new(1.3, -0.9, 0.0), Vec3::new(0.9, 0.9, 0.0)];
        let options = BuildOptions::default().fast_build().allow_update(true);
        let mut gas = Gas::builder().triangles(Triangles::new(&before)).options(options).build(ctx)?;
        let mut ias = Ias::builder(&[Instance::new(&gas)]).options(options).build(ctx)?;
        let color = Vec3::new(0.0, 1.0, 0.5);
        let records = [(Hit::Record, color)];
        let first = render(ctx, &ias, &records)?;
        assert!(check_coverage(&first, &triangle_coverage(before), color) > 300);

        gas.update(&[Triangles::new(&after).into()])?;
        ias.update(&[Instance::new(&gas)])?;
        let second = render(ctx, &ias, &records)?;
        assert!(check_coverage(&second, &triangle_coverage(after), color) > 300);
        assert!(differing(&first, &second, 0) > 500, "the refit did not change the picture");

        // A changed topology is refused, and the structure keeps its last state.
        let quad = [after[0], after[1], after[2], Vec3::ZERO];
        let err = gas.update(&[Triangles::new(&quad).indices_u32(&[0, 1, 2, 0, 2, 3]).into()]).err();
        assert!(
            matches!(&err, Some(Error::Accel(raykit::AccelError::UpdateRefused { reason, .. })) if reason.contains("2 triangles")),
            "{err:?}"
        );
        let err = gas.update(&[Triangles::new(&after).flags(raykit::GeometryFlags::OPAQUE).into()]).err();
        assert!(
            matches!(&err, Some(Error::Accel(raykit::AccelError::UpdateRefused { reason, .. })) if reason.contains("flags")),
            "{err:?}"
        );
        let third = render(ctx, &ias, &records)?;
        assert_eq!(differing(&second, &third, 0), 0);
        Ok(())
    })
}

#[test]
fn compaction_keeps_the_picture() -> anyhow::Result<()> {
    with_each_backend("compaction_keeps_the_picture", |ctx, _backend| {
        // A 40 × 40 grid with a hole pattern, so the picture has structure.
        let n = 40u32;
        let mut vertices = Vec::new();
        for y in 0..=n {
            for x in 0..=n {
                let (fx, fy) = (x as f32 / n as f32, y as f32 / n as f32);
                vertices.push(Vec3::new(-1.2 + 2.4 * fx, -0.9 + 1.8 * fy, (fx * 7.0).sin() * 0.1));
            }
        }
        let mut indices = Vec::new();
        for y in 0..n {
            for x in 0..n {
                if (x / 3 + y / 3) % 2 == 0 {
                    let i = y * (n + 1) + x;
                    indices.extend_from_slice(&[i, i + 1, i + n + 1, i + 1, i + n + 2, i + n + 1]);
                }
            }
        }
        let gas = Gas::builder()
            .triangles(Triangles::new(&vertices).indices_u32(&indices))
            .options(BuildOptions::default().allow_compaction(true))
            .build(ctx)?;
        let records = [(Hit::Barycentric, Vec3::ZERO)];
        let before = render(ctx, &Ias::single(ctx, &gas)?, &records)?;
        let original = gas.size();
        let gas = gas.compact()?;
        let sizes = gas.compaction().ok_or_else(|| anyhow::anyhow!("no compaction report"))?;
        assert_eq!(sizes.before, original);
        assert!(sizes.after <= sizes.before, "{sizes:?}");
        let after = render(ctx, &Ias::single(ctx, &gas)?, &records)?;
        assert_eq!(differing(&before, &after, 0), 0, "compaction changed the picture");
        assert!(before.iter().filter(|&&p| p != pack_unorm(BG)).count() > (W * H / 4) as usize);
        eprintln!("compaction: {} → {} bytes", sizes.before, sizes.after);
        Ok(())
    })
}

#[test]
fn batched_builds_render() -> anyhow::Result<()> {
    with_each_backend("batched_builds_render", |ctx, _backend| {
        let left = [Vec3::new(-1.4, -0.5, 0.0), Vec3::new(-0.6, -0.5, 0.0), Vec3::new(-1.0, 0.5, 0.0)];
        let right = [Vec3::new(0.6, -0.5, 0.0), Vec3::new(1.4, -0.5, 0.0), Vec3::new(1.0, 0.5, 0.0)];
        let pending = Gas::submit_many(
            ctx,
            vec![Gas::builder().triangles(Triangles::new(&left)), Gas::builder().triangles(Triangles::new(&right))],
        )?;
        let gases = pending.wait()?;
        let instances = [Instance::new(&gases[0]), Instance::new(&gases[1]).sbt_offset(1)];
        let ias = Ias::builder(&instances).submit(ctx)?.wait()?;
        let picture = render(ctx, &ias, &[(Hit::Record, Vec3::X), (Hit::Record, Vec3::Y)])?;
        check_coverage(
            &picture[..],
            &triangle_coverage(left)
                .iter()
                .zip(triangle_coverage(right))
                .map(|(l, r)| match (l, r) {
                    (Some(true), _) | (_, Some(true)) => None,
                    (Some(false), Some(false)) => Some(false),
                    _ => None,
                })
                .collect::<Vec<_>>(),
            Vec3::ZERO,
        );
        assert!(
            check_coverage(
                &picture,
                &triangle_coverage(left).iter().map(|c| c.filter(|&v| v)).collect::<Vec<_>>(),
                Vec3::X
            ) > 100
        );
        assert!(
            check_coverage(
                &picture,
                &triangle_coverage(right).iter().map(|c| c.filter(|&v| v)).collect::<Vec<_>>(),
                Vec3::Y
            ) > 100
        );
        Ok(())
    })
}

#[test]
fn each_geometry_hits_its_own_record_after_the_instance_offset() -> anyhow::Result<()> {
    with_each_backend("each_geometry_hits_its_own_record_after_the_instance_offset", |ctx, _backend| {
        let left = [Vec3::new(-1.4, -0.5, 0.0), Vec3::new(-0.6, -0.5, 0.0), Vec3::new(-1.0, 0.5, 0.0)];
        let right = [Vec3::new(0.6, -0.5, 0.0), Vec3::new(1.4, -0.5, 0.0), Vec3::new(1.0, 0.5, 0.0)];
        let gas = Gas::builder()
            .triangles(Triangles::new(&left).flags(raykit::GeometryFlags::OPAQUE))
            .triangles(
                Triangles::new(&right)
                    .flags(raykit::GeometryFlags::OPAQUE | raykit::GeometryFlags::NO_DUPLICATE_ANY_HIT),
            )
            .build(ctx)?;
        assert_eq!(gas.geometry_count(), 2);
        let ias = Ias::new(ctx, &[Instance::new(&gas).sbt_offset(1).flags(raykit::InstanceFlags::FORCE_OPAQUE)])?;
        // Record 0 is skipped by the offset; geometry 0 → record 1, geometry 1 → record 2.
        let picture = render(ctx, &ias, &[(Hit::Record, Vec3::ONE), (Hit::Record, Vec3::X), (Hit::Record, Vec3::Y)])?;
        let inside = |t: [Vec3; 3]| triangle_coverage(t).iter().map(|c| c.filter(|&v| v)).collect::<Vec<_>>();
        assert!(check_coverage(&picture, &inside(left), Vec3::X) > 100);
        assert!(check_coverage(&picture, &inside(right), Vec3::Y) > 100);
        assert!(!picture.contains(&pack_unorm(Vec3::ONE)), "record 0 was used despite the instance's SBT offset");
        Ok(())
    })
}
