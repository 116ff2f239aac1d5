//! A thin-lens camera (defocus blur), as *Ray Tracing in One Weekend* builds it:
//! a lens of radius `aperture / 2` at the eye, focused on the plane at
//! `focus_distance`. With aperture 0 it is a pinhole camera.
//!
//! Made on the host (or the device) with [`ThinLensCamera::look_at`], it goes
//! into the launch params as a field (it derives [`LaunchParams`](macro@crate::LaunchParams),
//! so the layout check covers it), and raygen asks it for rays:
//!
//! ```
//! use raykit_device::camera::ThinLensCamera;
//! use raykit_device::glam::{Vec2, Vec3};
//! let camera = ThinLensCamera::look_at(Vec3::new(13.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y, 20.0, 1.5, 0.1, 10.0);
//! // Pixel (x, y) of a w × h image, jittered by `j` and with lens sample `u` (uniform in [0, 1)²):
//! let (x, y, w, h, j, u) = (10.0, 20.0, 300.0, 200.0, Vec2::splat(0.5), Vec2::new(0.3, 0.7));
//! let ray = camera.ray((x + j.x) / w, (y + j.y) / h, u);
//! assert!((ray.origin - Vec3::new(13.0, 2.0, 3.0)).length() <= 0.05 + 1e-6);
//! ```

use spirv_std::glam::{Vec2, Vec3};

use crate::math::tan;
use crate::ray::Ray;
use crate::sampling::{random_in_unit_disk, PI};

/// A thin-lens camera: where the lens is, the image on the plane of focus, and
/// the lens's radius. Plain data shared by host and device.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable, crate::LaunchParams)]
pub struct ThinLensCamera {
    /// The lens centre (the eye).
    pub eye: Vec3,
    /// The lens radius (half the aperture); 0 for a pinhole.
    pub lens_radius: f32,
    /// The image's top-left corner on the plane of focus.
    pub top_left: Vec3,
    /// The image's width on the plane of focus, left to right.
    pub horizontal: Vec3,
    /// The image's height on the plane of focus, top to bottom.
    pub vertical: Vec3,
    /// Unit vector to the image's right, in the lens plane.
    pub right: Vec3,
    /// Unit vector up the image, in the lens plane.
    pub up: Vec3,
}

impl ThinLensCamera {
    /// A camera at `eye` looking at `target` with `up` towards the image's
    /// top, a vertical field of view of `vfov_degrees`, width / height `aspect`,
    /// lens diameter `aperture` and the plane of focus at `focus_distance`
    /// along the view direction.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        vfov_degrees: f32,
        aspect: f32,
        aperture: f32,
        focus_distance: f32,
    ) -> ThinLensCamera {
        let half_height = tan(vfov_degrees * (PI / 180.0) * 0.5);
        let half_width = aspect * half_height;
        let back = (eye - target).normalize();
        let right = up.cross(back).normalize();
        let image_up = back.cross(right);
        let horizontal = (2.0 * half_width * focus_distance) * right;
        let vertical = (-2.0 * half_height * focus_distance) * image_up;
        let top_left = eye - focus_distance * back - 0.5 * horizontal - 0.5 * vertical;
        ThinLensCamera { eye, lens_radius: 0.5 * aperture, top_left, horizontal, vertical, right, up: image_up }
    }

    /// The ray through image point `(s, t)` (`s` from 0 at the left edge to 1
    /// at the right, `t` from 0 at the top to 1 at the bottom) from lens point
    /// `lens` (two uniform numbers in `[0, 1)`, mapped to the aperture disk).
    /// Every ray through `(s, t)` meets the plane of focus at the same point;
    /// the direction is not normalised.
    pub fn ray(&self, s: f32, t: f32, lens: Vec2) -> Ray {
        let disk = self.lens_radius * random_in_unit_disk(lens);
        let origin = self.eye + disk.x * self.right + disk.y * self.up;
        let focus = self.top_left + s * self.horizontal + t * self.vertical;
        Ray::new(origin, focus - origin)
    }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::sampling::Pcg;

    #[test]
    fn rays_through_a_pixel_meet_on_the_plane_of_focus() {
        let (eye, target) = (Vec3::new(13.0, 2.0, 3.0), Vec3::ZERO);
        let focus = 10.0;
        let camera = ThinLensCamera::look_at(eye, target, Vec3::Y, 20.0, 1.5, 0.6, focus);
        let view = (target - eye).normalize().as_dvec3();
        let mut rng = Pcg::new(60, 1);
        for _ in 0..200 {
            let (s, t) = (rng.next_f32(), rng.next_f32());
            let pinhole = camera.ray(s, t, Vec2::new(0.0, 0.0));
            // The pinhole ray's point on the plane of focus (view · (p − eye) = focus), in f64.
            let on_plane = |r: Ray| {
                let (o, d) = (r.origin.as_dvec3(), r.direction.as_dvec3());
                o + d * ((focus as f64 - view.dot(o - eye.as_dvec3())) / view.dot(d))
            };
            let want = on_plane(Ray { origin: eye, ..pinhole });
            for _ in 0..20 {
                let r = camera.ray(s, t, rng.next_vec2());
                let offset = (r.origin - eye).as_dvec3();
                assert!(offset.length() <= 0.3 + 1e-6, "origin outside the lens");
                assert!(offset.dot(view).abs() < 1e-6, "origin off the lens plane");
                assert!((on_plane(r) - want).length() < 1e-4, "rays of a pixel do not meet in focus");
            }
        }
    }

    #[test]
    fn pinhole_field_of_view_and_orientation() {
        let camera = ThinLensCamera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0, 2.0, 0.0, 3.0);
        let centre = camera.ray(0.5, 0.5, Vec2::new(0.9, 0.1));
        assert_eq!(centre.origin, Vec3::new(0.0, 0.0, 5.0));
        assert!((centre.direction.normalize() - Vec3::NEG_Z).length() < 1e-6);
        // Top to bottom spans 60°; left to right the aspect's wider angle.
        let (top, bottom) = (camera.ray(0.5, 0.0, Vec2::ZERO), camera.ray(0.5, 1.0, Vec2::ZERO));
        let angle = top.direction.angle_between(bottom.direction).to_degrees();
        assert!((angle - 60.0).abs() < 1e-3, "{angle}");
        assert!(top.direction.y > 0.0 && bottom.direction.y < 0.0);
        let (left, right) = (camera.ray(0.0, 0.5, Vec2::ZERO), camera.ray(1.0, 0.5, Vec2::ZERO));
        let want = 2.0 * (2.0 * (30f64.to_radians()).tan()).atan().to_degrees();
        assert!((left.direction.angle_between(right.direction).to_degrees() as f64 - want).abs() < 1e-3);
        assert!(left.direction.x < 0.0 && right.direction.x > 0.0);
    }
}
