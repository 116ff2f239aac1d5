//! Denoising of progressive renders with Intel Open Image Denoise (OIDN).
//!
//! [`Denoiser`] runs OIDN's `RT` filter (ray-traced images, `hdr` on) on a
//! linear HDR RGB image, with optional first-hit albedo and normal guides
//! ([`Input`]), on OIDN's CPU device, or on its CUDA device where one exists
//! ([`DenoiseDevice`]; [`DenoiseDevice::Auto`] takes CUDA when it works, else the CPU).
//!
//! # The library
//!
//! OIDN is loaded at run time (`dlopen` of `libOpenImageDenoise.so.2`), not
//! linked: a build of raykit never needs OIDN, and a machine without it gets
//! [`Error::LibraryMissing`], which names the command that installs it:
//!
//! ```text
//! cargo xtask setup --denoise
//! ```
//!
//! That command downloads the official OIDN 2.5.1 Linux libraries (CPU and
//! CUDA devices, TBB) from PyPI's `pyoidn` wheel and unpacks them into
//! [`default_library_dir`] (`$RAYKIT_CACHE_DIR/oidn-2.5.1/lib`, else
//! `$XDG_CACHE_HOME/raykit/…`, else `~/.cache/raykit/…`). Python is not needed,
//! then or at run time. The library is looked for:
//!
//! 1. in `$RAYKIT_OIDN_DIR` when that is set (and only there: setting it to an
//!    empty folder hides the library, which is how the missing-library error is tested);
//! 2. in [`default_library_dir`];
//! 3. by the system's loader (`libOpenImageDenoise.so.2` on the library path, e.g. an OIDN
//!    installed system-wide).
//!
//! # Example
//!
//! ```no_run
//! use raykit_denoise::{DenoiseDevice, Denoiser, Input};
//!
//! let (width, height) = (64, 64);
//! let noisy = vec![[0.5f32; 3]; width * height];
//! let denoiser = Denoiser::new(DenoiseDevice::Auto)?;
//! let clean = denoiser.denoise(&Input::new(width as u32, height as u32, &noisy))?;
//! assert_eq!(clean.len(), noisy.len());
//! # Ok::<(), raykit_denoise::Error>(())
//! ```

#[cfg(feature = "cli")]
mod cli;
mod ffi;

#[cfg(feature = "cli")]
pub use cli::DenoiseArgs;

use std::ffi::{c_char, c_void};
use std::path::{Path, PathBuf};

/// The OIDN release `cargo xtask setup --denoise` installs.
pub const OIDN_VERSION: &str = "2.5.1";

/// The library file the denoiser loads.
pub const LIBRARY_NAME: &str = "libOpenImageDenoise.so.2";

/// The command that installs OIDN where the denoiser finds it.
pub const INSTALL_COMMAND: &str = "cargo xtask setup --denoise";

/// The variable naming a folder that holds [`LIBRARY_NAME`] (and OIDN's other
/// libraries beside it); when set, the only place the library is looked for.
pub const LIBRARY_DIR_VAR: &str = "RAYKIT_OIDN_DIR";

/// Where OIDN runs.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum DenoiseDevice {
    /// OIDN's CUDA device when one works here (an NVIDIA GPU and driver), else its CPU device.
    #[default]
    Auto,
    /// OIDN's CPU device (any x86-64 CPU with SSE4.1; every core).
    Cpu,
    /// OIDN's CUDA device (an NVIDIA GPU of Volta or newer with its driver).
    Cuda,
}

/// The device a [`Denoiser`] runs on, once chosen.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum DeviceKind {
    /// OIDN's CPU device.
    Cpu,
    /// OIDN's CUDA device.
    Cuda,
}

impl std::fmt::Display for DeviceKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DeviceKind::Cpu => "CPU",
            DeviceKind::Cuda => "CUDA",
        })
    }
}

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// OIDN could not be loaded.
    #[error(
        "Open Image Denoise ({LIBRARY_NAME}) could not be loaded: {tried}. Install it with `{INSTALL_COMMAND}` \
         (OIDN {OIDN_VERSION} into {default_dir}), or set {LIBRARY_DIR_VAR} to a folder holding {LIBRARY_NAME}",
        default_dir = default_library_dir().display()
    )]
    LibraryMissing {
        /// Each place tried and why it failed.
        tried: String,
    },
    /// The requested device does not exist or does not work here.
    #[error(
        "OIDN's {requested} device is not available here ({message}); use DenoiseDevice::Cpu, or DenoiseDevice::Auto \
         to take CUDA only where it works"
    )]
    DeviceUnavailable {
        /// The device asked for.
        requested: DeviceKind,
        /// OIDN's reason.
        message: String,
    },
    /// A size of zero, or one whose byte count overflows.
    #[error("cannot denoise a {width}×{height} image: {why}")]
    BadSize {
        /// The width given.
        width: u32,
        /// The height given.
        height: u32,
        /// What is wrong.
        why: &'static str,
    },
    /// An image's pixel count differs from width × height.
    #[error(
        "the {image} image has {got} pixels, but the image is {width}×{height} ({expected} pixels); pass one RGB \
         triple per pixel, row by row"
    )]
    SizeMismatch {
        /// `color`, `albedo` or `normal`.
        image: &'static str,
        /// Pixels expected.
        expected: usize,
        /// Pixels given.
        got: usize,
        /// The width.
        width: u32,
        /// The height.
        height: u32,
    },
    /// OIDN's RT filter takes a normal guide only together with an albedo guide.
    #[error("a normal guide needs an albedo guide too (OIDN's RT filter takes color+albedo or color+albedo+normal)")]
    NormalWithoutAlbedo,
    /// An input pixel is NaN or infinite.
    #[error(
        "the {image} image has a non-finite value ({value}) at pixel ({x}, {y}); OIDN needs finite input: clamp or \
         drop such samples before denoising"
    )]
    NonFinite {
        /// `color`, `albedo` or `normal`.
        image: &'static str,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The value.
        value: f32,
    },
    /// OIDN reported an error.
    #[error("OIDN failed in {operation}: {code}: {message}")]
    Device {
        /// The call that failed.
        operation: &'static str,
        /// OIDN's error code, by name.
        code: &'static str,
        /// OIDN's message.
        message: String,
    },
}

/// Results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Where `cargo xtask setup --denoise` installs OIDN: `oidn-<version>/lib` in
/// raykit's cache folder (`$RAYKIT_CACHE_DIR`, else `$XDG_CACHE_HOME/raykit`,
/// else `~/.cache/raykit`).
pub fn default_library_dir() -> PathBuf {
    cache_dir().join(format!("oidn-{OIDN_VERSION}")).join("lib")
}

/// raykit's cache folder (the one raykit-builder keeps the shader builder in).
fn cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("RAYKIT_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("raykit");
    }
    match std::env::var_os("HOME") {
        Some(home) => PathBuf::from(home).join(".cache").join("raykit"),
        None => std::env::temp_dir().join("raykit-cache"),
    }
}

/// Loads OIDN from the places the crate documentation lists, in order.
fn load_default() -> Result<&'static ffi::Api> {
    if let Some(dir) = std::env::var_os(LIBRARY_DIR_VAR) {
        return load_from(Path::new(&dir)).map_err(|why| Error::LibraryMissing {
            tried: format!("{LIBRARY_DIR_VAR}={}: {why}", Path::new(&dir).display()),
        });
    }
    let dir = default_library_dir();
    let in_cache = match load_from(&dir) {
        Ok(api) => return Ok(api),
        Err(why) => format!("{}: {why}", dir.display()),
    };
    match ffi::load(Path::new(LIBRARY_NAME)) {
        Ok(api) => Ok(api),
        Err(why) => Err(Error::LibraryMissing { tried: format!("{in_cache}; the system's library path: {why}") }),
    }
}

fn load_from(dir: &Path) -> Result<&'static ffi::Api, String> {
    let path = dir.join(LIBRARY_NAME);
    if !path.is_file() {
        return Err(format!("no {LIBRARY_NAME} there"));
    }
    ffi::load(&path)
}

/// The images to denoise: linear HDR RGB, one `[r, g, b]` per pixel, row by
/// row from the top, all of `width × height` pixels.
#[derive(Copy, Clone, Debug)]
pub struct Input<'a> {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The noisy colour (mean radiance per pixel).
    pub color: &'a [[f32; 3]],
    /// First-hit albedo (reflectance of the surface each camera ray hits first,
    /// averaged over the pixel's samples; 0 where rays escape), in 0..=1.
    pub albedo: Option<&'a [[f32; 3]]>,
    /// First-hit world-space normals, averaged over the pixel's samples
    /// (unnormalised is fine); needs `albedo`.
    pub normal: Option<&'a [[f32; 3]]>,
    /// Whether the guides are noise-free (OIDN's `cleanAux`): true for the
    /// first-hit albedo and normals of a render without depth of field, motion
    /// blur or glossy first hits, whose only variation within a pixel is its
    /// antialiasing. Noisy guides should set it false.
    pub clean_guides: bool,
}

impl<'a> Input<'a> {
    /// A colour image without guides.
    pub fn new(width: u32, height: u32, color: &'a [[f32; 3]]) -> Input<'a> {
        Input { width, height, color, albedo: None, normal: None, clean_guides: true }
    }

    /// With first-hit albedo and normal guides (noise-free, see [`Input::clean_guides`]).
    pub fn with_guides(self, albedo: &'a [[f32; 3]], normal: &'a [[f32; 3]]) -> Input<'a> {
        Input { albedo: Some(albedo), normal: Some(normal), ..self }
    }

    /// With an albedo guide only.
    pub fn with_albedo(self, albedo: &'a [[f32; 3]]) -> Input<'a> {
        Input { albedo: Some(albedo), ..self }
    }

    /// Checks sizes and values; the pixel count.
    fn validate(&self) -> Result<usize> {
        let (width, height) = (self.width, self.height);
        if width == 0 || height == 0 {
            return Err(Error::BadSize { width, height, why: "the image is empty; pass at least 1×1 pixels" });
        }
        let pixels = (width as usize)
            .checked_mul(height as usize)
            .filter(|n| n.checked_mul(12).is_some())
            .ok_or(Error::BadSize { width, height, why: "its byte size overflows this machine's addresses" })?;
        if self.normal.is_some() && self.albedo.is_none() {
            return Err(Error::NormalWithoutAlbedo);
        }
        let images = [("color", Some(self.color)), ("albedo", self.albedo), ("normal", self.normal)];
        for (image, data) in images {
            let Some(data) = data else { continue };
            if data.len() != pixels {
                return Err(Error::SizeMismatch { image, expected: pixels, got: data.len(), width, height });
            }
            if let Some((i, value)) =
                data.iter().enumerate().find_map(|(i, p)| p.iter().find(|v| !v.is_finite()).map(|v| (i, *v)))
            {
                let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
                return Err(Error::NonFinite { image, x, y, value });
            }
        }
        Ok(pixels)
    }
}

/// An OIDN device ready to denoise; reusable for many images.
pub struct Denoiser {
    api: &'static ffi::Api,
    device: ffi::Device,
    kind: DeviceKind,
}

// SAFETY: OIDN devices may be used from any thread, one call at a time;
// `denoise` takes `&self` but OIDN serialises calls on a device internally.
unsafe impl Send for Denoiser {}
// SAFETY: as above: OIDN's device objects are thread-safe.
unsafe impl Sync for Denoiser {}

impl std::fmt::Debug for Denoiser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Denoiser").field("device", &self.kind).field("library", &self.api.path).finish()
    }
}

impl Denoiser {
    /// Loads OIDN (see the crate documentation for where it is looked for) and
    /// creates the device `device` asks for.
    pub fn new(device: DenoiseDevice) -> Result<Denoiser> {
        Self::with_api(load_default()?, device)
    }

    /// Loads OIDN from `dir` (a folder holding [`LIBRARY_NAME`]) only.
    pub fn from_dir(dir: &Path, device: DenoiseDevice) -> Result<Denoiser> {
        let api = load_from(dir).map_err(|why| Error::LibraryMissing { tried: format!("{}: {why}", dir.display()) })?;
        Self::with_api(api, device)
    }

    fn with_api(api: &'static ffi::Api, device: DenoiseDevice) -> Result<Denoiser> {
        match device {
            DenoiseDevice::Cpu => Self::create(api, DeviceKind::Cpu),
            DenoiseDevice::Cuda => Self::create(api, DeviceKind::Cuda),
            DenoiseDevice::Auto => Self::create(api, DeviceKind::Cuda).or_else(|e| match e {
                Error::DeviceUnavailable { .. } => Self::create(api, DeviceKind::Cpu),
                other => Err(other),
            }),
        }
    }

    fn create(api: &'static ffi::Api, kind: DeviceKind) -> Result<Denoiser> {
        let ty = match kind {
            DeviceKind::Cpu => ffi::DEVICE_TYPE_CPU,
            DeviceKind::Cuda => ffi::DEVICE_TYPE_CUDA,
        };
        // SAFETY: a plain constructor; null on failure, with the error on the null device.
        let device = unsafe { (api.new_device)(ty) };
        if device.is_null() {
            let message = api.take_error(device).map(|(_, m)| m).unwrap_or_else(|| "no such device".to_owned());
            return Err(Error::DeviceUnavailable { requested: kind, message });
        }
        let denoiser = Denoiser { api, device, kind };
        // SAFETY: a live device.
        unsafe { (api.commit_device)(device) };
        if let Some((_, message)) = api.take_error(device) {
            // `denoiser` releases the device.
            return Err(Error::DeviceUnavailable { requested: kind, message });
        }
        Ok(denoiser)
    }

    /// The device this denoiser runs on.
    pub fn device(&self) -> DeviceKind {
        self.kind
    }

    /// The OIDN library's path.
    pub fn library_path(&self) -> &Path {
        &self.api.path
    }

    /// OIDN's version, e.g. 20501 for 2.5.1.
    pub fn version(&self) -> i32 {
        // SAFETY: a live device; the name is NUL-terminated.
        unsafe { (self.api.get_device_int)(self.device, c"version".as_ptr()) }
    }

    /// Denoises `input`: the filtered colour, one `[r, g, b]` per pixel.
    pub fn denoise(&self, input: &Input<'_>) -> Result<Vec<[f32; 3]>> {
        let pixels = input.validate()?;
        let bytes = pixels * 12;
        let api = self.api;
        let buffer = |data: Option<&[[f32; 3]]>| -> Result<Option<OwnedBuffer>> {
            let Some(data) = data else { return Ok(None) };
            // SAFETY: a live device.
            let raw = unsafe { (api.new_buffer)(self.device, bytes) };
            api.check(self.device, "oidnNewBuffer")?;
            let owned = OwnedBuffer { api, raw };
            // SAFETY: `data` holds `bytes` bytes (validated), the buffer as many.
            unsafe { (api.write_buffer)(raw, 0, bytes, data.as_ptr().cast::<c_void>()) };
            api.check(self.device, "oidnWriteBuffer")?;
            Ok(Some(owned))
        };
        let color = buffer(Some(input.color))?;
        let albedo = buffer(input.albedo)?;
        let normal = buffer(input.normal)?;
        // SAFETY: a live device.
        let raw = unsafe { (api.new_buffer)(self.device, bytes) };
        api.check(self.device, "oidnNewBuffer")?;
        let output = OwnedBuffer { api, raw };

        // SAFETY: a live device; the filter type is NUL-terminated.
        let filter = unsafe { (api.new_filter)(self.device, c"RT".as_ptr()) };
        api.check(self.device, "oidnNewFilter")?;
        let filter = OwnedFilter { api, raw: filter };
        let (w, h) = (input.width as usize, input.height as usize);
        let images: [(&std::ffi::CStr, &Option<OwnedBuffer>); 4] =
            [(c"color", &color), (c"albedo", &albedo), (c"normal", &normal), (c"output", &Some(output))];
        for (name, buffer) in images {
            if let Some(buffer) = buffer {
                // SAFETY: live filter and buffer; FLOAT3 images of `w × h` packed pixels fit `bytes`.
                unsafe {
                    (api.set_filter_image)(
                        filter.raw,
                        name.as_ptr(),
                        buffer.raw,
                        ffi::FORMAT_FLOAT3,
                        w,
                        h,
                        0,
                        12,
                        w * 12,
                    )
                };
            }
        }
        let set_bool = |name: &std::ffi::CStr, value: bool| {
            // SAFETY: a live filter; the name is NUL-terminated.
            unsafe { (api.set_filter_bool)(filter.raw, name.as_ptr() as *const c_char, value) }
        };
        set_bool(c"hdr", true);
        if input.albedo.is_some() {
            set_bool(c"cleanAux", input.clean_guides);
        }
        api.check(self.device, "setting the RT filter's images")?;
        // SAFETY: a live filter with its images set.
        unsafe { (api.commit_filter)(filter.raw) };
        api.check(self.device, "oidnCommitFilter")?;
        // SAFETY: as above; synchronous.
        unsafe { (api.execute_filter)(filter.raw) };
        api.check(self.device, "oidnExecuteFilter")?;
        let mut out = vec![[0f32; 3]; pixels];
        let Some(output) = &images[3].1 else { unreachable!("the output buffer is set above") };
        // SAFETY: `out` holds `bytes` bytes, the buffer as many.
        unsafe { (api.read_buffer)(output.raw, 0, bytes, out.as_mut_ptr().cast::<c_void>()) };
        api.check(self.device, "oidnReadBuffer")?;
        Ok(out)
    }
}

impl Drop for Denoiser {
    fn drop(&mut self) {
        // SAFETY: the device is live and released once.
        unsafe { (self.api.release_device)(self.device) };
    }
}

struct OwnedBuffer {
    api: &'static ffi::Api,
    raw: ffi::Buffer,
}

impl Drop for OwnedBuffer {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: a buffer of this device, released once.
            unsafe { (self.api.release_buffer)(self.raw) };
        }
    }
}

struct OwnedFilter {
    api: &'static ffi::Api,
    raw: ffi::Filter,
}

impl Drop for OwnedFilter {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: a filter of this device, released once.
            unsafe { (self.api.release_filter)(self.raw) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_inputs_are_refused_before_oidn_runs() {
        let color = vec![[0.5f32; 3]; 16];
        assert!(matches!(Input::new(0, 4, &[]).validate(), Err(Error::BadSize { .. })));
        let short = vec![[0.5f32; 3]; 15];
        let err = Input::new(4, 4, &short).validate().unwrap_err();
        assert!(matches!(err, Error::SizeMismatch { image: "color", expected: 16, got: 15, .. }), "{err}");
        let err = Input::new(4, 4, &color).with_guides(&color, &short).validate().unwrap_err();
        assert!(matches!(err, Error::SizeMismatch { image: "normal", .. }), "{err}");
        let only_normal = Input { normal: Some(&color), ..Input::new(4, 4, &color) };
        assert!(matches!(only_normal.validate(), Err(Error::NormalWithoutAlbedo)));
        let mut nan = color.clone();
        nan[5][1] = f32::NAN;
        let err = Input::new(4, 4, &nan).validate().unwrap_err();
        assert!(matches!(err, Error::NonFinite { image: "color", x: 1, y: 1, .. }), "{err}");
        assert_eq!(Input::new(4, 4, &color).with_guides(&color, &color).validate().unwrap(), 16);
    }

    #[test]
    fn a_folder_without_the_library_is_a_typed_error_naming_the_install_command() {
        let dir = std::env::temp_dir().join("raykit-denoise-no-library");
        std::fs::create_dir_all(&dir).unwrap();
        let err = Denoiser::from_dir(&dir, DenoiseDevice::Cpu).unwrap_err();
        assert!(matches!(err, Error::LibraryMissing { .. }), "{err}");
        let text = err.to_string();
        assert!(text.contains(INSTALL_COMMAND) && text.contains(LIBRARY_DIR_VAR), "{text}");
    }
}
