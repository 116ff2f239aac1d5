//! The OptiX program model: every program kind gets its prefix and its stage,
//! the host refuses wrong pairings, and scenes that need intersection, any-hit
//! and callable programs render as their CPU references say.

use program_model::{
    CALLABLE_PLACES, CUTOUT_OFFSET, CUTOUT_SCALE, GROUND, OCCLUDER_TRIANGLE, SBT_DATA_INSTANCES, SPHERES,
};
use program_model_device::{cutout_solid, normal_color, ortho_ray, pack, ray_sphere, Params, BACKGROUND, MATERIALS};
use raykit::glam::{UVec2, Vec2, Vec3, Vec4};
use raykit::{Context, Error, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, ProgramKind, Sbt};
use raykit_tests::{channel_distance, with_context, with_each_backend};

const SIZE: u32 = 96;

fn module(ctx: &Context) -> raykit::Result<Module> {
    Module::from_device_crate(ctx, "program-model-device")
}

/// Compares `got` with `reference` (None = background, exact); returns the
/// share of non-background pixels within 2/255.
fn compare(got: &[u32], mut reference: impl FnMut(UVec2) -> Option<Vec3>) -> anyhow::Result<f64> {
    let (mut covered, mut close, mut bg_wrong) = (0usize, 0usize, 0usize);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let pixel = got[(y * SIZE + x) as usize];
            match reference(UVec2::new(x, y)) {
                Some(c) => {
                    covered += 1;
                    if channel_distance(pixel, pack(c)) <= 2 {
                        close += 1;
                    }
                }
                None => {
                    if pixel != pack(BACKGROUND) {
                        bg_wrong += 1;
                    }
                }
            }
        }
    }
    anyhow::ensure!(covered > (SIZE * SIZE / 20) as usize, "the scene covers only {covered} pixels");
    // Pixels whose ray grazes an edge may go either way: allow 0.5% of them.
    anyhow::ensure!(bg_wrong <= (SIZE * SIZE / 200) as usize, "{bg_wrong} background pixels differ");
    Ok(close as f64 / covered as f64)
}

#[test]
fn every_program_kind_has_its_prefix_and_wrong_pairings_are_refused() -> anyhow::Result<()> {
    with_context("every_program_kind_has_its_prefix_and_wrong_pairings_are_refused", |ctx| {
        let module = module(ctx)?;
        let kinds: Vec<(String, Option<ProgramKind>)> =
            module.entry_points().iter().map(|e| (e.name.clone(), e.kind)).collect();
        for (entry, kind) in [
            (program_model_device::RG, ProgramKind::Raygen),
            (program_model_device::MS, ProgramKind::Miss),
            (program_model_device::SPHERE, ProgramKind::Intersection),
            (program_model_device::CUTOUT, ProgramKind::AnyHit),
            (program_model_device::SPHERE_SHADE, ProgramKind::ClosestHit),
            (program_model_device::RED, ProgramKind::Callable),
            (program_model_device::BLUE, ProgramKind::Callable),
            (program_model_device::ON_EXCEPTION, ProgramKind::Exception),
        ] {
            assert_eq!(entry.kind, kind);
            assert!(kind.prefixes().iter().any(|p| entry.name.starts_with(p.as_str())), "{}", entry.name);
            assert!(kinds.contains(&(entry.name.to_owned(), Some(kind))), "{} missing from {kinds:?}", entry.name);
        }
        assert_eq!(program_model_device::RED.name, "__direct_callable__red");
        assert_eq!(program_model_device::BLUE.name, "__continuation_callable__blue");
        assert_eq!(program_model_device::SPHERE.name, "__intersection__sphere");
        assert_eq!(program_model_device::CUTOUT.name, "__anyhit__cutout");
        assert_eq!(program_model_device::ON_EXCEPTION.name, "__exception__on_exception");
        assert_eq!(program_model_device::RG.name, "__raygen__rg");
        assert_eq!(program_model_device::MS.name, "__miss__ms");
        assert_eq!(program_model_device::SPHERE_SHADE.name, "__closesthit__sphere_shade");

        // Every entry point refused by every group constructor of another kind.
        let all = [
            program_model_device::RG,
            program_model_device::MS,
            program_model_device::SPHERE,
            program_model_device::CUTOUT,
            program_model_device::SPHERE_SHADE,
            program_model_device::RED,
            program_model_device::ON_EXCEPTION,
        ];
        let mut refusals = 0;
        for entry in all {
            let attempts: [(ProgramKind, raykit::Result<ProgramGroup>); 7] = [
                (ProgramKind::Raygen, ProgramGroup::raygen(&module, entry)),
                (ProgramKind::Miss, ProgramGroup::miss(&module, entry)),
                (ProgramKind::Callable, ProgramGroup::callable(&module, entry)),
                (ProgramKind::Exception, ProgramGroup::exception(&module, entry)),
                (ProgramKind::ClosestHit, ProgramGroup::hit_group(&module).closest_hit(entry).build()),
                (ProgramKind::AnyHit, ProgramGroup::hit_group(&module).any_hit(entry).build()),
                (ProgramKind::Intersection, ProgramGroup::hit_group(&module).intersection(entry).build()),
            ];
            for (kind, result) in attempts {
                if kind == entry.kind {
                    result?;
                } else {
                    let err = result.err().ok_or_else(|| anyhow::anyhow!("{} accepted as {kind}", entry.name))?;
                    assert!(matches!(err, Error::Module(raykit::ModuleError::ProgramKindMismatch { .. })), "{err:?}");
                    refusals += 1;
                }
            }
        }
        // Seven entry points, each refused by the six constructors of other kinds:
        // all eight OptiX prefixes are produced (direct and continuation callables
        // above) and every wrong pairing is an error.
        assert_eq!(refusals, 42);
        Ok(())
    })
}

#[test]
fn spheres_from_an_intersection_program_match_the_cpu_reference() -> anyhow::Result<()> {
    with_each_backend("spheres_from_an_intersection_program_match_the_cpu_reference", |ctx, _backend| {
        let got = program_model::spheres(ctx, SIZE)?;
        let share = compare(&got, |pixel| {
            let (origin, dir) = ortho_ray(pixel, UVec2::splat(SIZE));
            let mut best: Option<(f32, Vec3)> = None;
            for s in SPHERES {
                if let Some(t) = ray_sphere(origin, dir, s, 0.0) {
                    if best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, ((origin + t * dir) - s.truncate()) / s.w));
                    }
                }
            }
            best.map(|(_, n)| normal_color(n))
        })?;
        assert!(share >= 0.995, "only {:.2}% of sphere pixels within 2/255", share * 100.0);
        Ok(())
    })
}

#[test]
fn an_any_hit_program_cuts_holes_where_the_pattern_is_clear() -> anyhow::Result<()> {
    with_each_backend("an_any_hit_program_cuts_holes_where_the_pattern_is_clear", |ctx, _backend| {
        // The unit triangle, scaled and moved: any-hit works in object space,
        // where barycentrics are (x, y).
        let got = program_model::cutout(ctx, SIZE)?;
        let share = compare(&got, |pixel| {
            let (origin, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            let b = (Vec2::new(origin.x, origin.y) - CUTOUT_OFFSET.truncate()) / CUTOUT_SCALE;
            let inside = b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0;
            (inside && cutout_solid(b)).then(|| Vec3::new(1.0 - b.x - b.y, b.x, b.y))
        })?;
        assert!(share >= 0.99, "only {:.2}% of cut-out pixels within 2/255", share * 100.0);
        // Holes exist: pixels inside the triangle but in clear cells show the background.
        assert!(got.iter().filter(|&&p| p == pack(BACKGROUND)).count() > (SIZE * SIZE / 2) as usize);
        Ok(())
    })
}

#[test]
fn callables_chosen_by_instance_custom_index_colour_each_instance() -> anyhow::Result<()> {
    with_each_backend("callables_chosen_by_instance_custom_index_colour_each_instance", |ctx, _backend| {
        // A quad instanced three times side by side, custom indices 0, 1, 2.
        let got = program_model::callables(ctx, SIZE)?;
        let share = compare(&got, |pixel| {
            let (o, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            CALLABLE_PLACES
                .iter()
                .position(|p| o.x >= p.x && o.x <= p.x + 0.5 && o.y >= p.y && o.y <= p.y + 0.5)
                .map(|i| MATERIALS[i])
        })?;
        assert!(share >= 0.995, "only {:.2}% of instance pixels within 2/255", share * 100.0);
        Ok(())
    })
}

fn hit_triangle(origin: Vec3, dir: Vec3, tri: [Vec3; 3], t_max: f32) -> Option<f32> {
    raykit_tests::ray_triangle(origin, dir, tri, 0.0, t_max).map(|(t, _)| t)
}

/// Checks a render of the shadows scene against the CPU reference.
fn check_shadows(got: &[u32]) -> anyhow::Result<()> {
    use program_model_device::{LIGHT, LIT, OCCLUDER, SHADOWED, SHADOW_EPSILON};
    let ground = GROUND;
    let occluder = OCCLUDER_TRIANGLE;
    let mut shadowed = 0;
    let share = compare(got, |pixel| {
        let (origin, dir) = ortho_ray(pixel, UVec2::splat(SIZE));
        if hit_triangle(origin, dir, occluder, f32::MAX).is_some() {
            return Some(OCCLUDER);
        }
        let t = ground.iter().find_map(|tri| hit_triangle(origin, dir, *tri, f32::MAX))?;
        let start = origin + t * dir + Vec3::new(0.0, 0.0, SHADOW_EPSILON);
        let blocked = hit_triangle(start, LIGHT - start, occluder, 1.0).is_some();
        if blocked {
            shadowed += 1;
        }
        Some(if blocked { SHADOWED } else { LIT })
    })?;
    anyhow::ensure!(shadowed > 100, "the reference has only {shadowed} shadowed pixels");
    anyhow::ensure!(share >= 0.995, "only {:.2}% of pixels within 2/255", share * 100.0);
    Ok(())
}

#[test]
fn shadow_rays_of_a_second_ray_type_darken_the_occluded_ground() -> anyhow::Result<()> {
    with_each_backend("shadow_rays_of_a_second_ray_type_darken_the_occluded_ground", |ctx, _backend| {
        check_shadows(&program_model::shadows(ctx, SIZE)?)
    })
}

/// OptiX's program groups used across pipelines, on `VK_KHR_pipeline_library`:
/// the shadows scene (two ray types, trace depth 2) from a raygen library and a
/// library of the misses and hit groups renders the very pixels of the
/// monolithic pipeline, which match the CPU reference.
#[test]
fn a_pipeline_linked_from_libraries_renders_like_the_monolithic_one() -> anyhow::Result<()> {
    with_context("a_pipeline_linked_from_libraries_renders_like_the_monolithic_one", |ctx| {
        anyhow::ensure!(ctx.supports_pipeline_libraries(), "{} lacks VK_KHR_pipeline_library", ctx.device_name());
        let linked = program_model::shadows_linked_as(ctx, SIZE, program_model::Linking::Libraries)?;
        let monolithic = program_model::shadows_linked_as(ctx, SIZE, program_model::Linking::Monolithic)?;
        check_shadows(&linked)?;
        let differing = linked.iter().zip(&monolithic).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{differing} pixels differ between the linked and the monolithic pipeline");
        Ok(())
    })
}

#[test]
fn instances_sharing_a_hit_program_read_their_own_sbt_records() -> anyhow::Result<()> {
    with_each_backend("instances_sharing_a_hit_program_read_their_own_sbt_records", |ctx, _backend| {
        let got = program_model::sbt_data(ctx, SIZE)?;
        let share = compare(&got, |pixel| {
            let (o, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            SBT_DATA_INSTANCES
                .iter()
                .find(|(p, _)| o.x >= p.x && o.x <= p.x + 0.5 && o.y >= p.y && o.y <= p.y + 0.5)
                .map(|(_, color)| *color)
        })?;
        assert!(share >= 0.995, "only {:.2}% of instance pixels within 2/255", share * 100.0);
        // A hole in the hit region is refused.
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::RECORD_COLOR).build()?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
        let err = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss(&miss, ())
            .hit_at(1, &hit, program_model_device::ColorRecord { color: Vec3::ONE })
            .build()
            .err();
        assert!(
            matches!(err, Some(Error::Sbt(raykit::SbtError::Hole { region: raykit::SbtRegion::Hit, index: 0 }))),
            "{err:?}"
        );
        Ok(())
    })
}

#[test]
fn user_exceptions_reach_the_host_with_code_and_launch_index() -> anyhow::Result<()> {
    with_each_backend("user_exceptions_reach_the_host_with_code_and_launch_index", |ctx, _backend| {
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let gas = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::Y], None)?;
        let scene = Ias::single(ctx, &gas)?;
        let params =
            Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(16), scene: scene.handle() };
        let err = pipeline.launch(&sbt, &params, [16, 16, 1]).err();
        let Some(Error::Launch(raykit::LaunchError::UserExceptions { total, mut exceptions })) = err else {
            anyhow::bail!("expected UserExceptions, got {err:?}");
        };
        assert_eq!(total, 2);
        exceptions.sort_by_key(|e| e.code);
        let mut expected: Vec<raykit::UserException> = program_model_device::THROWN
            .iter()
            .map(|(at, code)| raykit::UserException { code: *code, launch_index: [at.x, at.y, 0] })
            .collect();
        expected.sort_by_key(|e| e.code);
        assert_eq!(exceptions, expected);
        // The launch ran to its end: every other pixel was written.
        let written = image.read()?.iter().filter(|&&p| p == 1).count();
        assert_eq!(written, 16 * 16 - 2);
        // The next launch starts with no exceptions recorded: a launch of a
        // single invocation that does not throw succeeds.
        let quiet = Params { size: UVec2::splat(1), ..params };
        pipeline.launch(&sbt, &quiet, [1, 1, 1])?;
        Ok(())
    })
}

#[test]
fn sbt_records_are_updated_between_launches_without_a_new_pipeline() -> anyhow::Result<()> {
    use program_model_device::{ColorRecord, Radiance};
    with_each_backend("sbt_records_are_updated_between_launches_without_a_new_pipeline", |ctx, _backend| {
        let gas = Gas::triangles(ctx, &program_model::QUAD, None)?;
        let scene = Ias::new(
            ctx,
            &[raykit::Instance::new(&gas)
                .transform(raykit::glam::Affine3A::from_translation(Vec3::new(-0.25, -0.25, 0.0)))],
        )?;
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::RECORD_COLOR).build()?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
        let mut sbt = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss_for::<Radiance, _>(&miss, ())
            .hit_for::<Radiance, _>(0, &hit, ColorRecord { color: Vec3::new(1.0, 0.0, 0.0) })
            .build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let params =
            Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(16), scene: scene.handle() };
        let centre = (8 * 16 + 8) as usize;
        pipeline.launch(&sbt, &params, [16, 16, 1])?;
        assert_eq!(image.read()?[centre], pack(Vec3::new(1.0, 0.0, 0.0)));
        sbt.update(raykit::SbtRegion::Hit, 0, ColorRecord { color: Vec3::new(0.0, 0.0, 1.0) })?;
        pipeline.launch(&sbt, &params, [16, 16, 1])?;
        assert_eq!(image.read()?[centre], pack(Vec3::new(0.0, 0.0, 1.0)));
        // Out of range and too large are refused; the SBT stays usable.
        assert!(matches!(
            sbt.update(raykit::SbtRegion::Hit, 1, ColorRecord { color: Vec3::ONE }),
            Err(Error::Sbt(raykit::SbtError::Update { .. }))
        ));
        assert!(matches!(
            sbt.update(raykit::SbtRegion::Hit, 0, [0u8; 4096]),
            Err(Error::Sbt(raykit::SbtError::Update { .. }))
        ));
        pipeline.launch(&sbt, &params, [16, 16, 1])?;
        assert_eq!(image.read()?[centre], pack(Vec3::new(0.0, 0.0, 1.0)));
        Ok(())
    })
}

#[test]
fn an_exception_program_runs_where_a_user_exception_was_thrown() -> anyhow::Result<()> {
    use program_model_device::{EXCEPTION_MARKER, THROWN};
    with_each_backend("an_exception_program_runs_where_a_user_exception_was_thrown", |ctx, _backend| {
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
        let handler = ProgramGroup::exception(&module, program_model_device::ON_EXCEPTION)?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &handler], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let gas = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::Y], None)?;
        let scene = Ias::single(ctx, &gas)?;
        let params =
            Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(16), scene: scene.handle() };
        let err = pipeline.launch(&sbt, &params, [16, 16, 1]).err();
        assert!(matches!(err, Some(Error::Launch(raykit::LaunchError::UserExceptions { total: 2, .. }))), "{err:?}");
        let pixels = image.read()?;
        for (at, code) in THROWN {
            assert_eq!(pixels[(at.y * 16 + at.x) as usize], EXCEPTION_MARKER | code, "at {at}");
        }
        assert_eq!(pixels.iter().filter(|&&p| p == 1).count(), 16 * 16 - 2);
        // The exception program is raykit's to place: users cannot add it as a callable.
        let err = Sbt::builder(&pipeline).raygen(&raygen, ()).callable(&handler, ()).build().err();
        assert!(matches!(err, Some(Error::Sbt(raykit::SbtError::GroupKind { .. }))), "{err:?}");
        // Two are refused at link time.
        let second = ProgramGroup::exception(&module, program_model_device::ON_EXCEPTION)?;
        let err = Pipeline::<Params>::new(ctx, &[&raygen, &handler, &second], LinkOptions::default()).err();
        assert!(matches!(err, Some(Error::Link(raykit::LinkError::SeveralExceptionPrograms))), "{err:?}");
        Ok(())
    })
}
