//! The handful of Open Image Denoise C functions the denoiser calls, resolved
//! from `libOpenImageDenoise.so.2` at run time (OIDN's `oidn.h`, version 2).

use std::ffi::{c_char, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::Error;

/// `OIDNDevice`.
pub(crate) type Device = *mut c_void;
/// `OIDNFilter`.
pub(crate) type Filter = *mut c_void;
/// `OIDNBuffer`.
pub(crate) type Buffer = *mut c_void;

/// `OIDN_DEVICE_TYPE_CPU`.
pub(crate) const DEVICE_TYPE_CPU: c_int = 1;
/// `OIDN_DEVICE_TYPE_CUDA`.
pub(crate) const DEVICE_TYPE_CUDA: c_int = 3;
/// `OIDN_FORMAT_FLOAT3`.
pub(crate) const FORMAT_FLOAT3: c_int = 3;

/// The library's entry points. The library stays loaded for the rest of the
/// process: OIDN's thread pool (TBB) must not be unloaded under its threads.
pub(crate) struct Api {
    pub path: PathBuf,
    pub new_device: unsafe extern "C" fn(c_int) -> Device,
    pub commit_device: unsafe extern "C" fn(Device),
    pub release_device: unsafe extern "C" fn(Device),
    pub get_device_int: unsafe extern "C" fn(Device, *const c_char) -> c_int,
    pub get_device_error: unsafe extern "C" fn(Device, *mut *const c_char) -> c_int,
    pub new_buffer: unsafe extern "C" fn(Device, usize) -> Buffer,
    pub write_buffer: unsafe extern "C" fn(Buffer, usize, usize, *const c_void),
    pub read_buffer: unsafe extern "C" fn(Buffer, usize, usize, *mut c_void),
    pub release_buffer: unsafe extern "C" fn(Buffer),
    pub new_filter: unsafe extern "C" fn(Device, *const c_char) -> Filter,
    pub set_filter_image: unsafe extern "C" fn(Filter, *const c_char, Buffer, c_int, usize, usize, usize, usize, usize),
    pub set_filter_bool: unsafe extern "C" fn(Filter, *const c_char, bool),
    pub commit_filter: unsafe extern "C" fn(Filter),
    pub execute_filter: unsafe extern "C" fn(Filter),
    pub release_filter: unsafe extern "C" fn(Filter),
}

/// The libraries loaded so far, by path (each loaded once, never unloaded).
static LOADED: Mutex<Vec<&'static Api>> = Mutex::new(Vec::new());

/// Loads `path` (a `libOpenImageDenoise.so.2`) once per process.
pub(crate) fn load(path: &Path) -> Result<&'static Api, String> {
    let mut loaded = LOADED.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(api) = loaded.iter().find(|api| api.path == path) {
        return Ok(api);
    }
    // SAFETY: OIDN's initialisers only set up its own state; the library is
    // leaked below, so no symbol outlives it.
    let library = unsafe { libloading::Library::new(path) }.map_err(|e| e.to_string())?;
    let library: &'static libloading::Library = Box::leak(Box::new(library));
    macro_rules! symbol {
        ($name:literal) => {
            // SAFETY: the type is the one `oidn.h` declares for this symbol.
            *unsafe { library.get(concat!($name, "\0").as_bytes()) }
                .map_err(|e| format!("{} lacks `{}` (not Open Image Denoise 2?): {e}", path.display(), $name))?
        };
    }
    let api = Api {
        path: path.to_path_buf(),
        new_device: symbol!("oidnNewDevice"),
        commit_device: symbol!("oidnCommitDevice"),
        release_device: symbol!("oidnReleaseDevice"),
        get_device_int: symbol!("oidnGetDeviceInt"),
        get_device_error: symbol!("oidnGetDeviceError"),
        new_buffer: symbol!("oidnNewBuffer"),
        write_buffer: symbol!("oidnWriteBuffer"),
        read_buffer: symbol!("oidnReadBuffer"),
        release_buffer: symbol!("oidnReleaseBuffer"),
        new_filter: symbol!("oidnNewFilter"),
        set_filter_image: symbol!("oidnSetFilterImage"),
        set_filter_bool: symbol!("oidnSetFilterBool"),
        commit_filter: symbol!("oidnCommitFilter"),
        execute_filter: symbol!("oidnExecuteFilter"),
        release_filter: symbol!("oidnReleaseFilter"),
    };
    let api: &'static Api = Box::leak(Box::new(api));
    loaded.push(api);
    Ok(api)
}

impl Api {
    /// The device's pending error (clearing it), `None` when there is none.
    /// `device` may be null: then the error of the last failed device creation.
    pub(crate) fn take_error(&self, device: Device) -> Option<(i32, String)> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: `device` is null or a live device; `message` is an out pointer.
        let code = unsafe { (self.get_device_error)(device, &mut message) };
        if code == 0 {
            return None;
        }
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: OIDN hands a NUL-terminated string valid until its next call on the device.
            unsafe { std::ffi::CStr::from_ptr(message) }.to_string_lossy().into_owned()
        };
        Some((code, text))
    }

    /// `Err` naming `operation` when the device has an error pending.
    pub(crate) fn check(&self, device: Device, operation: &'static str) -> Result<(), Error> {
        match self.take_error(device) {
            None => Ok(()),
            Some((code, message)) => Err(Error::Device { operation, code: error_name(code), message }),
        }
    }
}

/// The name of an `OIDNError` code.
pub(crate) fn error_name(code: i32) -> &'static str {
    match code {
        1 => "OIDN_ERROR_UNKNOWN",
        2 => "OIDN_ERROR_INVALID_ARGUMENT",
        3 => "OIDN_ERROR_INVALID_OPERATION",
        4 => "OIDN_ERROR_OUT_OF_MEMORY",
        5 => "OIDN_ERROR_UNSUPPORTED_HARDWARE",
        6 => "OIDN_ERROR_CANCELLED",
        _ => "an OIDN error",
    }
}
