//! Texture descriptions: texel formats, samplers, mip levels.

/// The texel formats of textures. All sample as four `f32` components.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum TextureFormat {
    /// 8-bit RGBA, sRGB-encoded colour (alpha linear); the sampler decodes to linear.
    Rgba8Srgb,
    /// 8-bit RGBA, linear (unsigned normalised).
    Rgba8Unorm,
    /// 16-bit float RGBA (IEEE half precision, little-endian).
    Rgba16Float,
    /// 32-bit float RGBA (little-endian).
    Rgba32Float,
}

impl TextureFormat {
    /// Every format.
    pub const ALL: [TextureFormat; 4] =
        [TextureFormat::Rgba8Srgb, TextureFormat::Rgba8Unorm, TextureFormat::Rgba16Float, TextureFormat::Rgba32Float];

    /// Bytes of one texel.
    pub const fn bytes_per_texel(self) -> usize {
        match self {
            TextureFormat::Rgba8Srgb | TextureFormat::Rgba8Unorm => 4,
            TextureFormat::Rgba16Float => 8,
            TextureFormat::Rgba32Float => 16,
        }
    }

    /// The linear value of the texel in `bytes` (what a sampler reads for it: sRGB
    /// colour decoded, 8-bit values over 255).
    pub fn decode(self, bytes: &[u8]) -> [f32; 4] {
        let mut out = [0.0; 4];
        for (c, v) in out.iter_mut().enumerate() {
            *v = match self {
                TextureFormat::Rgba8Srgb if c < 3 => raykit_device::color::srgb_to_linear(bytes[c] as f32 / 255.0),
                TextureFormat::Rgba8Srgb | TextureFormat::Rgba8Unorm => bytes[c] as f32 / 255.0,
                TextureFormat::Rgba16Float => half::f16::from_le_bytes([bytes[2 * c], bytes[2 * c + 1]]).to_f32(),
                TextureFormat::Rgba32Float => {
                    f32::from_le_bytes([bytes[4 * c], bytes[4 * c + 1], bytes[4 * c + 2], bytes[4 * c + 3]])
                }
            };
        }
        out
    }

    /// The texel of linear value `value` (sRGB-encoded for [`TextureFormat::Rgba8Srgb`],
    /// rounded to the nearest representable value), appended to `out`.
    pub fn encode(self, value: [f32; 4], out: &mut Vec<u8>) {
        let unorm = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        for (c, v) in value.into_iter().enumerate() {
            match self {
                TextureFormat::Rgba8Srgb if c < 3 => out.push(unorm(raykit_device::color::linear_to_srgb(v))),
                TextureFormat::Rgba8Srgb | TextureFormat::Rgba8Unorm => out.push(unorm(v)),
                TextureFormat::Rgba16Float => out.extend_from_slice(&half::f16::from_f32(v).to_le_bytes()),
                TextureFormat::Rgba32Float => out.extend_from_slice(&v.to_le_bytes()),
            }
        }
    }
}

/// A texel filter.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    /// The nearest texel (or mip level).
    Nearest,
    /// Linear interpolation between texels (or between two mip levels).
    #[default]
    Linear,
}

/// What happens to texture coordinates outside `[0, 1]`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum AddressMode {
    /// Tiles the texture.
    #[default]
    Repeat,
    /// Repeats the edge texels.
    ClampToEdge,
    /// Tiles the texture, mirrored every other tile.
    MirroredRepeat,
}

/// How a texture is sampled.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct SamplerOptions {
    /// Filter within a mip level (magnification and minification).
    pub filter: Filter,
    /// Filter between mip levels.
    pub mip_filter: Filter,
    /// Address mode of `u` (across a row).
    pub address_u: AddressMode,
    /// Address mode of `v` (down the rows).
    pub address_v: AddressMode,
}

/// Which mip levels a texture gets from one image.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mipmaps {
    /// Only the given level.
    One,
    /// The full chain down to 1×1, generated on the host (as `texture::generate_mips` makes it).
    #[default]
    Generate,
}

/// One mip level's texels, row-major, row 0 first.
#[derive(Clone, Debug, PartialEq)]
pub struct MipLevel {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height × bytes_per_texel` bytes.
    pub data: Vec<u8>,
}

/// The size of mip level `level` of a `width × height` texture: halved per level, at least 1.
pub fn mip_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    ((width >> level).max(1), (height >> level).max(1))
}

/// The number of levels of a full mip chain of a `width × height` texture.
pub fn full_mip_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// What a device can do with a texture format.
pub(crate) struct FormatSupport {
    /// Sample it, and upload to it.
    pub(crate) sampled: bool,
    /// Filter it linearly.
    pub(crate) linear_filter: bool,
    /// What the device reports, for errors.
    pub(crate) features: String,
}
