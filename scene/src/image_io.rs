//! Writing pictures: RGBA8 pixels (packed as `u32`, red in the lowest byte) or
//! linear RGB radiance (sRGB-encoded to 8 bits) to PNG through the `image`
//! crate, linear RGB radiance to PFM and, with feature `exr`, to OpenEXR (32-bit
//! float channels, through the `exr` crate). Rows run top to bottom in
//! memory, as raykit's renderers store them.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;

/// Why a picture could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The pixel slice does not hold `width × height` pixels.
    #[error("{what}: {got} pixels given for a {width}×{height} image ({want} expected); pass one pixel per position, row-major")]
    Size {
        /// What was written.
        what: &'static str,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Pixels expected.
        want: usize,
        /// Pixels given.
        got: usize,
    },
    /// The PNG encoder failed.
    #[error("writing PNG {path}: {source}")]
    Png {
        /// The file.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
    /// The EXR encoder failed.
    #[cfg(feature = "exr")]
    #[error("writing EXR {path}: {source}")]
    Exr {
        /// The file.
        path: PathBuf,
        /// The encoder's error.
        source: exr::error::Error,
    },
    /// Writing the file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

fn check_size(what: &'static str, width: u32, height: u32, got: usize) -> Result<(), ImageError> {
    let want = width as usize * height as usize;
    if got != want || want == 0 {
        return Err(ImageError::Size { what, width, height, want, got });
    }
    Ok(())
}

/// Writes RGBA8 pixels (red in the lowest byte) as a PNG file.
pub fn write_png_rgba8(path: &Path, width: u32, height: u32, pixels: &[u32]) -> Result<(), ImageError> {
    check_size("PNG", width, height, pixels.len())?;
    let bytes: Vec<u8> = pixels.iter().flat_map(|p| p.to_le_bytes()).collect();
    image::save_buffer(path, &bytes, width, height, image::ExtendedColorType::Rgba8)
        .map_err(|source| ImageError::Png { path: path.to_owned(), source })
}

/// Writes linear RGB radiance as an 8-bit sRGB PNG file: each channel clamped
/// to `[0, 1]`, sRGB-encoded and rounded (`raykit_device::color::pack_srgb8`,
/// the quantisation device programs use), alpha opaque. Tone-map first for
/// radiance above 1.
pub fn write_png_srgb(path: &Path, width: u32, height: u32, radiance: &[Vec3]) -> Result<(), ImageError> {
    check_size("PNG", width, height, radiance.len())?;
    let pixels: Vec<u32> = radiance.iter().map(|&c| raykit_device::color::pack_srgb8(c)).collect();
    write_png_rgba8(path, width, height, &pixels)
}

/// Writes linear RGB radiance as an OpenEXR file (channels R, G, B as 32-bit floats).
#[cfg(feature = "exr")]
pub fn write_exr(path: &Path, width: u32, height: u32, radiance: &[Vec3]) -> Result<(), ImageError> {
    check_size("EXR", width, height, radiance.len())?;
    let w = width as usize;
    exr::prelude::write_rgb_file(path, w, height as usize, |x, y| {
        let c = radiance[y * w + x];
        (c.x, c.y, c.z)
    })
    .map_err(|source| ImageError::Exr { path: path.to_owned(), source })
}

/// Writes linear RGB radiance as a PFM file (little-endian floats, rows bottom
/// to top, as the format wants).
pub fn write_pfm(path: &Path, width: u32, height: u32, radiance: &[Vec3]) -> Result<(), ImageError> {
    check_size("PFM", width, height, radiance.len())?;
    let io = |source| ImageError::Io { path: path.to_owned(), source };
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    write!(out, "PF\n{width} {height}\n-1.0\n").map_err(io)?;
    for row in (0..height as usize).rev() {
        let start = row * width as usize;
        for c in &radiance[start..start + width as usize] {
            for v in [c.x, c.y, c.z] {
                out.write_all(&v.to_le_bytes()).map_err(io)?;
            }
        }
    }
    out.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pictures_round_trip_through_their_readers() {
        let dir = std::env::temp_dir().join(format!("raykit-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (3u32, 2u32);
        let pixels: Vec<u32> = (0..6u32).map(|i| 0xff00_0000 | (i * 40) | ((255 - i * 40) << 8)).collect();
        let png = dir.join("a.png");
        write_png_rgba8(&png, w, h, &pixels).unwrap();
        let back = image::open(&png).unwrap().to_rgba8();
        let back: Vec<u32> = back.pixels().map(|p| u32::from_le_bytes(p.0)).collect();
        assert_eq!(back, pixels);

        let radiance: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32 * 0.5, 10.0 - i as f32, 1e-3 * i as f32)).collect();
        #[cfg(feature = "exr")]
        {
            let exr_path = dir.join("a.exr");
            write_exr(&exr_path, w, h, &radiance).unwrap();
            let image = exr::prelude::read_first_rgba_layer_from_file(
                &exr_path,
                |res, _| vec![Vec3::ZERO; res.width() * res.height()],
                |buf: &mut Vec<Vec3>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    buf[pos.y() * 3 + pos.x()] = Vec3::new(r, g, b)
                },
            )
            .unwrap();
            assert_eq!(image.layer_data.channel_data.pixels, radiance);
        }

        let pfm = dir.join("a.pfm");
        write_pfm(&pfm, w, h, &radiance).unwrap();
        let bytes = std::fs::read(&pfm).unwrap();
        let header = b"PF\n3 2\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        // The first stored row is the image's bottom row.
        let first = f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, radiance[3].x);

        // Linear radiance to sRGB 8-bit: 0 → 0, 1 → 255, 0.5 → 188 (the sRGB
        // curve: 1.055 · 0.5^(1/2.4) − 0.055 = 0.7354, × 255 = 187.5 → 188), clamped above 1.
        let linear = [Vec3::new(0.0, 1.0, 0.5), Vec3::new(4.0, 0.0031308, 0.05)];
        let srgb = dir.join("srgb.png");
        write_png_srgb(&srgb, 2, 1, &linear).unwrap();
        let back = image::open(&srgb).unwrap().to_rgba8();
        let back: Vec<[u8; 4]> = back.pixels().map(|p| p.0).collect();
        // 0.0031308 → 12.92 · 0.0031308 · 255 = 10.3 → 10; 0.05 → 0.2478 · 255 = 63.2 → 63.
        assert_eq!(back, vec![[0, 255, 188, 255], [255, 10, 63, 255]]);

        let err = write_png_rgba8(&png, 4, 4, &pixels).unwrap_err();
        assert!(matches!(err, ImageError::Size { want: 16, got: 6, .. }), "{err}");
        let err = write_png_srgb(&png, 4, 4, &linear).unwrap_err();
        assert!(matches!(err, ImageError::Size { want: 16, got: 2, .. }), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
