//! Motion blur in software (`Gas::moving_spheres`, `raykit_device::motion`):
//! the picture of moving spheres, one orthographic ray per sample through each
//! pixel's centre at a random time, against the exact time average computed
//! here in f64 (for a pixel centre `p` the fraction of `[0, 1]` during which
//! `|p − c(t)| < r`, `c` linear in `t`: a quadratic's interval). On each backend:
//! * every 8×8 block's mean within 5 standard errors of the exact mean (the
//!   samples are Bernoulli: the variance of a pixel's fraction is `f (1 − f) / n`);
//! * pixels the sweep never covers are exactly 0 and those it always covers
//!   exactly 1 (a box around only one end of the sweep would fail here);
//! * a fixed time (0, then 1) gives the still picture at that end, exactly away
//!   from the rims, and that picture is far from the time average: the
//!   comparison sees motion.
//!
//! The rays go along `−z` exactly (`-Vec3::Z`, whose other components are
//! `−0.0`): axis-aligned rays with signed zeros, as well.
//!
//! Bad moving spheres are refused with typed errors.

use raykit::glam::{DVec2, UVec2, Vec2, Vec3};
use raykit::{AccelError, Error, Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use raykit_tests::with_each_backend;
use spheres_test_device::{MotionParams, MovingRecord};

const WIDTH: u32 = 128;
const HEIGHT: u32 = 80;
const SAMPLES: u32 = 64;
const CORNER: Vec2 = Vec2::new(-2.0, -1.25);
const PIXEL: f32 = 1.0 / 32.0;

/// The instance's translation (in `x`, `y`; the picture is orthographic in `z`).
const SHIFT: Vec3 = Vec3::new(0.25, 0.0, -1.0);

/// The spheres, in object space: start centre, end centre, radius. One moves
/// diagonally, one stands still (start = end), one moves fast and small.
fn spheres() -> Vec<(Vec3, Vec3, f32)> {
    vec![
        (Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.3, 0.0), 0.5),
        (Vec3::new(0.6, -0.7, 0.0), Vec3::new(0.6, -0.7, 0.0), 0.3),
        (Vec3::new(-1.6, 0.8, 0.5), Vec3::new(0.2, 0.9, -0.5), 0.2),
    ]
}

/// The times in `[0, 1]` at which the world-space pixel centre `p` lies within
/// `radius` of the moving centre, as an interval (possibly empty).
fn covered(p: DVec2, start: DVec2, end: DVec2, radius: f64) -> (f64, f64) {
    // |p − start − t Δ|² < r²: a t² − 2 b t + c < 0.
    let (f, delta) = (p - start, end - start);
    let (a, b, c) = (delta.length_squared(), f.dot(delta), f.length_squared() - radius * radius);
    if a == 0.0 {
        return if c < 0.0 { (0.0, 1.0) } else { (0.0, 0.0) };
    }
    let disc = b * b - a * c;
    if disc <= 0.0 {
        return (0.0, 0.0);
    }
    let (t0, t1) = ((b - disc.sqrt()) / a, (b + disc.sqrt()) / a);
    (t0.clamp(0.0, 1.0), t1.clamp(0.0, 1.0))
}

/// The exact fraction of the shutter during which pixel `i`'s ray hits a
/// sphere of radius `radius + grow`, or (with `at`) whether it hits at that time.
fn exact(i: usize, grow: f64, at: Option<f64>) -> f64 {
    let (x, y) = ((i % WIDTH as usize) as f64, (i / WIDTH as usize) as f64);
    let p = CORNER.as_dvec2() + (DVec2::new(x, y) + 0.5) * PIXEL as f64;
    let shift = SHIFT.truncate().as_dvec2();
    let mut intervals: Vec<(f64, f64)> = spheres()
        .iter()
        .map(|&(s, e, r)| {
            let (s, e) = (s.truncate().as_dvec2() + shift, e.truncate().as_dvec2() + shift);
            match at {
                Some(t) => {
                    let c = s + t * (e - s);
                    if (p - c).length() < r as f64 + grow {
                        (0.0, 1.0)
                    } else {
                        (0.0, 0.0)
                    }
                }
                None => covered(p, s, e, r as f64 + grow),
            }
        })
        .filter(|(a, b)| b > a)
        .collect();
    // The union's length.
    intervals.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut length, mut reached) = (0.0, 0.0f64);
    for (a, b) in intervals {
        let a = a.max(reached);
        if b > a {
            length += b - a;
            reached = b;
        }
    }
    length
}

/// The picture on `ctx`: per pixel the fraction of its samples that hit, at
/// random times or all at `fixed_time`.
fn render(ctx: &raykit::Context, fixed_time: Option<f32>) -> anyhow::Result<Vec<f32>> {
    let all = spheres();
    let start: Vec<Vec3> = all.iter().map(|s| s.0).collect();
    let end: Vec<Vec3> = all.iter().map(|s| s.1).collect();
    let radii: Vec<f32> = all.iter().map(|s| s.2).collect();
    let gas = Gas::moving_spheres(ctx, &start, &end, &radii)?;
    anyhow::ensure!(gas.sphere_buffer().is_none(), "moving spheres offer a still-sphere buffer");
    let spheres = gas.moving_sphere_buffer().ok_or_else(|| anyhow::anyhow!("no moving-sphere buffer"))?;
    let scene = Ias::new(ctx, &[Instance::new(&gas).transform(raykit::glam::Affine3A::from_translation(SHIFT))])?;
    drop(gas);

    let pixels = (WIDTH * HEIGHT) as usize;
    let (image, times) = (ctx.buffer::<f32>(pixels)?, ctx.buffer::<f32>(pixels)?);
    let module = Module::from_device_crate(ctx, "spheres-test-device")?;
    let raygen = ProgramGroup::raygen(&module, spheres_test_device::RG_MOTION)?;
    let miss = ProgramGroup::miss(&module, spheres_test_device::MS_MOTION)?;
    let hit = ProgramGroup::hit_group(&module)
        .intersection(spheres_test_device::IS_MOVING)
        .closest_hit(spheres_test_device::CH_MOTION)
        .build()?;
    let pipeline = Pipeline::<MotionParams>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let record = MovingRecord { spheres, times: times.handle() };
    let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, record).build()?;
    let params = MotionParams {
        image: image.handle(),
        times: times.handle(),
        corner: CORNER,
        pixel: PIXEL,
        samples: SAMPLES,
        fixed: fixed_time.is_some() as u32,
        fixed_time: fixed_time.unwrap_or(0.0),
        size: UVec2::new(WIDTH, HEIGHT),
        scene: scene.handle(),
    };
    pipeline.launch(&sbt, &params, [WIDTH, HEIGHT, 1])?;
    Ok(image.read()?)
}

/// The worst block's distance from the exact means, in standard errors.
fn worst_block(got: &[f32], want: &[f64]) -> f64 {
    let mut worst = 0.0f64;
    for (by, bx) in (0..HEIGHT / 8).flat_map(|by| (0..WIDTH / 8).map(move |bx| (by, bx))) {
        let (mut mean, mut exact_mean, mut variance) = (0.0, 0.0, 0.0);
        for p in (0..64).map(|k| ((by * 8 + k / 8) * WIDTH + bx * 8 + k % 8) as usize) {
            mean += got[p] as f64 / 64.0;
            exact_mean += want[p] / 64.0;
            variance += want[p] * (1.0 - want[p]) / SAMPLES as f64 / (64.0 * 64.0);
        }
        // Blocks the sweep covers never or always have no noise: f32 sums are the floor.
        worst = worst.max((mean - exact_mean).abs() / variance.sqrt().max(1e-6));
    }
    worst
}

#[test]
fn a_moving_spheres_picture_converges_to_its_time_average() -> anyhow::Result<()> {
    with_each_backend("a_moving_spheres_picture_converges_to_its_time_average", |ctx, _| {
        let pixels = (WIDTH * HEIGHT) as usize;
        let got = render(ctx, None)?;
        let want: Vec<f64> = (0..pixels).map(|i| exact(i, 0.0, None)).collect();
        // Away from the rims (1e-4, far beyond f32 rounding), exact.
        let (mut never, mut always, mut blurred) = (0, 0, 0);
        let bad: Vec<(usize, f32)> = got
            .iter()
            .enumerate()
            .filter(|(i, &g)| exact(*i, -1e-4, None) == 1.0 && g != 1.0)
            .map(|(i, &g)| (i, g))
            .collect();
        eprintln!("DEBUG {} bad: {:?}", bad.len(), &bad[..bad.len().min(40)]);
        for (i, &g) in got.iter().enumerate() {
            if exact(i, 1e-4, None) == 0.0 {
                anyhow::ensure!(g == 0.0, "pixel {i} is {g}, but no sphere ever covers it");
                never += 1;
            } else if exact(i, -1e-4, None) == 1.0 {
                anyhow::ensure!(g == 1.0, "pixel {i} is {g}, but a sphere covers it all the time");
                always += 1;
            } else if want[i] > 0.05 && want[i] < 0.95 {
                blurred += 1;
            }
        }
        anyhow::ensure!(
            never > 1000 && always > 200 && blurred > 1000,
            "{never} never, {always} always, {blurred} blurred"
        );
        let worst = worst_block(&got, &want);
        eprintln!(
            "moving spheres [{:?}]: worst 8x8 block {worst:.2} standard errors from the time average; \
             {blurred} pixels blurred, {never} never covered, {always} always",
            ctx.backend()
        );
        anyhow::ensure!(worst < 5.0, "a block is {worst:.1} standard errors from the time average");

        // One time for every sample: the still picture at that end of the shutter.
        for time in [0.0, 1.0] {
            let still = render(ctx, Some(time))?;
            for (i, &g) in still.iter().enumerate() {
                let (outer, inner) = (exact(i, 1e-4, Some(time as f64)), exact(i, -1e-4, Some(time as f64)));
                if outer == inner {
                    anyhow::ensure!(g as f64 == outer, "time {time}: pixel {i} is {g}, the still picture {outer}");
                }
            }
            let far = worst_block(&still, &want);
            anyhow::ensure!(far > 20.0, "the still picture at time {time} is only {far:.1} standard errors off");
        }
        Ok(())
    })
}

#[test]
fn bad_moving_spheres_are_refused_with_typed_errors() -> anyhow::Result<()> {
    with_each_backend("bad_moving_spheres_are_refused_with_typed_errors", |ctx, _| {
        let ok = [Vec3::ZERO, Vec3::X];
        match Gas::moving_spheres(ctx, &ok, &ok[..1], &[1.0, 1.0]) {
            Err(Error::Accel(AccelError::MovingSphereCount { start: 2, end: 1 })) => {}
            other => anyhow::bail!("two starts and one end: {other:?}"),
        }
        match Gas::moving_spheres(ctx, &ok, &[Vec3::ZERO, Vec3::splat(f32::NAN)], &[1.0, 1.0]) {
            Err(Error::Accel(AccelError::InvalidSphere { sphere: 1, .. })) => {}
            other => anyhow::bail!("a NaN end centre: {other:?}"),
        }
        match Gas::moving_spheres(ctx, &ok, &ok, &[1.0]) {
            Err(Error::Accel(AccelError::SphereCount { centres: 2, radii: 1 })) => {}
            other => anyhow::bail!("one radius for two spheres: {other:?}"),
        }
        match Gas::moving_spheres(ctx, &[Vec3::new(f32::MAX, 0.0, 0.0)], &[Vec3::ZERO], &[f32::MAX]) {
            Err(Error::Accel(AccelError::InvalidSphere { sphere: 0, .. })) => {}
            other => anyhow::bail!("a sweep past f32: {other:?}"),
        }
        Ok(())
    })
}
