//! The OptiX program model: every program kind gets its prefix and its stage,
//! the host refuses wrong pairings, and scenes that need intersection, any-hit
//! and callable programs render as their CPU references say.

use programs_device::{
    cutout_solid, normal_color, ortho_ray, pack, ray_sphere, Params, BACKGROUND, MATERIALS,
};
use raykit::glam::{Affine3A, UVec2, Vec2, Vec3, Vec4};
use raykit::{
    Aabb, Aabbs, Context, Error, Gas, GeometryFlags, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup,
    ProgramKind, Sbt, Triangles,
};
use raykit_tests::{channel_distance, with_context};

const SIZE: u32 = 96;

fn module(ctx: &Context) -> raykit::Result<Module> {
    Module::from_device_crate(ctx, "programs-device")
}

/// Renders with `hit` as the only hit group (and `callables`) over `scene`.
fn render(
    ctx: &Context,
    module: &Module,
    hit: &ProgramGroup,
    callables: &[&ProgramGroup],
    scene: &Ias,
    spheres: &[Vec4],
) -> anyhow::Result<Vec<u32>> {
    let raygen = ProgramGroup::raygen(module, programs_device::RG)?;
    let miss = ProgramGroup::miss(module, programs_device::MS)?;
    let mut groups = vec![&raygen, &miss, hit];
    groups.extend_from_slice(callables);
    let pipeline = Pipeline::<Params>::new(ctx, &groups, LinkOptions { max_trace_depth: 1 })?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(hit, ());
    for callable in callables {
        sbt = sbt.callable(callable, ());
    }
    let sbt = sbt.build()?;
    let image = ctx.buffer::<u32>((SIZE * SIZE) as usize)?;
    let sphere_buffer = ctx.buffer_from::<Vec4>(if spheres.is_empty() { &[Vec4::ZERO] } else { spheres })?;
    let params = Params {
        image: image.handle(),
        spheres: sphere_buffer.handle(),
        size: UVec2::splat(SIZE),
        scene: scene.handle(),
    };
    pipeline.launch(&sbt, &params, [SIZE, SIZE, 1])?;
    Ok(image.read()?)
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
            (programs_device::RG, ProgramKind::Raygen),
            (programs_device::MS, ProgramKind::Miss),
            (programs_device::SPHERE, ProgramKind::Intersection),
            (programs_device::CUTOUT, ProgramKind::AnyHit),
            (programs_device::SPHERE_SHADE, ProgramKind::ClosestHit),
            (programs_device::RED, ProgramKind::Callable),
            (programs_device::BLUE, ProgramKind::Callable),
        ] {
            assert_eq!(entry.kind, kind);
            assert!(entry.name.starts_with(kind.prefixes().iter().find(|p| entry.name.starts_with(*p)).copied().unwrap_or("?")));
            assert!(kinds.contains(&(entry.name.to_owned(), Some(kind))), "{} missing from {kinds:?}", entry.name);
        }
        assert_eq!(programs_device::RED.name, "__direct_callable__red");
        assert_eq!(programs_device::BLUE.name, "__continuation_callable__blue");
        assert_eq!(programs_device::SPHERE.name, "__intersection__sphere");
        assert_eq!(programs_device::CUTOUT.name, "__anyhit__cutout");

        // Every entry point refused by every group constructor of another kind.
        let all = [
            programs_device::RG,
            programs_device::MS,
            programs_device::SPHERE,
            programs_device::CUTOUT,
            programs_device::SPHERE_SHADE,
            programs_device::RED,
        ];
        let mut refusals = 0;
        for entry in all {
            let attempts: [(ProgramKind, raykit::Result<ProgramGroup>); 6] = [
                (ProgramKind::Raygen, ProgramGroup::raygen(&module, entry)),
                (ProgramKind::Miss, ProgramGroup::miss(&module, entry)),
                (ProgramKind::Callable, ProgramGroup::callable(&module, entry)),
                (ProgramKind::ClosestHit, ProgramGroup::hit_group(&module).closest_hit(entry).build()),
                (ProgramKind::AnyHit, ProgramGroup::hit_group(&module).any_hit(entry).build()),
                (ProgramKind::Intersection, ProgramGroup::hit_group(&module).intersection(entry).build()),
            ];
            for (kind, result) in attempts {
                if kind == entry.kind {
                    result?;
                } else {
                    let err = result.err().ok_or_else(|| anyhow::anyhow!("{} accepted as {kind}", entry.name))?;
                    assert!(matches!(err, Error::ProgramKindMismatch { .. }), "{err:?}");
                    refusals += 1;
                }
            }
        }
        assert_eq!(refusals, 30);
        Ok(())
    })
}

#[test]
fn spheres_from_an_intersection_program_match_the_cpu_reference() -> anyhow::Result<()> {
    with_context("spheres_from_an_intersection_program_match_the_cpu_reference", |ctx| {
        let spheres = [
            Vec4::new(-0.4, -0.3, 0.0, 0.35),
            Vec4::new(0.35, 0.25, -0.5, 0.5),
            Vec4::new(0.1, -0.5, 0.5, 0.2),
        ];
        let boxes: Vec<Aabb> = spheres.iter().map(|s| Aabb::new(s.truncate() - s.w, s.truncate() + s.w)).collect();
        let gas = Gas::builder().aabbs(Aabbs::new(&boxes).flags(GeometryFlags::OPAQUE)).build(ctx)?;
        let scene = Ias::single(ctx, &gas)?;
        let module = module(ctx)?;
        let hit = ProgramGroup::hit_group(&module)
            .intersection(programs_device::SPHERE)
            .closest_hit(programs_device::SPHERE_SHADE)
            .build()?;
        let got = render(ctx, &module, &hit, &[], &scene, &spheres)?;
        let share = compare(&got, |pixel| {
            let (origin, dir) = ortho_ray(pixel, UVec2::splat(SIZE));
            let mut best: Option<(f32, Vec3)> = None;
            for s in spheres {
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
    with_context("an_any_hit_program_cuts_holes_where_the_pattern_is_clear", |ctx| {
        // The unit triangle, scaled ×1.6 and moved to (-0.8, -0.8): any-hit
        // works in object space, where barycentrics are (x, y).
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let gas = Gas::builder().triangles(Triangles::new(&tri).flags(GeometryFlags::NONE)).build(ctx)?;
        let to_world = Affine3A::from_scale_rotation_translation(Vec3::splat(1.6), Default::default(), Vec3::new(-0.8, -0.8, 0.0));
        let scene = Ias::new(ctx, &[Instance::new(&gas).transform(to_world)])?;
        let module = module(ctx)?;
        let hit = ProgramGroup::hit_group(&module)
            .any_hit(programs_device::CUTOUT)
            .closest_hit(programs_device::CUTOUT_SHADE)
            .build()?;
        let got = render(ctx, &module, &hit, &[], &scene, &[])?;
        let share = compare(&got, |pixel| {
            let (origin, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            let b = Vec2::new((origin.x + 0.8) / 1.6, (origin.y + 0.8) / 1.6);
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
    with_context("callables_chosen_by_instance_custom_index_colour_each_instance", |ctx| {
        // A square of two triangles, instanced three times side by side.
        let quad = [
            Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.0, 0.5, 0.0),
        ];
        let gas = Gas::triangles(ctx, &quad, None)?;
        let xs = [-0.9f32, -0.25, 0.4];
        let instances: Vec<Instance> = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| Instance::new(&gas).transform(Affine3A::from_translation(Vec3::new(x, -0.25, 0.0))).custom_index(i as u32))
            .collect();
        let scene = Ias::new(ctx, &instances)?;
        let module = module(ctx)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(programs_device::MATERIAL_SHADE).build()?;
        let red = ProgramGroup::callable(&module, programs_device::RED)?;
        let green = ProgramGroup::callable(&module, programs_device::GREEN)?;
        let blue = ProgramGroup::callable(&module, programs_device::BLUE)?;
        let got = render(ctx, &module, &hit, &[&red, &green, &blue], &scene, &[])?;
        let share = compare(&got, |pixel| {
            let (o, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            xs.iter()
                .position(|&x| o.x >= x && o.x <= x + 0.5 && o.y >= -0.25 && o.y <= 0.25)
                .map(|i| MATERIALS[i])
        })?;
        assert!(share >= 0.995, "only {:.2}% of instance pixels within 2/255", share * 100.0);
        Ok(())
    })
}

/// Möller–Trumbore on the host: the distance to `tri`, if hit in `(0, t_max)`.
fn hit_triangle(origin: Vec3, dir: Vec3, tri: [Vec3; 3], t_max: f32) -> Option<f32> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = origin - tri[0];
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < t_max).then_some(t)
}

#[test]
fn shadow_rays_of_a_second_ray_type_darken_the_occluded_ground() -> anyhow::Result<()> {
    use programs_device::{Shadow, ShadowedRadiance, LIGHT, LIT, OCCLUDER, SHADOWED, SHADOW_EPSILON};
    with_context("shadow_rays_of_a_second_ray_type_darken_the_occluded_ground", |ctx| {
        let ground = [
            [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
            [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
        ];
        let occluder = [Vec3::new(-0.4, -0.35, 1.0), Vec3::new(0.25, -0.35, 1.0), Vec3::new(-0.1, 0.3, 1.0)];
        let vertices: Vec<Vec3> = ground.iter().flatten().copied().chain(occluder).collect();
        let gas = Gas::triangles(ctx, &vertices, None)?;
        let scene = Ias::single(ctx, &gas)?;
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, programs_device::RG_SHADOWS)?;
        let miss = ProgramGroup::miss(&module, programs_device::MS_SHADOWS)?;
        let shadow_miss = ProgramGroup::miss(&module, programs_device::MS_SHADOW)?;
        let shade = ProgramGroup::hit_group(&module).closest_hit(programs_device::SHADE_SHADOWED).build()?;
        let shadow_hit = ProgramGroup::hit_group(&module).closest_hit(programs_device::SHADOW_HIT).build()?;
        let pipeline = Pipeline::<Params>::new(
            ctx,
            &[&raygen, &miss, &shadow_miss, &shade, &shadow_hit],
            LinkOptions { max_trace_depth: 2 },
        )?;
        // Placed from the ray types' declarations: no SBT index written by hand.
        let sbt = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss_for::<ShadowedRadiance, _>(&miss, ())
            .miss_for::<Shadow, _>(&shadow_miss, ())
            .hit_for::<ShadowedRadiance, _>(0, &shade, ())
            .hit_for::<Shadow, _>(0, &shadow_hit, ())
            .build()?;
        let image = ctx.buffer::<u32>((SIZE * SIZE) as usize)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let params = Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(SIZE), scene: scene.handle() };
        pipeline.launch(&sbt, &params, [SIZE, SIZE, 1])?;
        let got = image.read()?;
        let mut shadowed = 0;
        let share = compare(&got, |pixel| {
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
        assert!(shadowed > 100, "the reference has only {shadowed} shadowed pixels");
        assert!(share >= 0.995, "only {:.2}% of pixels within 2/255", share * 100.0);
        Ok(())
    })
}

#[test]
fn instances_sharing_a_hit_program_read_their_own_sbt_records() -> anyhow::Result<()> {
    use programs_device::ColorRecord;
    with_context("instances_sharing_a_hit_program_read_their_own_sbt_records", |ctx| {
        let quad = [
            Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.0, 0.5, 0.0),
        ];
        let gas = Gas::triangles(ctx, &quad, None)?;
        let places = [Vec3::new(-0.9, -0.9, 0.0), Vec3::new(0.3, -0.6, 0.0), Vec3::new(-0.3, 0.35, 0.0), Vec3::new(0.4, 0.4, 0.0)];
        let colors = [Vec3::new(0.9, 0.1, 0.1), Vec3::new(0.1, 0.8, 0.2), Vec3::new(0.2, 0.3, 0.9), Vec3::new(0.7, 0.7, 0.1)];
        let instances: Vec<Instance> = places
            .iter()
            .enumerate()
            .map(|(i, p)| Instance::new(&gas).transform(Affine3A::from_translation(*p)).sbt_offset(i as u32))
            .collect();
        let scene = Ias::new(ctx, &instances)?;
        let module = module(ctx)?;
        let raygen = ProgramGroup::raygen(&module, programs_device::RG)?;
        let miss = ProgramGroup::miss(&module, programs_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(programs_device::RECORD_COLOR).build()?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
        let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ());
        for (i, color) in colors.iter().enumerate() {
            sbt = sbt.hit_for::<programs_device::Radiance, _>(i, &hit, ColorRecord { color: *color });
        }
        let sbt = sbt.build()?;
        let image = ctx.buffer::<u32>((SIZE * SIZE) as usize)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let params = Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(SIZE), scene: scene.handle() };
        pipeline.launch(&sbt, &params, [SIZE, SIZE, 1])?;
        let share = compare(&image.read()?, |pixel| {
            let (o, _) = ortho_ray(pixel, UVec2::splat(SIZE));
            places.iter().position(|p| o.x >= p.x && o.x <= p.x + 0.5 && o.y >= p.y && o.y <= p.y + 0.5).map(|i| colors[i])
        })?;
        assert!(share >= 0.995, "only {:.2}% of instance pixels within 2/255", share * 100.0);
        // A hole in the hit region is refused.
        let err = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit_at(1, &hit, ColorRecord { color: Vec3::ONE }).build().err();
        assert!(matches!(err, Some(Error::SbtHole { region: "hit", index: 0 })), "{err:?}");
        Ok(())
    })
}
