//! Acceleration structures without rendering: input validation, batching,
//! non-blocking builds, update rules and compaction sizes.

use raykit::accel::BuildOptions;
use raykit::glam::{Affine3A, Vec3};
use raykit::{Aabb, Aabbs, Backend, BuildInput, Error, Gas, Ias, Instance, Triangles};
use raykit_tests::with_each_backend;

const TRI: [Vec3; 3] = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];

#[test]
fn bad_geometry_is_refused_with_the_reason() -> anyhow::Result<()> {
    with_each_backend("bad_geometry_is_refused_with_the_reason", |ctx, _backend| {
        let err = Gas::triangles(ctx, &[], None).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::Empty { .. }))), "{err:?}");
        let err = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)], None).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::NonFiniteVertex { vertex: 2, .. }))), "{err:?}");
        let err = Gas::triangles(ctx, &TRI, Some(&[0, 1, 3])).err();
        assert!(
            matches!(&err, Some(e @ Error::Accel(raykit::AccelError::IndexOutOfRange { index: 3, .. })) if e.to_string().contains("fix the index buffer")),
            "{err:?}"
        );
        let err = Gas::triangles(ctx, &TRI, Some(&[0, 1])).err();
        assert!(
            matches!(&err, Some(e @ Error::Accel(raykit::AccelError::TriangleCount { .. })) if e.to_string().contains("multiple of 3")),
            "{err:?}"
        );
        let err = Gas::triangles(ctx, &TRI[..2], None).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::TriangleCount { .. }))), "{err:?}");
        let bytes = [0u8; 60];
        let err = Gas::builder().triangles(Triangles::strided(&bytes, 18, 3)).build(ctx).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::MisalignedStride { stride: 18, .. }))), "{err:?}");
        let err = Gas::aabbs(ctx, &[Aabb::new(Vec3::ONE, Vec3::ZERO)]).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::InvalidAabb { .. }))), "{err:?}");
        let boxes = [Aabb::new(Vec3::ZERO, Vec3::ONE)];
        let err = Gas::builder().triangles(Triangles::new(&TRI)).aabbs(Aabbs::new(&boxes)).build(ctx).err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::MixedGeometryTypes { .. }))), "{err:?}");
        let gas = Gas::triangles(ctx, &TRI, None)?;
        let err = Ias::new(ctx, &[Instance::new(&gas).sbt_offset(1 << 24)]).err();
        assert!(
            matches!(err, Some(Error::Accel(raykit::AccelError::InstanceField { field: "sbt_offset", .. }))),
            "{err:?}"
        );
        let err =
            Ias::new(ctx, &[Instance::new(&gas).transform(Affine3A::from_translation(Vec3::splat(f32::INFINITY)))])
                .err();
        assert!(matches!(err, Some(Error::Accel(raykit::AccelError::NonFiniteTransform { .. }))), "{err:?}");
        assert!(matches!(Ias::new(ctx, &[]), Err(Error::Accel(raykit::AccelError::Empty { .. }))));
        // Valid input still builds: indexed (u16, u32) and not, strided, AABBs.
        Gas::triangles(ctx, &TRI, Some(&[0, 1, 2]))?;
        Gas::builder().triangles(Triangles::new(&TRI).indices_u16(&[0, 1, 2])).build(ctx)?;
        Gas::aabbs(ctx, &boxes)?;
        Ok(())
    })
}

#[test]
fn sizes_are_queried_before_building() -> anyhow::Result<()> {
    with_each_backend("sizes_are_queried_before_building", |ctx, backend| {
        let builder = Gas::builder().triangles(Triangles::new(&TRI));
        let sizes = builder.sizes(ctx)?;
        // The CPU backend builds without scratch memory.
        assert!(sizes.structure > 0 && (sizes.build_scratch > 0 || backend == Backend::Cpu), "{sizes:?}");
        let gas = builder.build(ctx)?;
        assert_eq!(gas.size(), sizes.structure);
        assert_eq!(gas.build_sizes(), sizes);
        Ok(())
    })
}

#[test]
fn batched_and_non_blocking_builds() -> anyhow::Result<()> {
    with_each_backend("batched_and_non_blocking_builds", |ctx, _backend| {
        let boxes = [Aabb::new(Vec3::ZERO, Vec3::ONE), Aabb::new(Vec3::ONE, Vec3::splat(2.0))];
        let builds = vec![
            Gas::builder().triangles(Triangles::new(&TRI)),
            Gas::builder().aabbs(Aabbs::new(&boxes)),
            Gas::builder()
                .triangles(Triangles::new(&TRI).indices_u16(&[0, 1, 2]))
                .options(BuildOptions::default().allow_compaction(true)),
        ];
        let pending = Gas::submit_many(ctx, builds)?;
        let _ = pending.is_ready()?;
        let gases = pending.wait()?;
        assert_eq!(gases.len(), 3);
        assert_eq!(gases[1].primitive_count(), 2);
        assert!(gases[2].compacted_size().is_some() && gases[0].compacted_size().is_none());
        // A batch with one bad build submits nothing and names the problem.
        let bad =
            vec![Gas::builder().triangles(Triangles::new(&TRI)), Gas::builder().triangles(Triangles::new(&TRI[..1]))];
        assert!(matches!(Gas::build_many(ctx, bad), Err(Error::Accel(raykit::AccelError::TriangleCount { .. }))));
        let instances: Vec<Instance> = gases.iter().filter(|g| g.geometry_count() == 1).map(Instance::new).collect();
        let pending_ias = Ias::builder(&instances).submit(ctx)?;
        let ias = pending_ias.wait()?;
        assert_eq!(ias.instance_count(), 3);
        // Dropping a pending build without waiting is safe: it waits itself.
        drop(Gas::builder().triangles(Triangles::new(&TRI)).submit(ctx)?);
        Ok(())
    })
}

#[test]
fn update_is_refused_unless_allowed_and_topology_unchanged() -> anyhow::Result<()> {
    with_each_backend("update_is_refused_unless_allowed_and_topology_unchanged", |ctx, _backend| {
        let quad = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)];
        let indices = [0u32, 1, 2, 1, 3, 2];
        let input = |v: &[Vec3], i: &'static [u32]| -> Vec<BuildInput<'static>> {
            let v: &'static [Vec3] = Box::leak(v.to_vec().into_boxed_slice());
            vec![Triangles::new(v).indices_u32(i).into()]
        };
        let mut fixed = Gas::triangles(ctx, &quad, Some(&indices))?;
        let err = fixed.update(&input(&quad, &[0, 1, 2, 1, 3, 2])).err();
        assert!(
            matches!(&err, Some(Error::Accel(raykit::AccelError::UpdateRefused { reason, .. })) if reason.contains("allow_update")),
            "{err:?}"
        );

        let options = BuildOptions::default().allow_update(true);
        let mut gas =
            Gas::builder().triangles(Triangles::new(&quad).indices_u32(&indices)).options(options).build(ctx)?;
        let moved: Vec<Vec3> = quad.iter().map(|v| *v * 2.0).collect();
        gas.update(&input(&moved, &[0, 1, 2, 1, 3, 2]))?;
        let err = gas.update(&input(&moved, &[0, 1, 2])).err();
        assert!(
            matches!(&err, Some(Error::Accel(raykit::AccelError::UpdateRefused { reason, .. })) if reason.contains("1 triangles")),
            "{err:?}"
        );
        let err = gas.update(&input(&moved, &[0, 1, 2, 2, 3, 1])).err();
        assert!(
            matches!(&err, Some(e @ Error::Accel(raykit::AccelError::UpdateRefused { reason, .. })) if reason.contains("index data") && e.to_string().contains("rebuild")),
            "{err:?}"
        );
        // A rebuild accepts the new topology.
        gas.rebuild(&input(&moved, &[0, 1, 2]))?;
        assert_eq!(gas.primitive_count(), 1);

        let mut ias = Ias::builder(&[Instance::new(&gas)]).options(options).build(ctx)?;
        ias.update(&[Instance::new(&gas).transform(Affine3A::from_translation(Vec3::Z))])?;
        let err = ias.update(&[Instance::new(&gas), Instance::new(&fixed)]).err();
        assert!(
            matches!(&err, Some(Error::Accel(raykit::AccelError::UpdateRefused { what: "IAS", reason })) if reason.contains("instance count")),
            "{err:?}"
        );
        ias.rebuild(&[Instance::new(&gas), Instance::new(&fixed)])?;
        assert_eq!(ias.instance_count(), 2);
        Ok(())
    })
}

#[test]
fn compaction_reports_both_sizes() -> anyhow::Result<()> {
    with_each_backend("compaction_reports_both_sizes", |ctx, _backend| {
        let gas = Gas::triangles(ctx, &TRI, None)?;
        assert!(matches!(gas.compact(), Err(Error::Accel(raykit::AccelError::CompactionNotAllowed))));
        let (vertices, indices) = grid(32);
        let gas = Gas::builder()
            .triangles(Triangles::new(&vertices).indices_u32(&indices))
            .options(BuildOptions::default().allow_compaction(true))
            .build(ctx)?;
        let before = gas.size();
        let queried = gas.compacted_size().ok_or_else(|| anyhow::anyhow!("no compacted size"))?;
        let compacted = gas.compact()?;
        let c = compacted.compaction().ok_or_else(|| anyhow::anyhow!("no compaction report"))?;
        assert_eq!(c.before, before);
        assert_eq!(c.after, queried);
        assert!(c.after <= c.before, "{c:?}");
        assert_eq!(compacted.size(), c.after);
        Ok(())
    })
}

/// An `n × n` grid of quads in the unit square, two triangles each.
fn grid(n: u32) -> (Vec<Vec3>, Vec<u32>) {
    let mut vertices = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            vertices.push(Vec3::new(x as f32 / n as f32, y as f32 / n as f32, 0.0));
        }
    }
    let mut indices = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let i = y * (n + 1) + x;
            indices.extend_from_slice(&[i, i + 1, i + n + 1, i + 1, i + n + 2, i + n + 1]);
        }
    }
    (vertices, indices)
}

#[test]
fn acceleration_structures_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<Gas>();
    check::<Ias>();
    check::<Instance>();
    check::<raykit::PendingBuild<Gas>>();
    check::<raykit::PendingBuild<Vec<Gas>>>();
}
