//! The reference of `examples/next_week`'s test: its scene (*The Next Week*'s
//! final scene as the example builds it) described again and path-traced in
//! plain f64 Rust, sharing no code with raykit: its own camera, box, quad and
//! sphere tests, random numbers (SplitMix64), materials and media. Per pixel
//! it returns the mean radiance and the variance of one sample, for the test's
//! block statistics. Compiled optimised in every profile (the workspace's
//! `Cargo.toml`): it traces millions of paths.

use glam::{DAffine3, DQuat, DVec3};

/// Traces a path takes at most (the example's `BOUNCES`).
pub const BOUNCES: u32 = 16;
/// The smoke's density and albedo, and its glass ball (centre, radius).
const SMOKE: (f64, DVec3) = (0.2, DVec3::new(0.2, 0.4, 0.9));
const SMOKE_BALL: (DVec3, f64) = (DVec3::new(360.0, 150.0, 145.0), 70.0);
/// The fog's density (white), and the ball that holds it.
const FOG_DENSITY: f64 = 0.0001;
const FOG_RADIUS: f64 = 5000.0;
/// Hits closer than this along a unit ray are the surface the ray left.
const T_MIN: f64 = 1e-4;

#[derive(Copy, Clone)]
enum Material {
    Lambertian(DVec3),
    Metal(DVec3, f64),
    Glass(f64),
    Light(DVec3),
    /// Squares of a side, the colour of the odd ones (the others white 0.9).
    Checker(f64, DVec3),
}

/// An axis-aligned box: its lowest and highest corners.
type Bounds = (DVec3, DVec3);

/// A sphere: centre at time 0, its velocity over the shutter, radius, material.
struct Sphere(DVec3, DVec3, f64, Material);

/// The scene: spheres in world space, the ground's boxes (min, max), the
/// light's rectangle at height `LIGHT_Y`, and the cluster in its own frame.
struct Scene {
    spheres: Vec<Sphere>,
    /// Per row of the ground (fixed x), its bounds and its 20 boxes.
    rows: Vec<(Bounds, Vec<Bounds>)>,
    /// The cluster's frame (object to world), its inverse, and its cells: bounds and centres.
    cluster: (DAffine3, DAffine3, Vec<(Bounds, Vec<DVec3>)>),
}

const LIGHT_Y: f64 = 554.0;
const LIGHT: (f64, f64, f64, f64) = (123.0, 423.0, 147.0, 412.0);
const GROUND: Material = Material::Lambertian(DVec3::new(0.48, 0.83, 0.53));
const CLUSTER: Material = Material::Lambertian(DVec3::splat(0.73));

fn scene() -> Scene {
    let v = DVec3::new;
    let still = DVec3::ZERO;
    let spheres = vec![
        Sphere(v(400.0, 400.0, 200.0), v(30.0, 0.0, 0.0), 50.0, Material::Lambertian(v(0.7, 0.3, 0.1))),
        Sphere(v(260.0, 150.0, 45.0), still, 50.0, Material::Glass(1.5)),
        Sphere(SMOKE_BALL.0, still, SMOKE_BALL.1, Material::Glass(1.5)),
        Sphere(v(0.0, 150.0, 145.0), still, 50.0, Material::Metal(v(0.8, 0.8, 0.9), 1.0)),
        Sphere(v(400.0, 200.0, 400.0), still, 100.0, Material::Checker(20.0, v(0.2, 0.3, 0.1))),
        Sphere(v(220.0, 280.0, 300.0), still, 80.0, Material::Checker(10.0, v(0.6, 0.2, 0.2))),
    ];
    let rows = (0..20)
        .map(|i| {
            let boxes: Vec<Bounds> = (0..20)
                .map(|j| {
                    let (x, z) = (-1000.0 + 100.0 * i as f64, -1000.0 + 100.0 * j as f64);
                    let height = 1.0 + 5.0 * ((7 * i + 13 * j) % 20) as f64;
                    (v(x, 0.0, z), v(x + 100.0, height, z + 100.0))
                })
                .collect();
            let top = boxes.iter().map(|b| b.1.y).fold(0.0, f64::max);
            ((v(boxes[0].0.x, 0.0, -1000.0), v(boxes[0].1.x, top, 1000.0)), boxes)
        })
        .collect();
    // The example's generator, in its own f32 arithmetic (the scene's description).
    let mut state = 1u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((state >> 8) as f32 / 16_777_216.0 * 165.0) as f64
    };
    let centres: Vec<DVec3> = (0..1000).map(|_| v(next(), next(), next())).collect();
    let mut cells: Vec<(Bounds, Vec<DVec3>)> = (0..64).map(|_| ((DVec3::MAX, DVec3::MIN), Vec::new())).collect();
    for c in centres {
        let k = (c / 165.0 * 4.0).floor().clamp(DVec3::ZERO, DVec3::splat(3.0));
        let cell = &mut cells[(k.x + 4.0 * k.y + 16.0 * k.z) as usize];
        cell.0 = (cell.0 .0.min(c - 10.0), cell.0 .1.max(c + 10.0));
        cell.1.push(c);
    }
    let frame =
        DAffine3::from_rotation_translation(DQuat::from_rotation_y(15f64.to_radians()), v(-100.0, 270.0, 395.0));
    Scene { spheres, rows, cluster: (frame, frame.inverse(), cells) }
}

/// The entry distance of the ray into a box, if it meets it before `t_max`.
fn slab(o: DVec3, inv: DVec3, (lo, hi): Bounds, t_max: f64) -> Option<f64> {
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
    (near <= far && far > T_MIN && near < t_max).then_some(near)
}

/// The nearest root past `T_MIN` of a ray with a sphere.
fn sphere_t(o: DVec3, d: DVec3, centre: DVec3, radius: f64) -> Option<f64> {
    let f = o - centre;
    let (b, c) = (f.dot(d), f.dot(f) - radius * radius);
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    [-b - disc.sqrt(), -b + disc.sqrt()].into_iter().find(|&t| t > T_MIN)
}

/// The nearest hit of a unit ray at `time`: distance, outward normal, material.
fn hit(scene: &Scene, o: DVec3, d: DVec3, time: f64) -> Option<(f64, DVec3, Material)> {
    let mut best: Option<(f64, DVec3, Material)> = None;
    let closer = |best: &mut Option<(f64, DVec3, Material)>, t: f64, n: DVec3, m: Material| {
        if best.is_none_or(|b| t < b.0) {
            *best = Some((t, n, m));
        }
    };
    for s in &scene.spheres {
        let centre = s.0 + time * s.1;
        if let Some(t) = sphere_t(o, d, centre, s.2) {
            closer(&mut best, t, (o + t * d - centre) / s.2, s.3);
        }
    }
    let inv = d.recip();
    for (bounds, boxes) in &scene.rows {
        if slab(o, inv, *bounds, best.map_or(f64::INFINITY, |b| b.0)).is_none() {
            continue;
        }
        for &(lo, hi) in boxes {
            let (a, b) = ((lo - o) * inv, (hi - o) * inv);
            let (near, far) = (a.min(b), a.max(b));
            let (t0, t1) = (near.max_element(), far.min_element());
            if t0 > t1 || t1 <= T_MIN {
                continue;
            }
            // Entering: the axis of the last plane crossed; from inside: the first one left.
            let (t, axis) = if t0 > T_MIN { (t0, near.to_array()) } else { (t1, far.to_array()) };
            let k = (0..3).find(|&k| axis[k] == t).unwrap_or(0);
            let mut n = DVec3::ZERO;
            n[k] = if (o + t * d)[k] > (lo[k] + hi[k]) / 2.0 { 1.0 } else { -1.0 };
            closer(&mut best, t, n, GROUND);
        }
    }
    if d.y != 0.0 {
        let t = (LIGHT_Y - o.y) / d.y;
        let p = o + t * d;
        if t > T_MIN && p.x > LIGHT.0 && p.x < LIGHT.1 && p.z > LIGHT.2 && p.z < LIGHT.3 {
            closer(&mut best, t, -DVec3::Y, Material::Light(DVec3::splat(7.0)));
        }
    }
    let (frame, to_object, cells) = &scene.cluster;
    let (lo, ld) = (to_object.transform_point3(o), to_object.transform_vector3(d));
    let linv = ld.recip();
    for (bounds, centres) in cells {
        if centres.is_empty() || slab(lo, linv, *bounds, best.map_or(f64::INFINITY, |b| b.0)).is_none() {
            continue;
        }
        for &c in centres {
            if let Some(t) = sphere_t(lo, ld, c, 10.0) {
                closer(&mut best, t, frame.transform_vector3((lo + t * ld - c) / 10.0), CLUSTER);
            }
        }
    }
    best
}

/// SplitMix64: the reference's own random numbers.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn in_ball(&mut self) -> DVec3 {
        loop {
            let p = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            if p.length_squared() < 1.0 {
                return p;
            }
        }
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let p = self.in_ball();
            if p.length_squared() > 1e-12 {
                return p.normalize();
            }
        }
    }
}

/// One path's radiance from a unit ray at `time`: the light's, times the
/// attenuations on the way, if the path reaches it (the sky is black).
fn radiance(scene: &Scene, mut o: DVec3, mut d: DVec3, time: f64, rng: &mut Rng) -> DVec3 {
    let mut throughput = DVec3::ONE;
    for _ in 0..BOUNCES {
        let found = hit(scene, o, d, time);
        // Where the ray is just after its origin, which may lie on the smoke's glass.
        let smoky = (o + T_MIN * d - SMOKE_BALL.0).length() < SMOKE_BALL.1;
        let (density, albedo) = if smoky { SMOKE } else { (FOG_DENSITY, DVec3::ONE) };
        // A ray that escapes goes through the fog up to the fog's ball.
        let reach = found.map_or_else(|| sphere_t(o, d, DVec3::ZERO, FOG_RADIUS).unwrap_or(0.0), |h| h.0);
        let distance = -(1.0 - rng.next()).ln() / density;
        if distance < reach {
            throughput *= albedo;
            (o, d) = (o + distance * d, rng.unit());
            continue;
        }
        let Some((t, outward, material)) = found else { return DVec3::ZERO };
        let p = o + t * d;
        let front = d.dot(outward) < 0.0;
        let n = if front { outward } else { -outward };
        let mirror = d - 2.0 * d.dot(n) * n;
        let (next, colour) = match material {
            Material::Lambertian(c) => ((n + rng.unit()).normalize(), c),
            Material::Checker(side, c) => {
                let k = (p / side).floor();
                let odd = (k.x + k.y + k.z).rem_euclid(2.0) == 1.0;
                ((n + rng.unit()).normalize(), if odd { DVec3::splat(0.9) } else { c })
            }
            Material::Metal(c, fuzz) => {
                let s = (mirror + fuzz * rng.in_ball()).normalize();
                if s.dot(n) <= 0.0 {
                    return DVec3::ZERO;
                }
                (s, c)
            }
            Material::Glass(ior) => {
                let eta = if front { 1.0 / ior } else { ior };
                let cos = (-d.dot(n)).min(1.0);
                let sin = (1.0 - cos * cos).sqrt();
                let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
                let next = if eta * sin > 1.0 || rng.next() < r0 + (1.0 - r0) * (1.0 - cos).powi(5) {
                    mirror
                } else {
                    let perpendicular = eta * (d + cos * n);
                    perpendicular - (1.0 - perpendicular.length_squared()).abs().sqrt() * n
                };
                (next.normalize(), DVec3::ONE)
            }
            Material::Light(emitted) => return throughput * emitted,
        };
        throughput *= colour;
        (o, d) = (p, next);
    }
    DVec3::ZERO
}

/// Per pixel of a `width × height` picture, top row first: the mean radiance
/// of `spp` samples and the variance of one sample, through the example's
/// pinhole camera (from (478, 278, −600) at (278, 278, 0), 40° vertically),
/// each sample at a random shutter time; on `threads` threads.
pub fn render(width: u32, height: u32, spp: u32, threads: u32) -> Vec<(DVec3, DVec3)> {
    let scene = scene();
    let (eye, target) = (DVec3::new(478.0, 278.0, -600.0), DVec3::new(278.0, 278.0, 0.0));
    let half_height = (40f64.to_radians() / 2.0).tan();
    let half_width = half_height * width as f64 / height as f64;
    let back = (eye - target).normalize();
    let right = DVec3::Y.cross(back).normalize();
    let up = back.cross(right);
    let pixel = |i: u32| {
        let (x, y) = ((i % width) as f64, (i / width) as f64);
        let mut rng = Rng(0x5eed_0000 + i as u64 * 0x1_0000_0001);
        let (mut sum, mut squares) = (DVec3::ZERO, DVec3::ZERO);
        for _ in 0..spp {
            let (s, t) = ((x + rng.next()) / width as f64, (y + rng.next()) / height as f64);
            let d = -back + (2.0 * s - 1.0) * half_width * right + (1.0 - 2.0 * t) * half_height * up;
            let time = rng.next();
            let l = radiance(&scene, eye, d.normalize(), time, &mut rng);
            (sum, squares) = (sum + l, squares + l * l);
        }
        let n = spp as f64;
        let mean = sum / n;
        (mean, ((squares - n * mean * mean) / (n - 1.0)).max(DVec3::ZERO))
    };
    let pixels = width * height;
    let chunk = pixels.div_ceil(threads.max(1));
    std::thread::scope(|scope| {
        let workers: Vec<_> = (0..pixels)
            .step_by(chunk as usize)
            .map(|first| {
                let pixel = &pixel;
                scope.spawn(move || (first..(first + chunk).min(pixels)).map(pixel).collect::<Vec<_>>())
            })
            .collect();
        workers.into_iter().flat_map(|w| w.join().unwrap_or_default()).collect()
    })
}
