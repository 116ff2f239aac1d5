//! A pinhole camera as sutil's `Camera`: eye, look-at point, up and vertical
//! field of view, turned into the `(u, v, w)` frame device programs build rays
//! from (`direction = normalize(x·u + y·v + w)` for `x, y ∈ [-1, 1]`, +y up).

use glam::Vec3;

/// A pinhole camera.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Camera {
    /// Position.
    pub eye: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_degrees: f32,
}

impl Camera {
    /// The `(u, v, w)` basis of sutil's `Camera::UVWFrame` for an image of
    /// `aspect` = width / height: `w` from the eye to the look-at point, `u`
    /// (right) and `v` (up) scaled to half the image plane at that distance.
    pub fn uvw(&self, aspect: f32) -> (Vec3, Vec3, Vec3) {
        let w = self.look_at - self.eye;
        let w_len = w.length();
        let u = w.cross(self.up).normalize();
        let v = u.cross(w).normalize();
        let v_len = w_len * (0.5 * self.fov_y_degrees.to_radians()).tan();
        let u_len = v_len * aspect;
        (u * u_len, v * v_len, w)
    }

    /// The unit direction through `(x, y)` of the image plane, both in
    /// `[-1, 1]` with +y up, for an image of `aspect`.
    pub fn direction(&self, aspect: f32, x: f32, y: f32) -> Vec3 {
        let (u, v, w) = self.uvw(aspect);
        (x * u + y * v + w).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frame_spans_the_field_of_view() {
        let camera = Camera { eye: Vec3::new(0.0, 0.0, 2.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 90.0 };
        let (u, v, w) = camera.uvw(2.0);
        assert!((w - Vec3::new(0.0, 0.0, -2.0)).length() < 1e-6);
        // 90°: the half height equals the distance, the half width twice that.
        assert!((v - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5, "{v}");
        assert!((u - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-5, "{u}");
        let top = camera.direction(2.0, 0.0, 1.0);
        assert!((top.angle_between(-Vec3::Z).to_degrees() - 45.0).abs() < 1e-3);
    }
}
