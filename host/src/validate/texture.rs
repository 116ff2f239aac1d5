//! What textures are checked with before either backend sees their data.

use crate::error::{Error, ResourceError, Result};
use crate::types::texture::TextureFormat;

/// Refuses mip level `level` of `width × height` texels of `format` when its
/// data is not `got` = width × height × bytes per texel bytes.
pub(crate) fn check_level(format: TextureFormat, level: u32, width: u32, height: u32, got: usize) -> Result<()> {
    let expected = width as usize * height as usize * format.bytes_per_texel();
    if got != expected {
        return Err(Error::Resource(ResourceError::TextureData {
            level,
            width,
            height,
            format,
            expected,
            got,
            fix: "give width × height × bytes_per_texel() bytes per level, rows packed without padding",
        }));
    }
    Ok(())
}
