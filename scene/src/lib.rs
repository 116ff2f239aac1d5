//! # raykit-scene
//!
//! Host-side helpers that raykit's renderers share: a pinhole [`Camera`] (sutil's
//! `Camera`, with the `u, v, w` frame the device programs turn into rays), and
//! writers for the pictures they produce ([`image_io`]): RGBA8 pixels to PNG,
//! linear radiance to OpenEXR (through the `exr` crate) and PFM; and
//! importance-sampled equirectangular [`EnvironmentMap`]s; and glTF 2.0 scenes ([`gltf::GltfScene`]).
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod camera;
pub mod environment;
pub mod gltf;
pub mod image_io;

pub use camera::Camera;
pub use environment::{EnvironmentError, EnvironmentMap};
pub use image_io::{write_exr, write_pfm, write_png_rgba8, ImageError};
