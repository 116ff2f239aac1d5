//! A path tracer bounce by bounce, as *Ray Tracing in One Weekend* traces it
//! but iteratively: raygen follows the path in a loop ([`trace_path`]), each
//! trace's closest-hit program says how the path goes on ([`Bounce::scatter_from`],
//! with a direction from [`crate::scatter`]) and the miss program what the sky
//! gives it ([`Bounce::escape`]). The payload, [`Bounce`], carries the path's
//! random numbers in and the bounce out: the light a hit emits
//! ([`Bounce::emit`], *The Next Week*'s diffuse lights) and the hit's distance
//! ([`Bounce::hit`]) besides the scattered ray; the pipeline's `max_trace_depth` is 1.
//!
//! A loop of one's own (participating media, next-event estimation) is built
//! from [`trace_bounce`], one trace of the path, as [`trace_path`] is: for a
//! constant-density medium the loop samples a scattering distance and compares
//! it with the payload's `distance` (see [`crate::medium`]).
//!
//! ```
//! use raykit_device::bounce::{self, Bounce};
//! use raykit_device::glam::Vec3;
//! use raykit_device::sampling::Pcg;
//! use raykit_device::{miss, raygen, LaunchParams, Miss, Ray, RayType, Raygen, Traversable};
//!
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
//! pub struct Params { pub scene: Traversable }
//!
//! pub struct Radiance;
//! impl RayType for Radiance {
//!     type Payload = Bounce;
//! }
//!
//! #[raygen]
//! fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] bounce: &mut Bounce) {
//!     let mut rng = Pcg::new(ctx.launch_linear_index(), 0);
//!     let ray = Ray::new(Vec3::ZERO, Vec3::Y);
//!     let _radiance: Vec3 = bounce::trace_path::<Radiance>(ctx, p.scene, ray, &mut rng, 16, bounce);
//! }
//!
//! #[miss(ray = Radiance)]
//! fn ms(_ctx: &mut Miss, #[payload] bounce: &mut Bounce) {
//!     bounce.escape(Vec3::ONE); // a white sky
//! }
//! ```

use spirv_std::glam::Vec3;

use crate::sampling::Pcg;
use crate::sphere::SurfaceHit;
use crate::{Ray, RayType, Raygen, Traversable};

/// What a trace did to the path ([`Bounce::state`]).
pub mod state {
    /// The path goes on from `origin` along `direction`, attenuated by `weight`.
    pub const SCATTERED: u32 = 0;
    /// The path ended on a surface (and the state a trace starts in: a hit
    /// program that says nothing absorbs).
    pub const ABSORBED: u32 = 1;
    /// The path left the scene; `weight` is the radiance it found.
    pub const ESCAPED: u32 = 2;
}

/// The payload of a path's rays.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Bounce {
    /// The path's random numbers: hit programs draw from them, raygen carries
    /// them on to the next bounce.
    pub rng: Pcg,
    /// The attenuation of the scattered ray, or the radiance found on escaping.
    pub weight: Vec3,
    /// Where the scattered ray starts.
    pub origin: Vec3,
    /// Its direction.
    pub direction: Vec3,
    /// Light the hit emits towards the path ([`Bounce::emit`]), counted whatever
    /// the path does next.
    pub emitted: Vec3,
    /// The hit's distance along the ray ([`Bounce::hit`]); infinite for a miss,
    /// or while no hit program has set it.
    pub distance: f32,
    /// [`state::SCATTERED`], [`state::ABSORBED`] or [`state::ESCAPED`].
    pub state: u32,
}

impl Bounce {
    /// A payload carrying `rng`, absorbed until a program says otherwise.
    pub fn new(rng: Pcg) -> Bounce {
        Bounce {
            rng,
            weight: Vec3::ZERO,
            origin: Vec3::ZERO,
            direction: Vec3::ZERO,
            emitted: Vec3::ZERO,
            distance: f32::INFINITY,
            state: state::ABSORBED,
        }
    }

    /// Records the hit's distance along the ray (closest-hit's `ctx.hit_t()`).
    pub fn hit(&mut self, distance: f32) -> &mut Bounce {
        self.distance = distance;
        self
    }

    /// The hit emits `radiance` towards the path (a light); the path may still
    /// scatter or be absorbed.
    pub fn emit(&mut self, radiance: Vec3) -> &mut Bounce {
        self.emitted += radiance;
        self
    }

    /// The path goes on from `origin` along `direction`, its light attenuated by `attenuation`.
    pub fn scatter(&mut self, origin: Vec3, direction: Vec3, attenuation: Vec3) {
        (self.origin, self.direction, self.weight, self.state) = (origin, direction, attenuation, state::SCATTERED);
    }

    /// With a direction, the path goes on from the surface along it (from
    /// [`SurfaceHit::spawn_origin`], so it does not hit the surface again),
    /// attenuated by `attenuation`; without one, it is absorbed.
    pub fn scatter_from(&mut self, surface: &SurfaceHit, direction: Option<Vec3>, attenuation: Vec3) {
        match direction {
            Some(d) => self.scatter(surface.spawn_origin(d), d, attenuation),
            None => self.absorb(),
        }
    }

    /// The path ends here.
    pub fn absorb(&mut self) {
        (self.weight, self.state) = (Vec3::ZERO, state::ABSORBED);
    }

    /// The path left the scene and found `radiance` (a miss program's sky).
    pub fn escape(&mut self, radiance: Vec3) {
        (self.weight, self.state) = (radiance, state::ESCAPED);
    }
}

/// One trace of a path: `payload` (the raygen program's `#[payload]`) starts
/// afresh with `rng`, `ray` is traced into `scene` with rays of type `R`, and
/// `rng` goes on from where the hit programs left it. The payload then says
/// what the trace did: its `state`, `weight`, `emitted`, `distance` and the
/// scattered ray.
pub fn trace_bounce<R: RayType<Payload = Bounce>>(
    ctx: &mut Raygen,
    scene: Traversable,
    ray: Ray,
    rng: &mut Pcg,
    payload: &mut Bounce,
) {
    *payload = Bounce::new(*rng);
    ctx.trace::<R>(scene, ray, payload);
    *rng = payload.rng;
}

/// Follows one path from `ray` into `scene` with rays of type `R`, for at most
/// `max_bounces` traces, drawing from `rng`: returns the radiance it brings back,
/// the light emitted at each hit and what it found on escaping, each times the
/// product of the attenuations before it (nothing more once it was absorbed or
/// took too many bounces). `payload` is the raygen program's `#[payload]`.
pub fn trace_path<R: RayType<Payload = Bounce>>(
    ctx: &mut Raygen,
    scene: Traversable,
    ray: Ray,
    rng: &mut Pcg,
    max_bounces: u32,
    payload: &mut Bounce,
) -> Vec3 {
    let (mut ray, mut throughput, mut radiance) = (ray, Vec3::ONE, Vec3::ZERO);
    let mut bounces = 0;
    while bounces < max_bounces {
        trace_bounce::<R>(ctx, scene, ray, rng, payload);
        radiance += throughput * payload.emitted;
        if payload.state == state::ESCAPED {
            radiance += throughput * payload.weight;
        }
        if payload.state != state::SCATTERED {
            break;
        }
        throughput *= payload.weight;
        ray = Ray { origin: payload.origin, direction: payload.direction, ..ray };
        bounces += 1;
    }
    radiance
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn scatter_from_a_surface_starts_outside_it_or_absorbs() {
        let surface =
            SurfaceHit { position: Vec3::new(0.0, 1000.0, 0.0), normal: Vec3::Y, front_face: true, error: 1e-4 };
        let mut bounce = Bounce::new(Pcg::new(1, 1));
        assert_eq!(bounce.state, state::ABSORBED);
        bounce.scatter_from(&surface, Some(Vec3::Y), Vec3::splat(0.5));
        assert_eq!((bounce.state, bounce.direction, bounce.weight), (state::SCATTERED, Vec3::Y, Vec3::splat(0.5)));
        assert!(bounce.origin.y > 1000.0001, "{}", bounce.origin);
        // Into the surface (refraction): the origin moves below it.
        bounce.scatter_from(&surface, Some(-Vec3::Y), Vec3::ONE);
        assert!(bounce.origin.y < 999.9999, "{}", bounce.origin);
        bounce.scatter_from(&surface, None, Vec3::ONE);
        assert_eq!((bounce.state, bounce.weight), (state::ABSORBED, Vec3::ZERO));
        bounce.escape(Vec3::new(0.5, 0.7, 1.0));
        assert_eq!((bounce.state, bounce.weight), (state::ESCAPED, Vec3::new(0.5, 0.7, 1.0)));
    }

    #[test]
    fn a_light_emits_and_records_its_distance_whatever_the_path_does_next() {
        let mut bounce = Bounce::new(Pcg::new(1, 1));
        assert_eq!((bounce.emitted, bounce.distance), (Vec3::ZERO, f32::INFINITY));
        bounce.hit(2.5).emit(Vec3::splat(4.0)).absorb();
        assert_eq!((bounce.state, bounce.emitted, bounce.distance), (state::ABSORBED, Vec3::splat(4.0), 2.5));
        bounce.emit(Vec3::X);
        assert_eq!(bounce.emitted, Vec3::new(5.0, 4.0, 4.0));
    }
}
