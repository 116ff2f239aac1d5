//! The CPU backend's textures: what `Texture2D` handles name when device
//! programs run on the host, and the sampler behind
//! [`SampleTexture::sample_lod`](raykit_device::SampleTexture::sample_lod).
//!
//! A texture keeps its mip levels as the host gave them (the texel bytes of
//! its [`TextureFormat`]) and its [`SamplerOptions`]. Handles are numbered as
//! on Vulkan, a slot and a generation (see [`crate::validate::handles`]), so launches
//! check them the same way; a launch takes a snapshot of the table when it
//! starts, so a texture dropped while it runs stays alive until it ends.
//!
//! Sampling follows Vulkan's rules for `OpImageSampleExplicitLod` with the
//! sampler raykit makes on Vulkan (see
//! [Texel Filtering](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#textures-texel-filtering)):
//! * the level of detail is clamped to the mip chain `[0, levels − 1]`; the
//!   nearest mip filter takes level `⌈λ + 0.5⌉ − 1`, the linear one blends
//!   levels `⌊λ⌋` and `⌊λ⌋ + 1` by the fraction of `λ`;
//! * within a level of `w × h` texels, the texel coordinate is `(u·w, v·h)`;
//!   the nearest filter takes texel `⌊u·w⌋`, the linear filter blends the 2×2
//!   texels around `u·w − 0.5` by their distances;
//! * each integer texel coordinate is wrapped by its axis's address mode
//!   (repeat, clamp to edge, mirrored repeat);
//! * texels are decoded to linear values before filtering (sRGB colour
//!   through the sRGB transfer function, 8-bit values over 255, half floats
//!   widened).
//!
//! Weights and blends are computed in `f32`; the null handle, and a handle
//! whose slot holds no texture, sample as zero, as the device's null
//! descriptor does.

use std::sync::{Arc, OnceLock};

use glam::{Vec2, Vec4};

use super::slots::{SlotTable, SlotValue};
use crate::error::Error;
use crate::error::ResourceError;
use crate::types::texture::{AddressMode, Filter, MipLevel, SamplerOptions, TextureFormat};

const SLOTS: u32 = raykit_abi::TEXTURE_TABLE_SLOTS;

/// The largest width and height of a texture on the CPU backend (its
/// `maxImageDimension2D`): that of lavapipe and of most GPUs.
pub(crate) const MAX_SIZE: u32 = 16384;

/// The CPU sampler's filtering precision as Vulkan reports it:
/// `(subTexelPrecisionBits, mipmapPrecisionBits)`. Weights are `f32`, so a
/// texel coordinate keeps at least 8 fractional bits up to `u·w` = 2^15
/// (every texture at most [`MAX_SIZE`] wide, sampled within two repeats), and
/// the mip fraction is exact.
pub(crate) const PRECISION_BITS: (u32, u32) = (8, 8);

/// Texel coordinates are clamped to ±2^24, where `f32` has no fractional bits
/// left: the weights there are 0 and the integer coordinates fit an `i64`.
const COORDINATE_LIMIT: f32 = 16_777_216.0;

/// One texture: its texels, level 0 first, and how it is sampled.
pub(crate) struct CpuTexture {
    format: TextureFormat,
    options: SamplerOptions,
    levels: Vec<MipLevel>,
}

impl CpuTexture {
    /// A texture of `levels`, already checked: at least one, each of the size
    /// [`crate::types::texture::mip_size`] gives, with `width × height ×
    /// bytes_per_texel` bytes.
    pub(crate) fn new(format: TextureFormat, levels: Vec<MipLevel>, options: SamplerOptions) -> CpuTexture {
        CpuTexture { format, options, levels }
    }

    /// Bytes of texels held.
    pub(crate) fn bytes(&self) -> u64 {
        self.levels.iter().map(|l| l.data.len() as u64).sum()
    }

    /// Samples at `uv` and level of detail `lod` (see the module's rules).
    pub(crate) fn sample(&self, uv: Vec2, lod: f32) -> Vec4 {
        let Some(last) = self.levels.len().checked_sub(1) else { return Vec4::ZERO };
        if last == 0 {
            // One level: every level of detail clamps to it.
            return self.sample_level(0, uv);
        }
        let lod = if lod.is_nan() { 0.0 } else { lod.clamp(0.0, last as f32) };
        match self.options.mip_filter {
            Filter::Nearest => {
                // Vulkan's preferred rounding: a level half-way between two takes the lower.
                let level = ((lod + 0.5).ceil() - 1.0).max(0.0) as usize;
                self.sample_level(level.min(last), uv)
            }
            Filter::Linear => {
                let floor = lod.floor();
                let (level, delta) = (floor as usize, lod - floor);
                if level >= last || delta == 0.0 {
                    return self.sample_level(level.min(last), uv);
                }
                (1.0 - delta) * self.sample_level(level, uv) + delta * self.sample_level(level + 1, uv)
            }
        }
    }

    /// Samples level `level` at `uv` with the texture's filter and address modes.
    fn sample_level(&self, level: usize, uv: Vec2) -> Vec4 {
        let Some(l) = self.levels.get(level) else { return Vec4::ZERO };
        let (modes, (w, h)) = ((self.options.address_u, self.options.address_v), (l.width, l.height));
        let x = texel_coordinate(uv.x, w);
        let y = texel_coordinate(uv.y, h);
        match self.options.filter {
            Filter::Nearest => {
                let i = wrap(floor(x), w, modes.0);
                let j = wrap(floor(y), h, modes.1);
                self.fetch(l, i, j)
            }
            Filter::Linear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (i0, j0) = (floor(x), floor(y));
                let (a, b) = (x - i0 as f32, y - j0 as f32);
                let (i, i1) = (wrap(i0, w, modes.0), wrap(i0 + 1, w, modes.0));
                let (j, j1) = (wrap(j0, h, modes.1), wrap(j0 + 1, h, modes.1));
                (1.0 - a) * (1.0 - b) * self.fetch(l, i, j)
                    + a * (1.0 - b) * self.fetch(l, i1, j)
                    + (1.0 - a) * b * self.fetch(l, i, j1)
                    + a * b * self.fetch(l, i1, j1)
            }
        }
    }

    /// The linear value of texel `(x, y)` of `level` (zero outside it, which
    /// wrapped coordinates never are).
    #[inline]
    fn fetch(&self, level: &MipLevel, x: u32, y: u32) -> Vec4 {
        /// The `N` bytes of texel `i`, when `data` holds them.
        #[inline(always)]
        fn texel<const N: usize>(data: &[u8], i: usize) -> Option<&[u8; N]> {
            data.get(i.checked_mul(N)?..)?.first_chunk()
        }
        let i = y as usize * level.width as usize + x as usize;
        let unorm = |b: u8| f32::from(b) / 255.0;
        let texel = match self.format {
            TextureFormat::Rgba8Srgb => texel::<4>(&level.data, i).map(|t| {
                let srgb = srgb_table();
                Vec4::new(srgb[usize::from(t[0])], srgb[usize::from(t[1])], srgb[usize::from(t[2])], unorm(t[3]))
            }),
            TextureFormat::Rgba8Unorm => {
                texel::<4>(&level.data, i).map(|t| Vec4::new(unorm(t[0]), unorm(t[1]), unorm(t[2]), unorm(t[3])))
            }
            TextureFormat::Rgba16Float => texel::<8>(&level.data, i).map(|t| {
                Vec4::from_array(std::array::from_fn(|c| half::f16::from_le_bytes([t[2 * c], t[2 * c + 1]]).to_f32()))
            }),
            TextureFormat::Rgba32Float => texel::<16>(&level.data, i).map(|t| {
                Vec4::from_array(std::array::from_fn(|c| {
                    f32::from_le_bytes([t[4 * c], t[4 * c + 1], t[4 * c + 2], t[4 * c + 3]])
                }))
            }),
        };
        texel.unwrap_or(Vec4::ZERO)
    }
}

/// `c × size`, with NaN taken as 0 and the result clamped to ±[`COORDINATE_LIMIT`].
fn texel_coordinate(c: f32, size: u32) -> f32 {
    let x = c * size as f32;
    if x.is_nan() {
        0.0
    } else {
        x.clamp(-COORDINATE_LIMIT, COORDINATE_LIMIT)
    }
}

/// `⌊x⌋` of a texel coordinate (not NaN, within ±[`COORDINATE_LIMIT`] + 1,
/// where every `i64` it gives converts back to `f32` exactly), without the
/// library call `f32::floor` is on x86-64's baseline.
#[inline(always)]
fn floor(x: f32) -> i64 {
    let t = x as i64;
    if t as f32 > x {
        t - 1
    } else {
        t
    }
}

/// Texel index `i` wrapped into `0..size` by `mode` (Vulkan's wrapping operations).
#[inline(always)]
fn wrap(i: i64, size: u32, mode: AddressMode) -> u32 {
    let n = i64::from(size.max(1));
    // Every mode leaves an index inside the texture as it is.
    if (0..n).contains(&i) {
        return i as u32;
    }
    let wrapped = match mode {
        AddressMode::Repeat => i.rem_euclid(n),
        AddressMode::ClampToEdge => i.clamp(0, n - 1),
        AddressMode::MirroredRepeat => {
            let t = i.rem_euclid(2 * n);
            if t >= n {
                2 * n - 1 - t
            } else {
                t
            }
        }
    };
    wrapped as u32
}

/// The linear value of each 8-bit sRGB code ([`TextureFormat::decode`]'s).
fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| raykit_device::color::srgb_to_linear(i as f32 / 255.0)))
}

/// The textures of every slot when a launch started, up to the last one taken.
pub(crate) type Snapshot = super::slots::Snapshot<Arc<CpuTexture>>;

/// Samples handle `handle` of `textures` (zero for a slot holding none).
pub(crate) fn sample(textures: &[Option<Arc<CpuTexture>>], handle: u32, uv: Vec2, lod: f32) -> Vec4 {
    match textures.get((handle & (SLOTS - 1)) as usize) {
        Some(Some(texture)) => texture.sample(uv, lod),
        _ => Vec4::ZERO,
    }
}

/// The texture table of one CPU context.
pub(crate) type TextureTable = SlotTable<Arc<CpuTexture>>;

impl SlotValue for Arc<CpuTexture> {
    const SLOTS: u32 = SLOTS;

    fn table_full(capacity: u32) -> Error {
        Error::Resource(ResourceError::TextureTableFull { capacity })
    }

    fn bytes(&self) -> u64 {
        CpuTexture::bytes(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(
        format: TextureFormat,
        width: u32,
        height: u32,
        texels: &[[f32; 4]],
        options: SamplerOptions,
    ) -> CpuTexture {
        let mut data = Vec::new();
        for t in texels {
            format.encode(*t, &mut data);
        }
        CpuTexture::new(format, vec![MipLevel { width, height, data }], options)
    }

    #[test]
    fn address_modes_wrap_as_vulkan_does() {
        let got: Vec<u32> = (-5..9).map(|i| wrap(i, 3, AddressMode::MirroredRepeat)).collect();
        assert_eq!(got, [1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2]);
        let got: Vec<u32> = (-2..5).map(|i| wrap(i, 3, AddressMode::Repeat)).collect();
        assert_eq!(got, [1, 2, 0, 1, 2, 0, 1]);
        let got: Vec<u32> = (-2..5).map(|i| wrap(i, 3, AddressMode::ClampToEdge)).collect();
        assert_eq!(got, [0, 0, 0, 1, 2, 2, 2]);
    }

    #[test]
    fn bilinear_weights_come_from_texel_centres() {
        // A 2×1 ramp from 0 to 1: halfway between the texel centres (u = 0.5) is 0.5;
        // at u = 0.375 (texel coordinate 0.75, a quarter past the first centre) 0.25.
        let options = SamplerOptions { address_u: AddressMode::ClampToEdge, ..Default::default() };
        let t = texture(TextureFormat::Rgba32Float, 2, 1, &[[0.0; 4], [1.0; 4]], options);
        assert_eq!(t.sample(Vec2::new(0.5, 0.5), 0.0).x, 0.5);
        assert_eq!(t.sample(Vec2::new(0.375, 0.5), 0.0).x, 0.25);
        // Clamped to the edge texel before its centre; repeat blends with the far edge.
        assert_eq!(t.sample(Vec2::new(0.1, 0.5), 0.0).x, 0.0);
        let t = texture(TextureFormat::Rgba32Float, 2, 1, &[[0.0; 4], [1.0; 4]], SamplerOptions::default());
        assert_eq!(t.sample(Vec2::new(0.0, 0.5), 0.0).x, 0.5);
    }

    #[test]
    fn srgb_is_decoded_before_filtering() {
        // Black and white sRGB texels blend to linear 0.5, not to the decode of 0.5.
        let options = SamplerOptions { address_u: AddressMode::ClampToEdge, ..Default::default() };
        let t = texture(TextureFormat::Rgba8Srgb, 2, 1, &[[0.0, 0.0, 0.0, 1.0], [1.0; 4]], options);
        let got = t.sample(Vec2::new(0.5, 0.5), 0.0);
        assert!((got.x - 0.5).abs() < 1e-6 && got.w == 1.0, "{got}");
    }

    #[test]
    fn mip_levels_are_chosen_and_blended_by_the_lod() {
        let levels = vec![
            MipLevel { width: 2, height: 2, data: bytemuck::cast_slice(&[[0.0f32; 4]; 4]).to_vec() },
            MipLevel { width: 1, height: 1, data: bytemuck::cast_slice(&[[1.0f32; 4]]).to_vec() },
        ];
        let nearest = SamplerOptions { mip_filter: Filter::Nearest, ..Default::default() };
        let t = CpuTexture::new(TextureFormat::Rgba32Float, levels.clone(), nearest);
        let at = |lod| t.sample(Vec2::splat(0.3), lod).x;
        assert_eq!([at(-1.0), at(0.5), at(0.51), at(7.0), at(f32::NAN)], [0.0, 0.0, 1.0, 1.0, 0.0]);
        let t = CpuTexture::new(TextureFormat::Rgba32Float, levels, SamplerOptions::default());
        let at = |lod| t.sample(Vec2::splat(0.3), lod).x;
        assert_eq!([at(0.0), at(0.25), at(1.0), at(3.0)], [0.0, 0.25, 1.0, 1.0]);
    }

    #[test]
    fn odd_coordinates_and_handles_sample_without_panicking() {
        let t = Arc::new(texture(TextureFormat::Rgba16Float, 1, 1, &[[2.0; 4]], SamplerOptions::default()));
        for c in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
            assert_eq!(t.sample(Vec2::new(c, 0.5), 0.0), Vec4::splat(2.0));
        }
        let table = [None, Some(t)];
        assert_eq!(sample(&table, 0, Vec2::ZERO, 0.0), Vec4::ZERO);
        assert_eq!(sample(&table, 1, Vec2::ZERO, 0.0), Vec4::splat(2.0));
        assert_eq!(sample(&table, 2 | (7 << 12), Vec2::ZERO, 0.0), Vec4::ZERO);
    }

    #[test]
    fn the_table_checks_generations_and_snapshots_its_textures() -> crate::error::Result<()> {
        let table = TextureTable::default();
        let t = || Arc::new(texture(TextureFormat::Rgba8Unorm, 1, 1, &[[1.0; 4]], SamplerOptions::default()));
        let (slot, handle) = table.insert(t())?;
        assert!(table.is_live(handle) && table.is_live(0) && !table.is_live(handle + (1 << 12)));
        let snapshot = table.snapshot();
        assert_eq!(snapshot.len(), slot as usize + 1);
        assert!(Arc::ptr_eq(&snapshot, &table.snapshot()), "unchanged tables share their snapshot");
        table.remove(slot);
        assert!(!table.is_live(handle));
        // The launch's snapshot keeps the dropped texture.
        assert_eq!(sample(&snapshot, handle, Vec2::ZERO, 0.0), Vec4::ONE);
        assert_eq!(table.snapshot().len(), 0);
        assert_eq!(table.usage(), (0, 0));
        Ok(())
    }
}
