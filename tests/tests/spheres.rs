//! Built-in spheres (`Gas::spheres` and `raykit_device::sphere`) against an
//! analytic reference in plain f64 Rust, on each backend: random rays (cut by
//! their interval), rays from inside spheres, grazing rays just inside and
//! outside the rim, rays whose entries an any-hit program ignores (the exits
//! are hit), and a camera 13 units from a radius-1000 ground, as in the
//! final scene of *Ray Tracing in One Weekend*. For every hit: the sphere, the
//! face, the distance, the surface point within its error bound of the exact
//! sphere and the normal; and a bounce ray from the spawn origin, which must
//! never hit its own sphere again. Bad spheres are refused with typed errors.

use raykit::device::sampling::Pcg;
use raykit::glam::{Affine3A, DAffine3, DVec3, Quat, Vec3, Vec4};
use raykit::{AccelError, Error, Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use raykit_tests::with_each_backend;
use spheres_test_device::{Params, SphereRecord, HIT_WORDS, MISS, RAY_WORDS};

/// 2⁻²⁴.
const U: f64 = 1.0 / 16_777_216.0;

/// The spheres of the first GAS (identity instance): the ground and five more.
fn spheres_a() -> (Vec<Vec3>, Vec<f32>) {
    let centres = vec![
        Vec3::new(0.0, -1000.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(-4.0, 1.0, 0.0),
        Vec3::new(4.0, 1.0, 0.0),
        Vec3::new(2.0, 0.5, 2.5),
        Vec3::new(-2.0, 0.3, -2.0),
    ];
    (centres, vec![1000.0, 1.0, 1.0, 1.0, 0.5, 0.3])
}

/// The one sphere of the second GAS, in its object space.
const B_CENTRE: Vec3 = Vec3::new(0.5, 0.0, 0.0);
const B_RADIUS: f32 = 0.5;

/// The second instance's transform: scale 2, a rotation, a translation.
fn transform_b() -> Affine3A {
    Affine3A::from_scale_rotation_translation(
        Vec3::splat(2.0),
        Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7),
        Vec3::new(1.0, 2.0, -6.0),
    )
}

/// A sphere in world space, in f64, with the instance and primitive it is.
#[derive(Copy, Clone, Debug)]
struct WorldSphere {
    centre: DVec3,
    radius: f64,
    instance: u32,
    primitive: u32,
}

fn world_spheres() -> Vec<WorldSphere> {
    let (centres, radii) = spheres_a();
    let mut all: Vec<WorldSphere> = centres
        .iter()
        .zip(&radii)
        .enumerate()
        .map(|(i, (c, &r))| WorldSphere { centre: c.as_dvec3(), radius: r as f64, instance: 0, primitive: i as u32 })
        .collect();
    let t = DAffine3::from_cols_array(&transform_b().to_cols_array().map(f64::from));
    all.push(WorldSphere {
        centre: t.transform_point3(B_CENTRE.as_dvec3()),
        radius: 2.0 * B_RADIUS as f64,
        instance: 1,
        primitive: 0,
    });
    all
}

/// One ray of the test: origin, direction, interval.
#[derive(Copy, Clone, Debug)]
struct TestRay {
    origin: Vec3,
    direction: Vec3,
    t_min: f32,
    t_max: f32,
}

/// The analytic hit of a ray with one sphere, with what its f32 error depends on.
#[derive(Copy, Clone, Debug)]
struct Reference {
    t: f64,
    front: bool,
    sphere: WorldSphere,
    /// First-order bound on the error of an f32 `t` (see `tolerance`).
    t_tolerance: f64,
}

/// The roots of `|o + t d − c|² = r²` in f64 (textbook formula), and how far the
/// line passes from tangency (negative inside), relative to the radius.
fn roots(ray: &TestRay, s: &WorldSphere) -> (Option<(f64, f64, f64)>, f64) {
    let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
    let f = o - s.centre;
    let (a, b, c) = (d.dot(d), f.dot(d), f.dot(f) - s.radius * s.radius);
    let closest = (f - (b / a) * d).length();
    let margin = (closest - s.radius) / s.radius;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return (None, margin);
    }
    let sq = disc.sqrt();
    // f32 error of the stable form, to first order: the constant term (|f|² and
    // r² rounded) over |q|, the discriminant through its square root, the
    // object-space ray (rounded by the instance transform) and t itself.
    let q = b.abs() + sq;
    let tolerance = |t: f64| {
        16.0 * U
            * ((f.length_squared() + s.radius * s.radius) / q
                + s.radius * f.length() / sq
                + (o.length() + f.length()) / d.length()
                + t.abs())
    };
    let (t0, t1) = ((-b - sq) / a, (-b + sq) / a);
    (Some((t0, t1, tolerance(t0).max(tolerance(t1)))), margin)
}

/// The nearest hit in the ray's interval, or `None`; `Err` when the ray is too
/// close to an ambiguity (tangency, an interval end, two nearly equal hits) for
/// f32 to be held to one answer.
fn nearest(ray: &TestRay, spheres: &[WorldSphere], exits_only: bool) -> Result<Option<Reference>, ()> {
    let mut hits: Vec<Reference> = Vec::new();
    for s in spheres {
        let (found, margin) = roots(ray, s);
        if margin.abs() < 1e-4 {
            return Err(());
        }
        let Some((t0, t1, tol)) = found else { continue };
        for (t, front) in [(t0, true), (t1, false)] {
            let scale = tol + 1e-6 * t.abs();
            if (t - ray.t_min as f64).abs() < 4.0 * scale || (t - ray.t_max as f64).abs() < 4.0 * scale {
                return Err(());
            }
            if t >= ray.t_min as f64 && t <= ray.t_max as f64 && !(exits_only && front) {
                hits.push(Reference { t, front, sphere: *s, t_tolerance: tol });
            }
        }
    }
    hits.sort_by(|a, b| a.t.total_cmp(&b.t));
    if let [first, second, ..] = &hits[..] {
        if (second.t - first.t).abs() < 4.0 * (first.t_tolerance + second.t_tolerance) {
            return Err(());
        }
    }
    Ok(hits.first().copied())
}

/// What the device recorded for one ray.
#[derive(Copy, Clone, Debug)]
struct DeviceHit {
    t: f32,
    kind: u32,
    primitive: u32,
    instance: u32,
    position: Vec3,
    error: f32,
    normal: Vec3,
    front: bool,
    /// The bounce ray's `(t, kind, primitive, instance)`, kind -1 when none was traced.
    bounce: Vec4,
}

/// Traces `rays` with their bounce directions (zero for none) on `ctx`; with
/// `exits_only`, an any-hit program ignores every entry.
fn trace(ctx: &raykit::Context, rays: &[(TestRay, Vec3)], exits_only: bool) -> anyhow::Result<Vec<DeviceHit>> {
    let (centres, radii) = spheres_a();
    let gas_a = Gas::spheres(ctx, &centres, &radii)?;
    let gas_b = Gas::spheres(ctx, &[B_CENTRE], &[B_RADIUS])?;
    let records = [
        SphereRecord { spheres: gas_a.sphere_buffer().ok_or_else(|| anyhow::anyhow!("no sphere buffer"))? },
        SphereRecord { spheres: gas_b.sphere_buffer().ok_or_else(|| anyhow::anyhow!("no sphere buffer"))? },
    ];
    let scene = Ias::new(ctx, &[Instance::new(&gas_a), Instance::new(&gas_b).transform(transform_b()).sbt_offset(1)])?;
    // The IAS keeps the GASes and their spheres alive.
    drop((gas_a, gas_b));

    let module = Module::from_device_crate(ctx, "spheres-test-device")?;
    let raygen = ProgramGroup::raygen(&module, spheres_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, spheres_test_device::MS)?;
    let mut hit = ProgramGroup::hit_group(&module)
        .intersection(spheres_test_device::IS_SPHERE)
        .closest_hit(spheres_test_device::CH_SPHERE);
    if exits_only {
        hit = hit.any_hit(spheres_test_device::AH_IGNORE_ENTRIES);
    }
    let hit = hit.build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, ())
        .hit(&hit, records[0])
        .hit(&hit, records[1])
        .build()?;

    let words: Vec<Vec4> = rays
        .iter()
        .flat_map(|(r, bounce)| {
            let trace_bounce = if *bounce == Vec3::ZERO { 0.0 } else { 1.0 };
            [r.origin.extend(r.t_min), r.direction.extend(r.t_max), bounce.extend(trace_bounce)]
        })
        .collect();
    assert_eq!(words.len(), rays.len() * RAY_WORDS as usize);
    let input = ctx.buffer_from(&words)?;
    let output = ctx.buffer::<Vec4>(rays.len() * HIT_WORDS as usize)?;
    let params = Params { rays: input.handle(), hits: output.handle(), scene: scene.handle() };
    pipeline.launch(&sbt, &params, [rays.len() as u32, 1, 1])?;
    let out = output.read()?;
    Ok(out
        .chunks(HIT_WORDS as usize)
        .map(|w| DeviceHit {
            t: w[0].x,
            kind: w[0].y as u32,
            primitive: w[0].z as u32,
            instance: w[0].w as u32,
            position: w[1].truncate(),
            error: w[1].w,
            normal: w[2].truncate(),
            front: w[2].w == 1.0,
            bounce: w[3],
        })
        .collect())
}

/// A direction around unit `n`, cosine-distributed but at least 0.01 off the
/// tangent plane, so the exact answer (never this sphere again) has a margin.
fn outward(rng: &mut Pcg, n: DVec3) -> Vec3 {
    loop {
        let d = rng.cosine_around(n.as_vec3());
        if d.as_dvec3().dot(n) > 0.01 {
            return d;
        }
    }
}

/// Counts of what a check saw.
#[derive(Default, Debug)]
struct Seen {
    hits: usize,
    misses: usize,
    back_faces: usize,
    ambiguous: usize,
    bounces: usize,
}

/// Traces `rays` and checks each against the reference; returns what it saw.
fn check(ctx: &raykit::Context, name: &str, rays: &[TestRay], seed: u32) -> anyhow::Result<Seen> {
    check_with(ctx, name, rays, seed, false)
}

/// [`check`], with every entry ignored by an any-hit program when `exits_only`.
fn check_with(
    ctx: &raykit::Context,
    name: &str,
    rays: &[TestRay],
    seed: u32,
    exits_only: bool,
) -> anyhow::Result<Seen> {
    let spheres = world_spheres();
    let mut rng = Pcg::new(seed, 77);
    let references: Vec<Result<Option<Reference>, ()>> =
        rays.iter().map(|r| nearest(r, &spheres, exits_only)).collect();
    // Each hit bounces off along a direction outward from the exact normal.
    let with_bounces: Vec<(TestRay, Vec3)> = rays
        .iter()
        .zip(&references)
        .map(|(r, reference)| {
            let bounce = match reference {
                Ok(Some(h)) => {
                    let p = r.origin.as_dvec3() + h.t * r.direction.as_dvec3();
                    outward(&mut rng, (p - h.sphere.centre).normalize())
                }
                _ => Vec3::ZERO,
            };
            (*r, bounce)
        })
        .collect();
    let got = trace(ctx, &with_bounces, exits_only)?;
    let mut seen = Seen::default();
    for (i, ((ray, reference), hit)) in rays.iter().zip(&references).zip(&got).enumerate() {
        let Ok(reference) = reference else {
            seen.ambiguous += 1;
            continue;
        };
        let at = || format!("{name}: ray {i} {ray:?}: device {hit:?}, reference {reference:?}");
        let Some(want) = reference else {
            anyhow::ensure!(hit.kind == MISS, "{}: expected a miss", at());
            seen.misses += 1;
            continue;
        };
        anyhow::ensure!(hit.kind != MISS, "{}: expected a hit", at());
        seen.hits += 1;
        let s = want.sphere;
        anyhow::ensure!((hit.instance, hit.primitive) == (s.instance, s.primitive), "{}: another sphere", at());
        let kind = if want.front { raykit::device::sphere::FRONT_FACE } else { raykit::device::sphere::BACK_FACE };
        anyhow::ensure!(hit.kind == kind && hit.front == want.front, "{}: wrong face", at());
        seen.back_faces += usize::from(!want.front);
        let t_error = (hit.t as f64 - want.t).abs();
        anyhow::ensure!(t_error <= want.t_tolerance, "{}: t off by {t_error} > {}", at(), want.t_tolerance);
        // The point is on the sphere within its bound, and where the ray meets it.
        let on_surface = ((hit.position.as_dvec3() - s.centre).length() - s.radius).abs();
        anyhow::ensure!(on_surface <= hit.error as f64, "{}: {on_surface} off the surface", at());
        let d = ray.direction.as_dvec3();
        let exact = ray.origin.as_dvec3() + want.t * d;
        let along = want.t_tolerance * d.length() + hit.error as f64 + 1e-6 * exact.length();
        anyhow::ensure!((hit.position.as_dvec3() - exact).length() <= along, "{}: point off the ray", at());
        let normal_error = (hit.normal.as_dvec3() - (exact - s.centre) / s.radius).length();
        anyhow::ensure!(normal_error <= 1e-5 + 2.0 * along / s.radius, "{}: normal off by {normal_error}", at());
        // The bounce leaves the sphere: it never hits it again.
        let bounce = hit.bounce;
        anyhow::ensure!(bounce.y >= 0.0, "{}: no bounce traced", at());
        seen.bounces += 1;
        let again = bounce.y as u32 != MISS && (bounce.w as u32, bounce.z as u32) == (s.instance, s.primitive);
        anyhow::ensure!(!again, "{}: the bounce hit its own sphere again at t = {}", at(), bounce.x);
    }
    anyhow::ensure!(seen.ambiguous * 20 <= rays.len(), "{name}: {} of {} rays ambiguous", seen.ambiguous, rays.len());
    Ok(seen)
}

fn random_rays(rng: &mut Pcg, n: usize) -> Vec<TestRay> {
    (0..n)
        .map(|i| {
            let origin =
                Vec3::new(16.0 * rng.next_f32() - 8.0, 0.2 + 6.0 * rng.next_f32(), 16.0 * rng.next_f32() - 8.0);
            let target = Vec3::new(12.0 * rng.next_f32() - 6.0, 2.5 * rng.next_f32(), 12.0 * rng.next_f32() - 8.0);
            let direction = (target - origin) * (0.25 + 2.0 * rng.next_f32());
            let t_max = if i % 3 == 0 { 0.2 + 2.0 * rng.next_f32() } else { 1e30 };
            TestRay { origin, direction, t_min: if i % 2 == 0 { 0.0 } else { 0.05 }, t_max }
        })
        .collect()
}

#[test]
fn spheres_match_the_analytic_reference() -> anyhow::Result<()> {
    with_each_backend("spheres_match_the_analytic_reference", |ctx, _| {
        let mut rng = Pcg::new(1, 1);
        let seen = check(ctx, "random rays", &random_rays(&mut rng, 3000), 1)?;
        anyhow::ensure!(seen.hits > 1000 && seen.misses > 100 && seen.back_faces > 20, "random rays: {seen:?}");

        // From inside every sphere: the exit, seen from the back.
        let spheres = world_spheres();
        let inside: Vec<TestRay> = (0..600)
            .map(|i| {
                let s = spheres[i % spheres.len()];
                let r = s.radius.min(3.0) as f32;
                let origin = s.centre.as_vec3() + 0.9 * r * rng.in_unit_sphere();
                TestRay { origin, direction: rng.unit_vector() * (0.5 + rng.next_f32()), t_min: 0.0, t_max: 1e30 }
            })
            .collect();
        let seen = check(ctx, "inside", &inside, 2)?;
        anyhow::ensure!(seen.back_faces >= 500, "inside: {seen:?}");

        // Grazing: lines passing 1e-3 radii inside or outside the rim.
        let grazing: Vec<TestRay> = (0..800)
            .map(|i| {
                let s = spheres[1 + i % (spheres.len() - 1)];
                let d = rng.unit_vector().as_dvec3();
                let side = rng.unit_vector().as_dvec3();
                let perpendicular = (side - side.dot(d) * d).normalize();
                let offset = if i % 2 == 0 { 1.0 - 1e-3 } else { 1.0 + 1e-3 };
                // From two radii before the sphere to two after it: little else in the way.
                let origin = s.centre + perpendicular * (s.radius * offset) - d * (2.0 * s.radius);
                let t_max = (4.0 * s.radius) as f32;
                TestRay { origin: origin.as_vec3(), direction: d.as_vec3(), t_min: 0.0, t_max }
            })
            .collect();
        let seen = check(ctx, "grazing", &grazing, 3)?;
        anyhow::ensure!(seen.hits >= 300 && seen.misses >= 200, "grazing: {seen:?}");

        // An any-hit program that ignores every entry: the exits are hit instead.
        let seen = check_with(ctx, "entries ignored", &random_rays(&mut rng, 1500), 5, true)?;
        anyhow::ensure!(seen.hits > 500 && seen.back_faces == seen.hits, "entries ignored: {seen:?}");
        Ok(())
    })
}

#[test]
fn a_radius_1000_ground_under_a_camera_13_away() -> anyhow::Result<()> {
    with_each_backend("a_radius_1000_ground_under_a_camera_13_away", |ctx, _| {
        // The book's camera: from (13, 2, 3) at the origin, 20° field of view,
        // 3:2, with a lens of aperture 0.1 focused at 10 (defocus moves origins).
        let camera = raykit::device::camera::ThinLensCamera::look_at(
            Vec3::new(13.0, 2.0, 3.0),
            Vec3::ZERO,
            Vec3::Y,
            20.0,
            1.5,
            0.1,
            10.0,
        );
        let mut rng = Pcg::new(9, 9);
        let (w, h) = (96, 64);
        let rays: Vec<TestRay> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let jitter = rng.next_vec2();
                let r = camera.ray((x as f32 + jitter.x) / w as f32, (y as f32 + jitter.y) / h as f32, rng.next_vec2());
                TestRay { origin: r.origin, direction: r.direction, t_min: 0.001, t_max: 1e30 }
            })
            .collect();
        let seen = check(ctx, "ground", &rays, 4)?;
        anyhow::ensure!(seen.hits > w * h / 2 && seen.bounces == seen.hits, "ground: {seen:?}");
        Ok(())
    })
}

#[test]
fn bad_spheres_are_refused_with_typed_errors() -> anyhow::Result<()> {
    with_each_backend("bad_spheres_are_refused_with_typed_errors", |ctx, _| {
        let centres = [Vec3::ZERO, Vec3::X];
        for (radius, what) in [(f32::NAN, "NaN"), (-0.5, "negative"), (f32::INFINITY, "infinite")] {
            match Gas::spheres(ctx, &centres, &[1.0, radius]) {
                Err(Error::Accel(AccelError::InvalidSphere { sphere: 1, reason, .. })) => {
                    anyhow::ensure!(reason.contains(what), "radius {radius}: {reason}")
                }
                other => anyhow::bail!("radius {radius}: {other:?}"),
            }
        }
        match Gas::spheres(ctx, &[Vec3::new(f32::INFINITY, 0.0, 0.0)], &[1.0]) {
            Err(Error::Accel(AccelError::InvalidSphere { sphere: 0, .. })) => {}
            other => anyhow::bail!("infinite centre: {other:?}"),
        }
        match Gas::spheres(ctx, &centres, &[1.0]) {
            Err(Error::Accel(AccelError::SphereCount { centres: 2, radii: 1 })) => {}
            other => anyhow::bail!("counts: {other:?}"),
        }
        match Gas::spheres(ctx, &[], &[]) {
            Err(Error::Accel(AccelError::Empty { .. })) => {}
            other => anyhow::bail!("no spheres: {other:?}"),
        }
        // A sphere GAS is not refitted from boxes (its buffer would go stale).
        let mut gas = Gas::spheres(ctx, &centres, &[1.0, 2.0])?;
        anyhow::ensure!(gas.sphere_buffer().is_some() && gas.primitive_count() == 2);
        let boxes = [raykit::Aabb::around_sphere(Vec3::ZERO, 1.0)];
        match gas.update(&[raykit::Aabbs::new(&boxes).into()]) {
            Err(Error::Accel(AccelError::UpdateRefused { .. })) => {}
            other => anyhow::bail!("update: {other:?}"),
        }
        anyhow::ensure!(Gas::aabbs(ctx, &boxes)?.sphere_buffer().is_none());
        Ok(())
    })
}
