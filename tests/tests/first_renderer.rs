//! The README's first renderer (`examples/first_renderer`) against an
//! independent path tracer written here in plain f64 Rust (its own sphere
//! test, camera, random numbers and material sampling, the same scene and
//! material model), on each backend: every 8×8 block's mean radiance agrees
//! within 5 combined standard errors per channel, the errors estimated from the
//! spread of each pixel's batches (radiance is at most 1: no heavy tails).

use first_renderer::{camera, scene, Group};
use first_renderer_device::{DIFFUSE, GLASS, MAX_DEPTH, METAL};
use raykit::glam::{DVec3, UVec2, Vec4};
use raykit_tests::with_each_backend;

const SIZE: UVec2 = UVec2::new(64, 48);
/// Batches (launches) and samples per pixel in each.
const BATCHES: u32 = 4;
const SAMPLES: u32 = 16;

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
    /// A point in the unit ball, by rejection.
    fn in_ball(&mut self) -> DVec3 {
        loop {
            let p = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
            if p.length_squared() < 1.0 {
                return p;
            }
        }
    }
}

/// The nearest sphere hit past `1e-9`: distance, sphere centre and radius, group.
fn hit(groups: &[Group], o: DVec3, d: DVec3) -> Option<(f64, DVec3, f64, usize)> {
    let mut best: Option<(f64, DVec3, f64, usize)> = None;
    for (g, group) in groups.iter().enumerate() {
        for &(c, r) in &group.spheres {
            let (c, r) = (c.as_dvec3(), r as f64);
            let f = o - c;
            let (a, b, cc) = (d.dot(d), f.dot(d), f.dot(f) - r * r);
            let disc = b * b - a * cc;
            if disc < 0.0 {
                continue;
            }
            for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                if t > 1e-9 && best.is_none_or(|(bt, ..)| t < bt) {
                    best = Some((t, c, r, g));
                    break;
                }
            }
        }
    }
    best
}

/// One path's radiance (the material model of the device programs, written again).
fn radiance(groups: &[Group], mut o: DVec3, mut d: DVec3, rng: &mut Rng) -> DVec3 {
    let mut throughput = DVec3::ONE;
    for _ in 0..MAX_DEPTH {
        let Some((t, c, r, g)) = hit(groups, o, d) else {
            let s = 0.5 * (d.normalize().y + 1.0);
            return throughput * ((1.0 - s) * DVec3::ONE + s * DVec3::new(0.5, 0.7, 1.0));
        };
        let m = &groups[g].material;
        let unit = d.normalize();
        let p = o + t * d;
        let outward = (p - c) / r;
        let front = unit.dot(outward) < 0.0;
        let n = if front { outward } else { -outward };
        let mirror = unit - 2.0 * unit.dot(n) * n;
        let next = match m.kind {
            DIFFUSE => {
                // n + a uniform unit vector is cosine-distributed (the book's form).
                let v = loop {
                    let v = rng.in_ball();
                    if v.length_squared() > 1e-12 {
                        break v.normalize();
                    }
                };
                let s = n + v;
                if s.length_squared() < 1e-24 {
                    n
                } else {
                    s.normalize()
                }
            }
            METAL => {
                let s = (mirror + m.param as f64 * rng.in_ball()).normalize();
                if s.dot(n) <= 0.0 {
                    return DVec3::ZERO;
                }
                s
            }
            GLASS => {
                let eta = if front { 1.0 / m.param as f64 } else { m.param as f64 };
                let cos = (-unit.dot(n)).min(1.0);
                let sin = (1.0 - cos * cos).sqrt();
                let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
                let schlick = r0 + (1.0 - r0) * (1.0 - cos).powi(5);
                if eta * sin > 1.0 || rng.next() < schlick {
                    mirror
                } else {
                    let perpendicular = eta * (unit + cos * n);
                    perpendicular - (1.0 - perpendicular.length_squared()).abs().sqrt() * n
                }
            }
            other => panic!("material kind {other}"),
        };
        if m.kind != GLASS {
            throughput *= m.albedo.as_dvec3();
        }
        o = p;
        d = next;
    }
    DVec3::ZERO
}

/// The reference picture: each pixel's mean per batch.
fn reference() -> Vec<Vec<DVec3>> {
    let groups = scene();
    let cam = camera(SIZE.x, SIZE.y);
    let (eye, lens) = (cam.eye.as_dvec3(), cam.lens_radius as f64);
    let (right, up) = (cam.right.as_dvec3(), cam.up.as_dvec3());
    let (corner, h, v) = (cam.top_left.as_dvec3(), cam.horizontal.as_dvec3(), cam.vertical.as_dvec3());
    let mut rng = Rng(0x5eed);
    (0..SIZE.x * SIZE.y)
        .map(|i| {
            let (x, y) = ((i % SIZE.x) as f64, (i / SIZE.x) as f64);
            (0..BATCHES)
                .map(|_| {
                    let mut sum = DVec3::ZERO;
                    for _ in 0..SAMPLES {
                        let s = (x + rng.next()) / SIZE.x as f64;
                        let t = (y + rng.next()) / SIZE.y as f64;
                        let disk = loop {
                            let (a, b) = (2.0 * rng.next() - 1.0, 2.0 * rng.next() - 1.0);
                            if a * a + b * b < 1.0 {
                                break (a, b);
                            }
                        };
                        let origin = eye + lens * (disk.0 * right + disk.1 * up);
                        let focus = corner + s * h + t * v;
                        sum += radiance(&groups, origin, focus - origin, &mut rng);
                    }
                    sum / SAMPLES as f64
                })
                .collect()
        })
        .collect()
}

/// Per 8×8 block and channel: the mean of the pixels' means and its variance
/// (each pixel's variance of its mean from the spread of its batches).
fn blocks(pixels: &[Vec<DVec3>]) -> Vec<(DVec3, DVec3)> {
    let (bw, bh) = (SIZE.x / 8, SIZE.y / 8);
    (0..bw * bh)
        .map(|b| {
            let (bx, by) = (b % bw, b / bw);
            let (mut mean, mut var) = (DVec3::ZERO, DVec3::ZERO);
            for y in 0..8 {
                for x in 0..8 {
                    let batches = &pixels[((by * 8 + y) * SIZE.x + bx * 8 + x) as usize];
                    let k = batches.len() as f64;
                    let m = batches.iter().sum::<DVec3>() / k;
                    let s2 = batches.iter().map(|v| (*v - m) * (*v - m)).sum::<DVec3>() / (k - 1.0);
                    mean += m / 64.0;
                    var += s2 / k / (64.0 * 64.0);
                }
            }
            (mean, var)
        })
        .collect()
}

/// The device's pixels per batch, from the sums after each launch.
fn batches(steps: &[Vec<Vec4>]) -> Vec<Vec<DVec3>> {
    (0..steps[0].len())
        .map(|p| {
            (0..steps.len())
                .map(|k| {
                    let before = if k == 0 { Vec4::ZERO } else { steps[k - 1][p] };
                    let d = steps[k][p] - before;
                    d.truncate().as_dvec3() / d.w as f64
                })
                .collect()
        })
        .collect()
}

#[test]
fn the_first_renderer_matches_a_plain_rust_path_tracer() -> anyhow::Result<()> {
    let want = blocks(&reference());
    with_each_backend("the_first_renderer_matches_a_plain_rust_path_tracer", |ctx, _| {
        let steps = first_renderer::render(ctx, SIZE, SAMPLES, BATCHES)?;
        anyhow::ensure!(steps.len() == BATCHES as usize, "{} launches", steps.len());
        let last = steps.last().ok_or_else(|| anyhow::anyhow!("no launch"))?;
        anyhow::ensure!(last.iter().all(|p| p.w == (SAMPLES * BATCHES) as f32), "sample counts");
        let got = blocks(&batches(&steps));
        let mut worst = 0.0f64;
        for (b, ((gm, gv), (wm, wv))) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                // Blocks of sky alone have no noise: f32 rounding is the floor.
                let z = (gm[c] - wm[c]).abs() / (gv[c] + wv[c]).sqrt().max(1e-5);
                worst = worst.max(z);
                anyhow::ensure!(z < 5.0, "block {b} channel {c}: {} against {} ({z:.1} standard errors)", gm[c], wm[c]);
            }
        }
        // The scene is not black: the comparison has something to compare.
        anyhow::ensure!(got.iter().all(|(m, _)| m.min_element() > 0.05), "a black block");
        println!("worst block: {worst:.2} standard errors");
        Ok(())
    })
}
