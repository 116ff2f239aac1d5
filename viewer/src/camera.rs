//! The viewer's cameras: an orbit camera (drag turns the eye around the point
//! looked at, the wheel moves it closer or away) and a fly camera (drag turns the
//! view, WASD/QE move the eye), both over [`raykit_scene::Camera`]; and the
//! `--camera` text form, which round-trips every `f32` exactly.

use raykit::glam::{Quat, Vec3};
use raykit_scene::Camera;

use crate::error::{Result, ViewerError};

/// Radians a drag of one pixel turns the camera.
pub const RADIANS_PER_PIXEL: f32 = 0.005;
/// The factor one wheel step scales the orbit distance by.
pub const ZOOM_PER_STEP: f32 = 0.9;
/// How close (in degrees) the view may come to the up direction.
const POLE_MARGIN_DEGREES: f32 = 1.0;

/// How a drag moves the camera.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum CameraMode {
    /// Drag turns the eye around the point looked at; the wheel dollies.
    #[default]
    Orbit,
    /// Drag turns the view around the eye; WASD/QE (or the wheel) move the eye.
    Fly,
}

/// A camera and the way input moves it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CameraRig {
    camera: Camera,
    /// The mode of drags and the wheel.
    pub mode: CameraMode,
}

impl CameraRig {
    /// A rig starting at `camera`, in orbit mode.
    pub fn new(camera: Camera) -> CameraRig {
        CameraRig { camera, mode: CameraMode::Orbit }
    }

    /// The camera now.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// Puts the camera at `camera`.
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = camera;
    }

    /// A mouse drag of `(dx, dy)` pixels: orbit or look, by [`CameraRig::mode`].
    pub fn drag(&mut self, dx: f32, dy: f32) {
        match self.mode {
            CameraMode::Orbit => self.orbit(dx, dy),
            CameraMode::Fly => self.look(dx, dy),
        }
    }

    /// Turns the eye around the point looked at: `dx` pixels around the up
    /// direction, `dy` pixels over the top (stopping short of the poles).
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        let c = &mut self.camera;
        let offset = rotated(c.eye - c.look_at, c.up, -dx * RADIANS_PER_PIXEL, -dy * RADIANS_PER_PIXEL);
        c.eye = c.look_at + offset;
    }

    /// Turns the view around the eye (the fly camera's drag).
    pub fn look(&mut self, dx: f32, dy: f32) {
        let c = &mut self.camera;
        let direction = rotated(c.look_at - c.eye, c.up, -dx * RADIANS_PER_PIXEL, dy * RADIANS_PER_PIXEL);
        c.look_at = c.eye + direction;
    }

    /// `steps` wheel steps: in orbit mode the eye moves towards the point looked
    /// at (positive steps) or away, by [`ZOOM_PER_STEP`] per step; in fly mode
    /// it moves forward by a tenth of the distance to that point per step.
    pub fn zoom(&mut self, steps: f32) {
        let c = &mut self.camera;
        match self.mode {
            CameraMode::Orbit => c.eye = c.look_at + (c.eye - c.look_at) * ZOOM_PER_STEP.powf(steps),
            CameraMode::Fly => {
                let forward = (c.look_at - c.eye) * 0.1 * steps;
                c.eye += forward;
                c.look_at += forward;
            }
        }
    }

    /// Moves the eye and the point looked at together: `forward` along the view,
    /// `right` across it and `up` along the up direction, in scene units.
    pub fn translate(&mut self, forward: f32, right: f32, up: f32) {
        let c = &mut self.camera;
        let (f, r, u) = frame(c);
        let delta = f * forward + r * right + u * up;
        c.eye += delta;
        c.look_at += delta;
    }

    /// Scene units per second the fly keys move by: half the distance from the eye
    /// to the point looked at (so the speed suits the scene's scale).
    pub fn fly_speed(&self) -> f32 {
        0.5 * (self.camera.look_at - self.camera.eye).length()
    }
}

/// The unit forward, right and up directions of `c`.
fn frame(c: &Camera) -> (Vec3, Vec3, Vec3) {
    let forward = (c.look_at - c.eye).normalize_or_zero();
    let right = forward.cross(c.up).normalize_or_zero();
    (forward, right, c.up.normalize_or_zero())
}

/// `v` turned by `yaw` radians around `up`, then by `pitch` radians around the
/// horizontal axis across it, unless that brings it within the pole margin of `up`.
fn rotated(v: Vec3, up: Vec3, yaw: f32, pitch: f32) -> Vec3 {
    let up = up.normalize_or_zero();
    if up == Vec3::ZERO || v == Vec3::ZERO {
        return v;
    }
    let v = Quat::from_axis_angle(up, yaw) * v;
    let axis = v.cross(up).normalize_or_zero();
    if axis == Vec3::ZERO {
        return v;
    }
    let pitched = Quat::from_axis_angle(axis, pitch) * v;
    let angle = pitched.angle_between(up).to_degrees();
    if (POLE_MARGIN_DEGREES..=180.0 - POLE_MARGIN_DEGREES).contains(&angle) {
        pitched
    } else {
        v
    }
}

/// `camera` as `--camera` takes it: eye, look-at point, up and the vertical field
/// of view, ten comma-separated numbers (each the shortest text that reads back as
/// the same `f32`).
pub fn format_camera(camera: &Camera) -> String {
    let Camera { eye, look_at, up, fov_y_degrees } = camera;
    let numbers = [eye.x, eye.y, eye.z, look_at.x, look_at.y, look_at.z, up.x, up.y, up.z, *fov_y_degrees];
    numbers.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(",")
}

/// Reads a camera written by [`format_camera`].
pub fn parse_camera(value: &str) -> Result<Camera> {
    let error = |reason: String| ViewerError::Camera { value: value.to_owned(), reason };
    let numbers: Vec<f32> = value
        .split(',')
        .map(|n| n.trim().parse::<f32>().map_err(|e| error(format!("{:?} is not a number ({e})", n.trim()))))
        .collect::<Result<_>>()?;
    let [ex, ey, ez, lx, ly, lz, ux, uy, uz, fov] = numbers[..] else {
        return Err(error(format!("{} numbers", numbers.len())));
    };
    if numbers.iter().any(|n| !n.is_finite()) {
        return Err(error("every number must be finite".into()));
    }
    let camera = Camera {
        eye: Vec3::new(ex, ey, ez),
        look_at: Vec3::new(lx, ly, lz),
        up: Vec3::new(ux, uy, uz),
        fov_y_degrees: fov,
    };
    if camera.eye == camera.look_at {
        return Err(error("the eye is the point looked at".into()));
    }
    if camera.up == Vec3::ZERO || (camera.look_at - camera.eye).cross(camera.up) == Vec3::ZERO {
        return Err(error("the up direction is zero or along the view".into()));
    }
    if !(fov > 0.0 && fov < 180.0) {
        return Err(error(format!("the field of view {fov} is not between 0 and 180 degrees")));
    }
    // The frame the rays are made from, in f32: a distance from the eye to the
    // point looked at whose square overflows or underflows gives none.
    let (u, v, w) = camera.uvw(1.0);
    if !(u.is_finite() && v.is_finite() && w.is_finite()) || u == Vec3::ZERO || v == Vec3::ZERO {
        return Err(error(
            "the eye is too far from or too close to the point looked at for f32 (no finite camera frame); \
             bring the coordinates nearer to each other"
                .into(),
        ));
    }
    Ok(camera)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn box_camera() -> Camera {
        Camera {
            eye: Vec3::new(278.0, 273.0, -900.0),
            look_at: Vec3::new(278.0, 273.0, 330.0),
            up: Vec3::Y,
            fov_y_degrees: 35.0,
        }
    }

    #[test]
    fn the_text_form_reads_back_exactly() {
        let mut rig = CameraRig::new(box_camera());
        rig.orbit(123.0, -45.0);
        rig.zoom(1.5);
        let camera = rig.camera();
        assert_eq!(parse_camera(&format_camera(&camera)).unwrap(), camera);
    }

    #[test]
    fn bad_camera_text_is_an_error_naming_the_problem() {
        for (value, expected) in [
            ("1,2,3", "3 numbers"),
            ("0,0,0,0,0,0,0,1,0,40", "the eye is the point looked at"),
            ("0,0,0,0,0,1,0,0,1,40", "up direction"),
            ("0,0,0,0,0,1,0,1,0,190", "field of view"),
            ("0,0,x,0,0,1,0,1,0,40", "\"x\" is not a number"),
            ("0,0,0,0,0,1,0,1,0,NaN", "finite"),
            ("0,0,0,0,0,1e30,0,1,0,40", "too far from or too close"),
            ("-3e38,0,0,3e38,0,0,0,1,0,40", "too far from or too close"),
            ("0,0,0,0,0,1e-30,0,1,0,40", "too far from or too close"),
        ] {
            let message = parse_camera(value).unwrap_err().to_string();
            assert!(message.contains(expected), "{value}: {message}");
        }
    }

    #[test]
    fn orbiting_keeps_the_distance_and_a_full_turn_comes_back() {
        let mut rig = CameraRig::new(box_camera());
        let distance = (rig.camera().eye - rig.camera().look_at).length();
        let steps = 100;
        let pixels_per_turn = std::f32::consts::TAU / RADIANS_PER_PIXEL;
        for _ in 0..steps {
            rig.orbit(pixels_per_turn / steps as f32, 0.0);
        }
        let c = rig.camera();
        assert!(((c.eye - c.look_at).length() - distance).abs() < 1e-2 * distance);
        assert!((c.eye - box_camera().eye).length() < 1e-3 * distance, "{:?}", c.eye);
        assert_eq!(c.look_at, box_camera().look_at);
    }

    #[test]
    fn pitch_stops_short_of_the_pole() {
        let mut rig = CameraRig::new(box_camera());
        for _ in 0..1000 {
            rig.orbit(0.0, 50.0);
        }
        let c = rig.camera();
        let angle = (c.eye - c.look_at).angle_between(c.up).to_degrees();
        assert!((POLE_MARGIN_DEGREES..=180.0 - POLE_MARGIN_DEGREES).contains(&angle), "{angle}");
    }

    #[test]
    fn zoom_and_fly_move_as_documented() {
        let mut rig = CameraRig::new(box_camera());
        rig.zoom(1.0);
        let c = rig.camera();
        assert!(((c.look_at - c.eye).length() - 1230.0 * ZOOM_PER_STEP).abs() < 1e-2);
        rig.mode = CameraMode::Fly;
        let before = rig.camera();
        rig.translate(10.0, 5.0, 2.0);
        let after = rig.camera();
        assert!((after.eye - before.eye - Vec3::new(-5.0, 2.0, 10.0)).length() < 1e-3, "{:?}", after.eye);
        assert!((after.look_at - before.look_at - (after.eye - before.eye)).length() < 1e-3);
        rig.look(100.0, 0.0);
        assert_eq!(rig.camera().eye, after.eye, "looking around keeps the eye");
    }
}
