//! The three materials of *Ray Tracing in One Weekend* as scattering functions
//! over a [`SurfaceHit`]: [`lambertian`], [`metal`] and [`dielectric`]. Each
//! picks the direction a path leaves the surface in (or `None`: the path is
//! absorbed); the attenuation is the material's colour, which the program knows.
//! A closest-hit program of a path tracer is then a choice of one of them and
//! a [`Bounce::scatter_from`](crate::bounce::Bounce::scatter_from):
//!
//! ```
//! use raykit_device::bounce::Bounce;
//! use raykit_device::glam::Vec3;
//! use raykit_device::sampling::Pcg;
//! use raykit_device::scatter;
//! use raykit_device::sphere::SurfaceHit;
//!
//! // A hit on the top of the unit sphere by a ray going down at 45°.
//! let surface = SurfaceHit { position: Vec3::Y, normal: Vec3::Y, front_face: true, error: 0.0 };
//! let incoming = Vec3::new(1.0, -1.0, 0.0);
//! let mut bounce = Bounce::new(Pcg::new(1, 2));
//! let direction = scatter::metal(&surface, incoming, 0.0, &mut bounce.rng); // a perfect mirror
//! assert!((direction.unwrap() - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
//! bounce.scatter_from(&surface, direction, Vec3::splat(0.8));
//! assert!(bounce.origin.y > 1.0); // the next ray starts above the surface
//! ```
//!
//! Directions need not be normalised; every result is a unit vector on the
//! side of the surface the path continues on.

use spirv_std::glam::Vec3;

use crate::optics::{reflect, refract, schlick};
use crate::sampling::Pcg;
use crate::sphere::SurfaceHit;

/// A diffuse (Lambertian) surface: a cosine-distributed direction around the
/// normal on the side the ray came from.
pub fn lambertian(surface: &SurfaceHit, rng: &mut Pcg) -> Vec3 {
    rng.cosine_around(surface.facing_normal())
}

/// A metal: the mirror direction of `direction`, moved by a random point of
/// the ball of radius `fuzz` (0 for a perfect mirror) and normalised; `None`
/// when that points into the surface (the book absorbs such paths).
pub fn metal(surface: &SurfaceHit, direction: Vec3, fuzz: f32, rng: &mut Pcg) -> Option<Vec3> {
    let n = surface.facing_normal();
    let scattered = (reflect(direction.normalize(), n) + fuzz * rng.in_unit_sphere()).normalize();
    if scattered.dot(n) > 0.0 {
        Some(scattered)
    } else {
        None
    }
}

/// A dielectric (glass, water) of index of refraction `ior` inside the surface
/// and 1 outside: the mirror direction with Schlick's reflectance or under
/// total internal reflection, the refracted direction (Snell's law) otherwise.
/// A path through it keeps all its light: attenuate by white.
pub fn dielectric(surface: &SurfaceHit, direction: Vec3, ior: f32, rng: &mut Pcg) -> Vec3 {
    let d = direction.normalize();
    let n = surface.facing_normal();
    let eta = if surface.front_face { 1.0 / ior } else { ior };
    let reflects = rng.next_f32() < schlick(-d.dot(n), eta);
    match refract(d, n, eta) {
        Some(refracted) if !reflects => refracted,
        _ => reflect(d, n),
    }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::glam::DVec3;

    const N: usize = 40_000;

    fn surface(normal: Vec3, front_face: bool) -> SurfaceHit {
        SurfaceHit { position: Vec3::ZERO, normal, front_face, error: 0.0 }
    }

    /// A mean of `n` samples of values in [0, 1] within 5 standard errors of `want`.
    fn assert_mean(sum: f64, sum_squares: f64, n: usize, want: f64, what: &str) {
        let mean = sum / n as f64;
        let se = ((sum_squares / n as f64 - mean * mean).max(0.0) / n as f64).sqrt().max(1e-9);
        assert!((mean - want).abs() < 5.0 * se, "{what}: {mean} against {want} ({se} standard error)");
    }

    #[test]
    fn lambertian_directions_are_cosine_distributed_on_the_side_of_the_ray() {
        let normal = Vec3::new(1.0, 2.0, -2.0).normalize();
        for front_face in [true, false] {
            let s = surface(normal, front_face);
            let facing = if front_face { normal } else { -normal };
            let mut rng = Pcg::new(7, front_face as u32);
            let (mut sum, mut squares) = (0.0, 0.0);
            for _ in 0..N {
                let d = lambertian(&s, &mut rng);
                assert!((d.length() - 1.0).abs() < 1e-5);
                let cos = d.dot(facing) as f64;
                assert!(cos >= -1e-6, "a diffuse direction below the surface: {cos}");
                (sum, squares) = (sum + cos, squares + cos * cos);
            }
            // E[cos θ] under the density cos θ / π is 2/3.
            assert_mean(sum, squares, N, 2.0 / 3.0, "mean cosine");
        }
    }

    #[test]
    fn metal_mirrors_blurs_by_fuzz_and_absorbs_below_the_surface() {
        let s = surface(Vec3::Y, true);
        let mut rng = Pcg::new(3, 4);
        // Unnormalised incoming direction, perfect mirror: exact reflection.
        let d = metal(&s, Vec3::new(2.0, -1.0, 0.5), 0.0, &mut rng).expect("a mirror reflects");
        let want = DVec3::new(2.0, 1.0, 0.5).normalize();
        assert!((d.as_dvec3() - want).length() < 1e-6, "{d}");
        // Fuzz 0.3 at 45°: unit directions within 0.3 of the mirror direction (before normalising).
        let mirror = Vec3::new(1.0, 1.0, 0.0).normalize();
        for _ in 0..N {
            let d = metal(&s, Vec3::new(1.0, -1.0, 0.0), 0.3, &mut rng).expect("45° with fuzz 0.3 stays above");
            assert!((d.length() - 1.0).abs() < 1e-5 && d.angle_between(mirror) <= (0.3f32).asin() + 1e-4);
        }
        // Grazing incidence with a large fuzz: some paths point into the surface and are absorbed, none below.
        let (mut absorbed, mut kept) = (0, 0);
        for _ in 0..N {
            match metal(&s, Vec3::new(1.0, -0.05, 0.0), 0.8, &mut rng) {
                Some(d) => {
                    assert!(d.y > 0.0);
                    kept += 1;
                }
                None => absorbed += 1,
            }
        }
        assert!(absorbed > N / 10 && kept > N / 10, "{absorbed} absorbed, {kept} kept");
    }

    #[test]
    fn dielectric_reflects_with_schlicks_probability_and_refracts_by_snell() {
        let ior = 1.5f64;
        let mut rng = Pcg::new(9, 1);
        for (front_face, incidence) in [(true, 0.0f64), (true, 60.0), (false, 20.0)] {
            // Outward normal +y; from outside the ray comes down, from inside it goes up.
            let s = surface(Vec3::Y, front_face);
            let (sin, cos) = incidence.to_radians().sin_cos();
            let d = if front_face { DVec3::new(sin, -cos, 0.0) } else { DVec3::new(sin, cos, 0.0) };
            let eta = if front_face { 1.0 / ior } else { ior };
            // Schlick's reflectance in f64, written again.
            let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
            let reflectance = r0 + (1.0 - r0) * (1.0 - cos).powi(5);
            let (mut reflected, mut squares) = (0.0, 0.0);
            for _ in 0..N {
                let out = dielectric(&s, (3.0 * d).as_vec3(), ior as f32, &mut rng).as_dvec3();
                assert!((out.length() - 1.0).abs() < 1e-5);
                let is_reflection = out.y * d.y < 0.0;
                if is_reflection {
                    assert!((out - DVec3::new(d.x, -d.y, 0.0)).length() < 1e-5, "not the mirror direction: {out}");
                } else {
                    // Snell: sin θt = eta sin θi, on the far side.
                    assert!((out.x - eta * sin).abs() < 1e-5 && out.z.abs() < 1e-6, "not refracted: {out}");
                }
                let r = is_reflection as u32 as f64;
                (reflected, squares) = (reflected + r, squares + r);
            }
            assert_mean(reflected, squares, N, reflectance, "reflected fraction");
        }
        // From inside past the critical angle (41.8° for 1.5): always the mirror direction.
        let s = surface(Vec3::Y, false);
        let d = Vec3::new(0.8, 0.6, 0.0);
        for _ in 0..1000 {
            assert!((dielectric(&s, d, 1.5, &mut rng) - Vec3::new(0.8, -0.6, 0.0)).length() < 1e-6);
        }
    }
}
