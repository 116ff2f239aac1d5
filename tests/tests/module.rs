//! Modules and program groups: reflection of entry points, and the checks that
//! turn a wrong program kind into an error instead of a broken pipeline.

use raykit::{Error, LinkOptions, Module, Pipeline, ProgramGroup, ProgramKind};
use raykit_tests::with_context;

#[test]
fn lists_the_entry_points_with_their_stages() -> anyhow::Result<()> {
    with_context("lists_the_entry_points_with_their_stages", |ctx| {
        let module = Module::from_device_crate(ctx, "triangle-device")?;
        let mut entries: Vec<(String, Option<ProgramKind>)> =
            module.entry_points().iter().map(|e| (e.name.clone(), e.kind)).collect();
        entries.sort_by(|a, b| a.0.cmp(&b.0));
        assert_eq!(
            entries,
            vec![
                ("__closesthit__ch".to_owned(), Some(ProgramKind::ClosestHit)),
                ("__miss__ms".to_owned(), Some(ProgramKind::Miss)),
                ("__raygen__rg".to_owned(), Some(ProgramKind::Raygen)),
            ]
        );
        let models: Vec<&str> = module.entry_points().iter().map(|e| e.execution_model.as_str()).collect();
        assert!(
            models.contains(&"RayGenerationKHR") && models.contains(&"MissKHR") && models.contains(&"ClosestHitKHR")
        );
        Ok(())
    })
}

#[test]
fn wrong_program_kinds_are_errors_that_name_the_entry_points() -> anyhow::Result<()> {
    with_context("wrong_program_kinds_are_errors_that_name_the_entry_points", |ctx| {
        let module = Module::from_device_crate(ctx, "triangle-device")?;

        let err = ProgramGroup::raygen(&module, "__miss__ms")
            .err()
            .ok_or_else(|| anyhow::anyhow!("raygen from a miss entry was accepted"))?;
        assert!(
            matches!(
                err,
                Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Raygen, .. })
            ),
            "{err:?}"
        );
        let text = err.to_string();
        for name in ["__raygen__rg", "__miss__ms", "__closesthit__ch"] {
            assert!(text.contains(name), "message does not list {name}: {text}");
        }

        // The typed constant of another kind is refused as well.
        let err = ProgramGroup::miss(&module, triangle_device::CH).err().ok_or_else(|| anyhow::anyhow!("accepted"))?;
        assert!(
            matches!(err, Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Miss, .. })),
            "{err:?}"
        );

        let err = ProgramGroup::hit_group(&module).closest_hit(triangle_device::RG).build().err();
        assert!(
            matches!(
                err,
                Some(Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::ClosestHit, .. }))
            ),
            "{err:?}"
        );

        let err = ProgramGroup::raygen(&module, "__raygen__nope").err();
        assert!(
            matches!(&err, Some(Error::Module(raykit::ModuleError::EntryPointNotFound { name, .. })) if name == "__raygen__nope"),
            "{err:?}"
        );

        assert!(ProgramGroup::hit_group(&module).build().is_ok(), "an empty hit group is allowed");

        // The context is still usable after the errors.
        let pixels = triangle::render(ctx, 16, 16)?;
        assert_eq!(pixels.len(), 256);
        Ok(())
    })
}

#[test]
fn glsl_modules_with_entry_main_load() -> anyhow::Result<()> {
    with_context("glsl_modules_with_entry_main_load", |ctx| {
        let bytes = include_bytes!("../data/raygen_main.rgen.spv");
        let module = Module::new(ctx, bytes)?;
        assert_eq!(module.entry_points().len(), 1);
        assert_eq!(module.entry_points()[0].name, "main");
        assert_eq!(module.entry_points()[0].kind, Some(ProgramKind::Raygen));
        let raygen = ProgramGroup::raygen(&module, "main")?;
        assert!(matches!(
            ProgramGroup::miss(&module, "main"),
            Err(Error::Module(raykit::ModuleError::ProgramKindMismatch { .. }))
        ));
        let pipeline = Pipeline::<()>::new(ctx, &[&raygen], LinkOptions::default())?;
        drop(pipeline);
        Ok(())
    })
}

#[test]
fn bad_modules_and_link_options_are_typed_errors() -> anyhow::Result<()> {
    with_context("bad_modules_and_link_options_are_typed_errors", |ctx| {
        assert!(matches!(
            Module::new(ctx, b"definitely not SPIR-V"),
            Err(Error::Module(raykit::ModuleError::InvalidSpirv { .. }))
        ));
        let bytes = include_bytes!("../data/raygen_main.rgen.spv");
        assert!(matches!(
            Module::new(ctx, &bytes[..bytes.len() - 2]),
            Err(Error::Module(raykit::ModuleError::InvalidSpirv { .. }))
        ));
        assert!(matches!(
            Module::new(ctx, &bytes[..(bytes.len() / 2) & !3]),
            Err(Error::Module(raykit::ModuleError::InvalidSpirv { .. }))
        ));
        let missing = Module::from_file(ctx, "no/such/file.spv");
        assert!(matches!(missing, Err(Error::Module(raykit::ModuleError::SpirvFile { .. }))));

        let module = Module::from_device_crate(ctx, "triangle-device")?;
        let raygen = ProgramGroup::raygen(&module, triangle_device::RG)?;
        let miss = ProgramGroup::miss(&module, triangle_device::MS)?;
        let limit = ctx.limits().max_ray_recursion_depth;
        let err =
            Pipeline::<triangle_device::Params>::new(ctx, &[&raygen], LinkOptions { max_trace_depth: limit + 1 }).err();
        assert!(matches!(err, Some(Error::Link(raykit::LinkError::TraceDepthTooLarge { .. }))), "{err:?}");
        let err = Pipeline::<triangle_device::Params>::new(ctx, &[&miss], LinkOptions::default()).err();
        assert!(matches!(err, Some(Error::Link(raykit::LinkError::NoRaygen))), "{err:?}");

        let pipeline = Pipeline::<triangle_device::Params>::new(ctx, &[&raygen, &miss], LinkOptions::default())?;
        let err = raykit::Sbt::builder(&pipeline).miss(&miss, ()).build().err();
        assert!(
            matches!(err, Some(Error::Sbt(raykit::SbtError::Missing { region: raykit::SbtRegion::Raygen }))),
            "{err:?}"
        );
        let err = raykit::Sbt::builder(&pipeline).raygen(&miss, ()).build().err();
        assert!(matches!(err, Some(Error::Sbt(raykit::SbtError::GroupKind { .. }))), "{err:?}");
        let err = raykit::Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).build().err();
        assert!(matches!(err, Some(Error::Sbt(raykit::SbtError::RecordTooSmall { .. }))), "{err:?}");
        let miss_data = triangle_device::MissData { bg_color: triangle::BG_COLOR };
        let sbt = raykit::Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, miss_data).build()?;
        let params: triangle_device::Params = bytemuck_zeroed();
        let err = pipeline.launch(&sbt, &params, [0, 1, 1]).err();
        assert!(matches!(err, Some(Error::Launch(raykit::LaunchError::Dimensions { .. }))), "{err:?}");
        Ok(())
    })
}

fn bytemuck_zeroed<T: raykit::device::bytemuck::Zeroable>() -> T {
    T::zeroed()
}

/// The ray payload and hit attribute sizes of every entry point, read from the
/// SPIR-V (what pipeline libraries declare as their interface): exact, and the
/// same for the Rust programs and their GLSL twins, which declare the same types.
#[test]
fn payload_and_hit_attribute_sizes_are_read_from_the_spirv_alike_for_rust_and_glsl() -> anyhow::Result<()> {
    use raykit::module::reflect_entry_points;
    use raykit::InterfaceSizes;
    let sizes = |bytes: &[u8]| -> anyhow::Result<Vec<(String, InterfaceSizes)>> {
        let mut entries: Vec<(String, InterfaceSizes)> =
            reflect_entry_points(bytes)?.into_iter().map(|e| (e.name, e.interface)).collect();
        entries.sort_by(|a, b| a.0.cmp(&b.0));
        Ok(entries)
    };
    let of = |payload, hit_attributes| InterfaceSizes { payload, hit_attributes };
    let rust = |name: &str| -> anyhow::Result<Vec<u8>> { Ok(std::fs::read(raykit::spirv_path(name))?) };
    // Path tracer (both raygens, the second writing the denoiser's guides): a 48-byte
    // radiance payload, a 4-byte shadow payload, no attributes read.
    assert_eq!(
        sizes(&rust("path-tracer-device")?)?,
        [
            ("__closesthit__ch".to_owned(), of(48, 0)),
            ("__closesthit__ch_shadow".to_owned(), of(4, 0)),
            ("__miss__ms".to_owned(), of(48, 0)),
            ("__miss__ms_shadow".to_owned(), of(4, 0)),
            ("__raygen__rg".to_owned(), of(48, 0)),
            ("__raygen__rg_guides".to_owned(), of(48, 0)),
        ]
    );
    let glsl = |bytes: &[u8]| -> anyhow::Result<InterfaceSizes> { Ok(sizes(bytes)?[0].1) };
    assert_eq!(glsl(include_bytes!("../../examples/path_tracer/glsl/path_tracer.rgen.spv"))?, of(48, 0));
    assert_eq!(glsl(include_bytes!("../../examples/path_tracer/glsl/path_tracer.rchit.spv"))?, of(48, 0));
    assert_eq!(glsl(include_bytes!("../../examples/path_tracer/glsl/path_tracer.rmiss.spv"))?, of(48, 0));
    assert_eq!(glsl(include_bytes!("../../examples/path_tracer/glsl/shadow.rchit.spv"))?, of(4, 0));
    assert_eq!(glsl(include_bytes!("../../examples/path_tracer/glsl/shadow.rmiss.spv"))?, of(4, 0));
    // Triangle: a Vec3 payload; the closest-hit reads the barycentrics (vec2).
    assert_eq!(
        sizes(&rust("triangle-device")?)?,
        [
            ("__closesthit__ch".to_owned(), of(12, 8)),
            ("__miss__ms".to_owned(), of(12, 0)),
            ("__raygen__rg".to_owned(), of(12, 0))
        ]
    );
    assert_eq!(glsl(include_bytes!("../../examples/triangle/glsl/triangle.rchit.spv"))?, of(12, 8));
    assert_eq!(glsl(include_bytes!("../../examples/triangle/glsl/triangle.rgen.spv"))?, of(12, 0));
    Ok(())
}

/// A payload array sized by a specialization constant counts at the constant's
/// default, and the module is not refused.
#[test]
fn a_payload_array_sized_by_a_specialization_constant_counts_its_default() -> anyhow::Result<()> {
    let entries = raykit::module::reflect_entry_points(include_bytes!("../data/payload_spec_array.rgen.spv"))?;
    assert_eq!(entries.len(), 1);
    assert_eq!(entries[0].interface, raykit::InterfaceSizes { payload: 40, hit_attributes: 0 });
    Ok(())
}
