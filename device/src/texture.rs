//! Sampled textures reached through launch params and SBT records, as buffers
//! are: a [`Texture2D`] handle is a slot of the bindless texture table
//! ([`TextureTable`], set [`crate::BUFFER_TABLE_SET`], binding
//! [`TEXTURE_TABLE_BINDING`](raykit_abi::TEXTURE_TABLE_BINDING)): combined image
//! samplers, each with the filter and address modes the host chose for it.
//!
//! A program that samples declares the table with a `#[textures]` parameter and
//! samples it with an explicit level of detail ([`SampleTexture::sample_lod`]):
//! ray-tracing stages have no derivatives, so the program picks the mip level
//! (for example from the ray's footprint), in every stage alike.
//!
//! ```
//! use raykit_device::glam::{Vec2, Vec3, Vec4};
//! use raykit_device::{closest_hit, ClosestHit, RayType, SampleTexture, Texture2D, TextureTable};
//!
//! /// The hit group's record: the surface's texture.
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
//! pub struct Material { pub albedo: Texture2D }
//!
//! pub struct Radiance;
//! impl RayType for Radiance { type Payload = Vec3; }
//!
//! #[closest_hit(ray = Radiance)]
//! fn ch(ctx: &mut ClosestHit, #[record] m: &Material, #[textures] textures: &TextureTable, #[payload] c: &mut Vec3) {
//!     let uv: Vec2 = ctx.barycentrics();
//!     let texel: Vec4 = textures.sample_lod(m.albedo, uv, 0.0);
//!     *c = texel.truncate();
//! }
//! ```
//!
//! Host side, `raykit::Texture::handle` gives the handle; every launch checks
//! the handles in its params and in records that derive
//! [`SbtRecordData`](macro@crate::SbtRecordData) against the live textures, as it
//! checks buffer handles. The null handle (zero) and the slot of a dropped texture
//! sample as zero (`nullDescriptor`).

use spirv_std::glam::{Vec2, Vec4};

/// The image type of every texture: 2D, sampled, float components (formats
/// RGBA8 sRGB and linear, RGBA16F, RGBA32F all sample as `f32`).
pub type Image2d = spirv_std::Image!(2D, type = f32, sampled);

/// The bindless texture table every `#[textures]` parameter names. Part of
/// raykit's ABI with the host.
#[cfg(target_arch = "spirv")]
pub type TextureTable = spirv_std::RuntimeArray<spirv_std::image::SampledImage<Image2d>>;

/// What a `#[textures]` parameter names when the program runs on raykit's CPU
/// backend: the runtime of the program call, which samples for it. Programs
/// write `&TextureTable` on both targets (the lifetime is elided here).
#[cfg(not(target_arch = "spirv"))]
pub struct TextureTable<'a> {
    runtime: &'a dyn crate::cpu::Runtime,
}

#[cfg(not(target_arch = "spirv"))]
impl<'a> TextureTable<'a> {
    /// The table of a program call running on `runtime` (the macros make one
    /// for each call).
    #[doc(hidden)]
    pub fn __cpu(runtime: &'a dyn crate::cpu::Runtime) -> TextureTable<'a> {
        TextureTable { runtime }
    }
}

/// A handle to a 2D texture in the bindless texture table: its slot in the low
/// 12 bits, a generation the host checks above them.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[doc(alias("cudaTextureObject_t"))]
pub struct Texture2D {
    index: u32,
}

impl Texture2D {
    /// The null handle: samples as zero.
    pub const NULL: Texture2D = Texture2D { index: 0 };

    /// A handle with value `index`. Host-side code should use
    /// `raykit::Texture::handle`, which launches check.
    pub const fn from_raw(index: u32) -> Self {
        Texture2D { index }
    }

    /// The slot of the texture table this handle names (its value modulo the
    /// table's size).
    pub const fn table_index(self) -> u32 {
        self.index & (raykit_abi::TEXTURE_TABLE_SLOTS - 1)
    }

    /// The handle's value as the host stored it.
    pub const fn raw(self) -> u32 {
        self.index
    }
}

/// Sampling the texture table.
pub trait SampleTexture {
    /// Samples `texture` at `uv` (0..1 across the texture, `(0, 0)` at the
    /// first texel of the first row) at mip level `lod` (0 = full size;
    /// fractions blend two levels when the texture's mip filter is linear),
    /// with the texture's filter and address modes. Returns RGBA, linear
    /// (sRGB textures are decoded by the sampler).
    fn sample_lod(&self, texture: Texture2D, uv: Vec2, lod: f32) -> Vec4;
}

#[cfg(not(target_arch = "spirv"))]
impl SampleTexture for TextureTable<'_> {
    fn sample_lod(&self, texture: Texture2D, uv: Vec2, lod: f32) -> Vec4 {
        self.runtime.sample_texture(texture.raw(), uv, lod)
    }
}

#[cfg(target_arch = "spirv")]
impl SampleTexture for TextureTable {
    fn sample_lod(&self, texture: Texture2D, uv: Vec2, lod: f32) -> Vec4 {
        {
            let index = texture.table_index();
            let mut result = Vec4::ZERO;
            // The handle may differ between invocations (it comes from records or
            // payloads), so the access is decorated `NonUniform` as glslang decorates
            // `textures[nonuniformEXT(i)]`, and the capabilities that decoration needs
            // are declared here: rust-gpu 0.11 drops `NonUniform` decorations (those
            // spirv-std's `RuntimeArray::index` and `sample_by_lod` emit included)
            // from modules without `ShaderNonUniform`, and drivers may then sample one
            // invocation's texture for all (lavapipe does, in hit programs).
            // SAFETY: `index` is below the table's size, and every slot holds a
            // texture or a null descriptor (raykit fills the table so); the pointer
            // operand is only a type witness.
            unsafe {
                core::arch::asm! {
                    "OpCapability ShaderNonUniform",
                    "OpCapability SampledImageArrayNonUniformIndexing",
                    "OpDecorate %index NonUniform",
                    "OpDecorate %ptr NonUniform",
                    "OpDecorate %image NonUniform",
                    "OpDecorate %sample NonUniform",
                    "%index = OpLoad _ {index}",
                    "%ptr = OpAccessChain typeof*{element} {table} %index",
                    "%image = OpLoad _ %ptr",
                    "%coord = OpLoad _ {uv}",
                    "%lod = OpLoad _ {lod}",
                    "%sample = OpImageSampleExplicitLod typeof*{result} %image %coord Lod %lod",
                    "OpStore {result} %sample",
                    index = in(reg) &index,
                    table = in(reg) self,
                    element = in(reg) &core::ptr::null::<spirv_std::image::SampledImage<Image2d>>(),
                    uv = in(reg) &uv,
                    lod = in(reg) &lod,
                    result = in(reg) &mut result,
                }
            }
            result
        }
    }
}
