//! # raykit-device
//!
//! The device side of raykit: OptiX 7's programs (`__raygen__`, `__miss__`,
//! `__closesthit__`, …) written as plain Rust functions and compiled to SPIR-V by
//! rust-gpu. The attribute macros wrap a function and emit the Vulkan entry point
//! with the OptiX-prefixed name, one per program kind, each documented with an
//! example: [`raygen`], [`miss`], [`closest_hit`], [`any_hit`], [`intersection`],
//! [`direct_callable`], [`continuation_callable`], [`exception`](macro@exception). The derives
//! [`LaunchParams`](macro@LaunchParams), [`SbtRecordData`](macro@SbtRecordData) and
//! [`Element`](macro@Element) record the layouts of what crosses to the device:
//! launch params, SBT records, and user structs in buffers ([`mod@element`]).
//!
//! A program receives a *stage context* ([`Raygen`], [`Miss`], [`ClosestHit`]) that
//! offers exactly what that stage may use (launch index, tracing, barycentrics, …),
//! plus, marked by parameter attributes:
//!
//! * `#[params] p: &P` — the launch params (push constants), one `#[repr(C)]` struct
//!   shared with the host;
//! * `#[record] r: &R` — the program's own SBT record data, typed;
//! * `#[payload] p: &mut T` — the ray payload (outgoing in raygen, incoming in miss
//!   and closest-hit).
//!
//! ```
//! use raykit_device::glam::{UVec3, Vec3};
//! use raykit_device::{miss, raygen, Buffer, LaunchParams, Miss, RayType, Raygen, Traversable};
//!
//! /// The launch params, shared with the host (which checks the layout against the SPIR-V).
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
//! pub struct Params {
//!     pub image: Buffer<u32>,
//!     pub width: u32,
//!     pub scene: Traversable,
//! }
//!
//! /// The one ray type: its payload is a colour.
//! pub struct Radiance;
//! impl RayType for Radiance {
//!     type Payload = Vec3;
//! }
//!
//! /// One ray down -z per pixel; stores the red channel of what came back.
//! #[raygen]
//! fn rg(ctx: &mut Raygen, #[params] params: &Params, #[payload] color: &mut Vec3) {
//!     let index: UVec3 = ctx.launch_index();
//!     let origin = Vec3::new(index.x as f32 / params.width as f32, index.y as f32, 1.0);
//!     ctx.trace_from::<Radiance>(params.scene, origin, Vec3::NEG_Z, color);
//!     let pixel = ctx.launch_linear_index();
//!     ctx.store(params.image, pixel, (color.x * 255.0) as u32);
//! }
//!
//! #[miss(ray = Radiance)]
//! fn ms(_ctx: &mut Miss, #[payload] color: &mut Vec3) {
//!     *color = Vec3::ONE;
//! }
//!
//! // The host finds the entry points through constants the macros generate,
//! // named as OptiX names its programs.
//! assert_eq!(RG.name, "__raygen__rg");
//! assert_eq!(MS.name, "__miss__ms");
//! ```
//!
//! Beside the program model, the pieces every small renderer writes:
//! [`sphere`] (built-in spheres: the intersection test and its hit attributes),
//! [`triangle`] (triangle meshes, quads and boxes: the world-space hit with its
//! error bound and spawn origin, normals, uvs),
//! [`sampling`] (random numbers, unit vectors, points in the unit sphere and
//! disk, cosine-weighted directions), [`optics`] (reflect, refract, Fresnel and
//! Schlick), [`scatter`] (the Lambertian, metal and dielectric materials),
//! [`bounce`] (a path tracer's payload and its loop in raygen), [`medium`]
//! (constant-density participating media), [`camera`] (a
//! thin-lens camera), [`ray::offset_ray_origin`] (self-intersection-free ray
//! origins) and [`color`] (sRGB and RGBA8).
//!
//! This crate also compiles for the host target: launch-params structs, record data
//! types, [`Buffer`] and [`Traversable`] handles and the [`EntryPoint`] constants the
//! macros generate are shared between the two sides.
#![cfg_attr(target_arch = "spirv", no_std)]
#![cfg_attr(target_arch = "spirv", feature(asm_experimental_arch))]
#![deny(missing_docs)]

// The derives name this crate `::raykit_device`, in it too (`camera::ThinLensCamera`).
extern crate self as raykit_device;

pub mod bounce;
pub mod camera;
pub mod color;
#[cfg(not(target_arch = "spirv"))]
pub mod cpu;
pub mod element;
pub mod entry;
pub mod environment;
pub mod exception;
pub mod handles;
pub mod math;
pub mod medium;
pub mod motion;
pub mod optics;
pub mod params;
pub mod ray;
pub mod record;
pub mod sampling;
pub mod scatter;
pub mod sphere;
pub mod stage;
pub mod texture;
pub mod triangle;

pub use bytemuck;
pub use element::Element;
pub use entry::{EntryPoint, ProgramKind, ProgramPrefix, RayTypeInfo};
pub use handles::{Buffer, Traversable};
pub use params::{
    uses_push_constants, DeviceField, FieldLayout, LaunchParams, ParamsLayout, Scalar, ScalarKind, Shape,
    PARAMS_BINDING, PARAMS_SET, PUSH_CONSTANT_BUDGET,
};
pub use ray::{Ray, RayFlags, RayType};
pub use raykit_abi as abi;
pub use raykit_macros::{
    any_hit, closest_hit, continuation_callable, direct_callable, exception, intersection, miss, raygen, Element,
    LaunchParams, SbtRecordData,
};
pub use record::SbtRecordData;
pub use spirv_std;
pub use spirv_std::glam;
pub use spirv_std::matrix::Matrix4x3;
pub use stage::{
    AnyHit, ClosestHit, ContinuationCallable, DirectCallable, Exception, Intersection, Miss, Raygen,
    HIT_KIND_BACK_FACING_TRIANGLE, HIT_KIND_FRONT_FACING_TRIANGLE,
};
pub use texture::{SampleTexture, Texture2D, TextureTable};

/// The bindless storage-buffer table every program sees at descriptor set
/// [`BUFFER_TABLE_SET`], binding [`BUFFER_TABLE_BINDING`]. [`Buffer`] handles in launch params index it. Part of raykit's ABI
/// with the host; user code never names it.
pub type BufferTable = spirv_std::RuntimeArray<spirv_std::TypedBuffer<[u32]>>;

pub use raykit_abi::{BUFFER_TABLE_BINDING, BUFFER_TABLE_SET, TEXTURE_TABLE_BINDING};

#[doc(hidden)]
pub mod __private {
    //! Used by the code the macros generate; not a stable API.
    /// The params layout check run by the tests `#[params]` programs generate (host only).
    #[cfg(not(target_arch = "spirv"))]
    pub use raykit_spirv;
    pub use spirv_std::spirv;

    /// The body of the entry point `#[derive(Element)]` gives a device crate's
    /// SPIR-V for each element struct: it reads the struct from the push constants
    /// (so the SPIR-V keeps the block, with the struct's layout) and writes it to
    /// slot 0 of the buffer table. It is never part of a pipeline, so never runs.
    #[cfg(target_arch = "spirv")]
    pub fn record_element<T: crate::Element>(element: &T, buffers: &mut crate::BufferTable) {
        // SAFETY: slot 0 is in the table, and a write past a buffer's end is
        // defined (robustBufferAccess2, see `crate::Buffer`); the program never runs.
        unsafe {
            let words: &mut [u32] = buffers.index_mut(0);
            element.write_unchecked(words, 0);
        }
    }

    /// The check of `#[derive(Element)]` structs' layout against a built SPIR-V
    /// file, run by the tests the derive generates in device crates (host only).
    #[cfg(not(target_arch = "spirv"))]
    #[allow(clippy::result_large_err)] // as raykit-spirv's layout errors: rare, built once
    pub fn check_element_file<T: crate::Element>(path: &std::path::Path) -> Result<(), raykit_spirv::LayoutError> {
        raykit_spirv::layout::check_element_file(path, &T::SHAPE)
    }
}
