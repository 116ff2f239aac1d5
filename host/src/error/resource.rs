//! Errors of buffers and textures: sizes, ranges, data, formats and the bindless tables.

/// Errors of buffers and textures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ResourceError {
    /// A buffer is larger than one storage-buffer descriptor can cover.
    #[error("a buffer of {bytes} bytes is over this device's maxStorageBufferRange of {limit} bytes, the most a device program can reach through one buffer handle; split the data into several buffers (for example one per image tile or row block) and pass their handles, or an array of handles, in the params")]
    BufferTooLarge {
        /// The buffer's size.
        bytes: u64,
        /// `maxStorageBufferRange`.
        limit: u32,
    },

    /// The bindless buffer table is full.
    #[error("the buffer table is full ({capacity} live buffers); drop buffers that are no longer needed")]
    BufferTableFull {
        /// Its size.
        capacity: u32,
    },

    /// The texture table has no free slot.
    #[error("the texture table is full ({capacity} live textures); drop textures no longer needed, or pack several images into one (an atlas)")]
    TextureTableFull {
        /// Its size.
        capacity: u32,
    },

    /// A texture of that size cannot be made.
    #[error("texture of {width}×{height}: {problem}; {fix}")]
    TextureSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
        /// What is wrong.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// The texel data given for a texture does not fit it.
    #[error("texture data of mip level {level} ({width}×{height} {format:?}): {got} bytes given, {expected} expected; {fix}")]
    TextureData {
        /// The mip level.
        level: u32,
        /// That level's width.
        width: u32,
        /// That level's height.
        height: u32,
        /// The format.
        format: crate::types::texture::TextureFormat,
        /// Bytes the level needs.
        expected: usize,
        /// Bytes given.
        got: usize,
        /// How to fix it.
        fix: &'static str,
    },

    /// A texture format or source image raykit or the device cannot use.
    #[error("texture format {format}: {problem}; {fix}")]
    TextureFormat {
        /// The format (raykit's, or the source image's).
        format: String,
        /// What is wrong.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// An image file that cannot be read or decoded.
    #[error("reading the image {path}: {reason}; give a PNG or JPEG file, or decode it yourself and call Texture::from_image")]
    ImageFile {
        /// The file.
        path: std::path::PathBuf,
        /// What the reader or the decoder said.
        reason: String,
    },

    /// A buffer of that size cannot be made.
    #[error("buffer of {len} elements of {element_size} bytes: {reason}")]
    BufferSize {
        /// Elements asked for.
        len: usize,
        /// Size of one element.
        element_size: usize,
        /// Why not.
        reason: &'static str,
    },

    /// A buffer range past the buffer's end, or reversed.
    #[error("elements {start}..{end} of a buffer of {len}: {}", if .start > .end { "the range is reversed" } else { "past the buffer's end" })]
    BufferRange {
        /// First element of the range.
        start: usize,
        /// One past its last element.
        end: usize,
        /// Elements in the buffer.
        len: usize,
    },
}
