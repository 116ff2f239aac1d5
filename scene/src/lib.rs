//! # raykit-scene
//!
//! Host-side helpers that raykit's renderers share: a pinhole [`Camera`] (sutil's
//! `Camera`, with the `u, v, w` frame the device programs turn into rays), and
//! writers for the pictures they produce ([`image_io`]): RGBA8 pixels or linear
//! radiance to PNG, linear radiance to PFM and (feature `exr`, through the `exr`
//! crate) OpenEXR; importance-sampled equirectangular [`EnvironmentMap`]s; and
//! (feature `gltf`) glTF 2.0 scenes (`gltf::GltfScene`).
//!
//! Both features are on by default. `raykit` re-exports this crate without them
//! as `raykit::scene` (with [`Camera`] and the PNG writers at its top level), so
//! an application that writes PNGs needs no scene formats:
//!
//! ```
//! use raykit_scene::{write_png_srgb, Camera};
//! use glam::Vec3;
//!
//! let camera = Camera { eye: Vec3::new(0.0, 0.0, 2.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 45.0 };
//! let (_u, _v, w) = camera.uvw(4.0 / 3.0);
//! assert_eq!(w, Vec3::new(0.0, 0.0, -2.0));
//! // Linear radiance, row by row from the top: sRGB-encoded to 8 bits a channel.
//! let radiance = vec![Vec3::new(0.2, 0.5, 1.0); 4 * 3];
//! let path = std::env::temp_dir().join(format!("raykit-scene-doc-{}.png", std::process::id()));
//! write_png_srgb(&path, 4, 3, &radiance)?;
//! # std::fs::remove_file(&path).ok();
//! # Ok::<(), raykit_scene::ImageError>(())
//! ```
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod camera;
pub mod environment;
#[cfg(feature = "gltf")]
pub mod gltf;
pub mod image_io;

pub use camera::Camera;
pub use environment::{EnvironmentError, EnvironmentMap};
#[cfg(feature = "exr")]
pub use image_io::write_exr;
pub use image_io::{write_pfm, write_png_rgba8, write_png_srgb, ImageError};
