//! Sampled 2D textures, OptiX's CUDA texture objects, reached by device programs through [`Texture2D`]
//! handles in launch params and SBT records, as buffers are through
//! `Buffer<T>` handles (see [`raykit_device::texture`]).
//!
//! A [`Texture`] is an image in one of four [`TextureFormat`]s, with a full or
//! partial mip chain ([`Mipmaps::Generate`] builds it on the host with a 2×2 box
//! filter, in linear light for sRGB textures; [`Texture::from_levels`] takes
//! supplied levels), and its own sampler ([`SamplerOptions`]: filter, mip filter,
//! address modes). It takes
//! a slot of the context's bindless texture table (set 0, binding 1, combined
//! image samplers); every launch checks the texture handles of its params and
//! records as it checks buffer handles, so a dropped texture's handle is refused
//! with [`LaunchError::InvalidHandle`](crate::LaunchError::InvalidHandle).
//!
//! On Vulkan it is an image (optimal tiling, `SAMPLED | TRANSFER_DST`) with a
//! sampler in a bindless table of combined image samplers. On the CPU backend
//! the texels stay in host memory and a sampler written to Vulkan's filtering
//! rules reads them (see [`crate::cpu`]); formats, mips, sampler options,
//! handles and errors are the same. See
//! [`VkImageCreateInfo`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkImageCreateInfo.html)
//! and [`VkSamplerCreateInfo`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkSamplerCreateInfo.html).

use std::sync::Arc;

use ash::vk;
use raykit_device::Texture2D;

use crate::context::{Context, ContextRepr};
use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::types::texture::FormatSupport;
use crate::validate::texture::check_level;

impl TextureFormat {
    /// The Vulkan format.
    pub const fn vk_format(self) -> vk::Format {
        crate::vulkan::conv::format(self)
    }
}
pub use crate::types::texture::{
    full_mip_count, mip_size, AddressMode, Filter, MipLevel, Mipmaps, SamplerOptions, TextureFormat,
};

/// A 2D texture in device memory with its sampler, at a slot of the context's
/// texture table. Dropping it frees the slot once no pending work can sample it.
///
/// ```
/// use raykit::{Backend, Context, ContextOptions, Mipmaps, SamplerOptions, Texture, TextureFormat};
/// // The CPU backend needs no GPU; on Vulkan the calls are the same.
/// let ctx = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?;
/// let red = [255u8, 0, 0, 255].repeat(4 * 4);
/// let options = SamplerOptions::default();
/// let texture = Texture::new(&ctx, TextureFormat::Rgba8Srgb, 4, 4, &red, Mipmaps::Generate, options)?;
/// assert_eq!((texture.size(), texture.mip_levels()), ((4, 4), 3));
/// let handle = texture.handle(); // for launch params or SBT records
/// # let _ = handle;
/// # Ok::<(), raykit::Error>(())
/// ```
#[doc(alias("cudaTextureObject_t", "cudaCreateTextureObject"))]
pub struct Texture {
    repr: TextureRepr,
    /// The table slot.
    slot: u32,
    handle: u32,
    format: TextureFormat,
    width: u32,
    height: u32,
    levels: u32,
    options: SamplerOptions,
}

/// Where a [`Texture`]'s texels are.
enum TextureRepr {
    /// A Vulkan image with its view and sampler.
    Vulkan(crate::vulkan::texture::VulkanImage),
    /// Host memory, in the CPU backend's texture table.
    Cpu(Arc<crate::cpu::CpuContext>),
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Texture")
            .field("format", &self.format)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("levels", &self.levels)
            .field("sampler", &self.options)
            .field("handle", &format_args!("{:#x}", self.handle))
            .finish()
    }
}

impl Texture {
    /// A texture of `format` from level 0's texels (`width × height`, row-major),
    /// with the mip levels `mips` asks for.
    pub fn new(
        ctx: &Context,
        format: TextureFormat,
        width: u32,
        height: u32,
        data: &[u8],
        mips: Mipmaps,
        sampler: SamplerOptions,
    ) -> Result<Texture> {
        check_size(ctx, width, height)?;
        let levels = match mips {
            Mipmaps::One => {
                check_level(format, 0, width, height, data.len())?;
                vec![MipLevel { width, height, data: data.to_vec() }]
            }
            Mipmaps::Generate => generate_mips(format, width, height, data)?,
        };
        Self::from_levels(ctx, format, &levels, sampler)
    }

    /// A texture from supplied mip levels: level 0 first, each level the size
    /// [`mip_size`] gives (a partial chain is fine; at most [`full_mip_count`] levels).
    pub fn from_levels(
        ctx: &Context,
        format: TextureFormat,
        levels: &[MipLevel],
        sampler: SamplerOptions,
    ) -> Result<Texture> {
        let Some(base) = levels.first() else {
            return Err(Error::Resource(ResourceError::TextureSize {
                width: 0,
                height: 0,
                problem: "no mip level given".to_owned(),
                fix: "give at least level 0",
            }));
        };
        let (width, height) = (base.width, base.height);
        check_size(ctx, width, height)?;
        let max = full_mip_count(width, height);
        if levels.len() as u32 > max {
            return Err(Error::Resource(ResourceError::TextureSize {
                width,
                height,
                problem: format!("{} mip levels given, a {width}×{height} texture has at most {max}", levels.len()),
                fix: "give the levels from full size down to at most 1×1",
            }));
        }
        for (i, level) in levels.iter().enumerate() {
            let (w, h) = mip_size(width, height, i as u32);
            if (level.width, level.height) != (w, h) {
                return Err(Error::Resource(ResourceError::TextureSize {
                    width: level.width,
                    height: level.height,
                    problem: format!("mip level {i} of a {width}×{height} texture must be {w}×{h}"),
                    fix: "halve the size per level (rounding down, at least 1)",
                }));
            }
            check_level(format, i as u32, w, h, level.data.len())?;
        }
        check_format(ctx, format, sampler)?;
        let (repr, slot, handle) = match ctx.repr() {
            ContextRepr::Cpu(cpu) => {
                let texture = crate::cpu::textures::CpuTexture::new(format, levels.to_vec(), sampler);
                let (slot, handle) = cpu.textures.insert(Arc::new(texture))?;
                (TextureRepr::Cpu(cpu.clone()), slot, handle)
            }
            ContextRepr::Vulkan(inner) => {
                let (image, slot, handle) =
                    crate::vulkan::texture::create(inner, format, (width, height), levels, sampler)?;
                (TextureRepr::Vulkan(image), slot, handle)
            }
        };
        let levels = levels.len() as u32;
        Ok(Texture { repr, slot, handle, format, width, height, levels, options: sampler })
    }

    /// A texture from an image of the `image` crate: 8-bit images (grey, grey +
    /// alpha, RGB, RGBA) become [`TextureFormat::Rgba8Srgb`] when `srgb` (colour
    /// pictures) or [`TextureFormat::Rgba8Unorm`] (data such as normal or
    /// roughness maps); 32-bit float images become [`TextureFormat::Rgba32Float`].
    /// Missing channels are filled as the `image` crate's `to_rgba*` do.
    pub fn from_image(
        ctx: &Context,
        image: &image::DynamicImage,
        srgb: bool,
        mips: Mipmaps,
        sampler: SamplerOptions,
    ) -> Result<Texture> {
        use image::DynamicImage as D;
        let (w, h) = (image.width(), image.height());
        match image {
            D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
                let format = if srgb { TextureFormat::Rgba8Srgb } else { TextureFormat::Rgba8Unorm };
                Self::new(ctx, format, w, h, image.to_rgba8().as_raw(), mips, sampler)
            }
            D::ImageRgb32F(_) | D::ImageRgba32F(_) => {
                let rgba = image.to_rgba32f();
                Self::new(ctx, TextureFormat::Rgba32Float, w, h, bytemuck::cast_slice(rgba.as_raw()), mips, sampler)
            }
            other => Err(Error::Resource(ResourceError::TextureFormat {
                format: format!("{:?}", other.color()),
                problem: "16-bit integer images have no texture format here (RGBA8 sRGB or linear, RGBA16F, RGBA32F)"
                    .to_owned(),
                fix: "convert the image first: to_rgba8() for colour, to_rgba32f() to keep the precision",
            })),
        }
    }

    /// A texture from an image file (PNG or JPEG, recognised by its contents),
    /// decoded by the `image` crate and uploaded as [`Texture::from_image`] does:
    /// `srgb` for colour pictures, linear for data. A file that cannot be read or
    /// decoded is [`ResourceError::ImageFile`], naming it.
    ///
    /// ```no_run
    /// use raykit::{Context, ContextOptions, Mipmaps, SamplerOptions, Texture};
    /// let ctx = Context::new(ContextOptions::default())?;
    /// let earth = Texture::load(&ctx, "earthmap.jpg".as_ref(), true, Mipmaps::Generate, SamplerOptions::default())?;
    /// # let _ = earth;
    /// # Ok::<(), raykit::Error>(())
    /// ```
    pub fn load(
        ctx: &Context,
        path: &std::path::Path,
        srgb: bool,
        mips: Mipmaps,
        sampler: SamplerOptions,
    ) -> Result<Texture> {
        let refused = |reason: String| Error::Resource(ResourceError::ImageFile { path: path.to_path_buf(), reason });
        let reader = image::ImageReader::open(path).map_err(|e| refused(e.to_string()))?;
        let reader = reader.with_guessed_format().map_err(|e| refused(e.to_string()))?;
        let image = reader.decode().map_err(|e| refused(e.to_string()))?;
        Self::from_image(ctx, &image, srgb, mips, sampler)
    }

    /// The handle device programs sample through.
    pub fn handle(&self) -> Texture2D {
        Texture2D::from_raw(self.handle)
    }

    /// The format.
    pub fn format(&self) -> TextureFormat {
        self.format
    }

    /// Width and height of level 0.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Number of mip levels.
    pub fn mip_levels(&self) -> u32 {
        self.levels
    }

    /// The sampler's options.
    pub fn sampler_options(&self) -> SamplerOptions {
        self.options
    }
}

/// The full mip chain of a `width × height` texture of `format` whose level 0
/// is `base`, level 0 included. Each texel of level `l + 1` is the mean of the
/// 2×2 texels of level `l` it covers (clamped at an odd edge), in linear values
/// ([`TextureFormat::decode`]), encoded back with [`TextureFormat::encode`].
pub fn generate_mips(format: TextureFormat, width: u32, height: u32, base: &[u8]) -> Result<Vec<MipLevel>> {
    check_level(format, 0, width, height, base.len())?;
    let bpt = format.bytes_per_texel();
    let mut levels = vec![MipLevel { width, height, data: base.to_vec() }];
    for level in 1..full_mip_count(width, height) {
        let prev = &levels[level as usize - 1];
        let (w, h) = mip_size(width, height, level);
        let texel = |x: u32, y: u32| {
            let (x, y) = (x.min(prev.width - 1), y.min(prev.height - 1));
            let i = (y * prev.width + x) as usize * bpt;
            format.decode(&prev.data[i..i + bpt])
        };
        let mut data = Vec::with_capacity(w as usize * h as usize * bpt);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let t = texel(2 * x + dx, 2 * y + dy);
                    for c in 0..4 {
                        sum[c] += t[c] * 0.25;
                    }
                }
                format.encode(sum, &mut data);
            }
        }
        levels.push(MipLevel { width: w, height: h, data });
    }
    Ok(levels)
}

/// The device's filtering precision: `(subTexelPrecisionBits, mipmapPrecisionBits)`,
/// the bits of the weights with which it blends texels and mip levels (what a CPU
/// reference of sampling must allow for). The CPU backend's sampler blends in
/// `f32` and reports `(8, 8)`.
pub fn filter_precision_bits(ctx: &Context) -> (u32, u32) {
    match ctx.repr() {
        ContextRepr::Vulkan(inner) => crate::vulkan::texture::filter_precision_bits(inner),
        ContextRepr::Cpu(_) => crate::cpu::textures::PRECISION_BITS,
    }
}

/// The largest width and height of a texture on the device (`maxImageDimension2D`);
/// 16384 on the CPU backend.
pub fn max_texture_size(ctx: &Context) -> u32 {
    match ctx.repr() {
        ContextRepr::Vulkan(inner) => crate::vulkan::texture::max_texture_size(inner),
        ContextRepr::Cpu(_) => crate::cpu::textures::MAX_SIZE,
    }
}

fn check_size(ctx: &Context, width: u32, height: u32) -> Result<()> {
    let max = max_texture_size(ctx);
    if width == 0 || height == 0 {
        return Err(Error::Resource(ResourceError::TextureSize {
            width,
            height,
            problem: "a texture needs at least one texel in each direction".to_owned(),
            fix: "give a width and height of at least 1",
        }));
    }
    if width > max || height > max {
        return Err(Error::Resource(ResourceError::TextureSize {
            width,
            height,
            problem: format!("the device's maxImageDimension2D is {max}"),
            fix: "downscale the image, or split it into tiles of at most maxImageDimension2D texels",
        }));
    }
    Ok(())
}

/// Refuses a format (and filter) the device cannot sample (the CPU backend
/// samples and filters every format).
fn check_format(ctx: &Context, format: TextureFormat, sampler: SamplerOptions) -> Result<()> {
    let support = match ctx.repr() {
        ContextRepr::Vulkan(inner) => crate::vulkan::texture::format_support(inner, format),
        ContextRepr::Cpu(_) => FormatSupport { sampled: true, linear_filter: true, features: String::new() },
    };
    if !support.sampled {
        return Err(Error::Resource(ResourceError::TextureFormat {
            format: format!("{format:?}"),
            problem: format!("the device cannot sample it ({})", support.features),
            fix: "use another TextureFormat (RGBA8 formats are sampled by every Vulkan device)",
        }));
    }
    let linear = sampler.filter == Filter::Linear || sampler.mip_filter == Filter::Linear;
    if linear && !support.linear_filter {
        return Err(Error::Resource(ResourceError::TextureFormat {
            format: format!("{format:?}"),
            problem: "the device cannot filter it linearly".to_owned(),
            fix: "use Filter::Nearest for this format, or Rgba16Float, which every Vulkan device filters",
        }));
    }
    Ok(())
}

impl Drop for Texture {
    fn drop(&mut self) {
        // Launches refuse its handle from now on.
        match &self.repr {
            // The slot is emptied and reused once no pending work can sample it;
            // the image is freed after it (when `image` drops).
            TextureRepr::Vulkan(image) => image.release_slot(self.slot),
            // Launches running keep the texels they started with.
            TextureRepr::Cpu(cpu) => cpu.textures.remove(self.slot),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chains_halve_down_to_one_texel() {
        assert_eq!(full_mip_count(16, 8), 5);
        assert_eq!(full_mip_count(1, 1), 1);
        assert_eq!(full_mip_count(5, 3), 3);
        assert_eq!(mip_size(5, 3, 1), (2, 1));
        assert_eq!(mip_size(5, 3, 2), (1, 1));
    }

    #[test]
    fn generated_mips_average_in_linear_light() -> Result<()> {
        // sRGB 2×1: black and white average to linear 0.5, which encodes as 188.
        let base = [0, 0, 0, 255, 255, 255, 255, 255];
        let levels = generate_mips(TextureFormat::Rgba8Srgb, 2, 1, &base)?;
        assert_eq!(levels.len(), 2);
        assert_eq!(levels[1].data, [188, 188, 188, 255]);
        let levels = generate_mips(TextureFormat::Rgba8Unorm, 2, 1, &base)?;
        assert_eq!(levels[1].data, [128, 128, 128, 255]);
        // Float formats round-trip their values.
        for format in [TextureFormat::Rgba16Float, TextureFormat::Rgba32Float] {
            let mut bytes = Vec::new();
            format.encode([0.25, 2.0, -1.0, 1.0], &mut bytes);
            assert_eq!(format.decode(&bytes), [0.25, 2.0, -1.0, 1.0]);
        }
        let result = generate_mips(TextureFormat::Rgba32Float, 2, 2, &[0; 16]);
        assert!(
            matches!(result, Err(Error::Resource(ResourceError::TextureData { expected: 64, got: 16, .. }))),
            "{result:?}"
        );
        Ok(())
    }
}
