//! The compile cache: OptiX's disk cache of compiled programs as a
//! [`VkPipelineCache`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkPipelineCache.html)
//! saved on disk.
//!
//! Every pipeline (and pipeline library) a [`crate::Context`] creates goes through one
//! pipeline cache. The cache is loaded from disk when the context is created and
//! written back when it is destroyed (or on [`crate::Context::save_pipeline_cache`]),
//! atomically: to a temporary file in the same directory, then renamed over the old one.
//!
//! Where: [`PipelineCacheLocation`] in [`crate::ContextOptions`]. By default
//! `$RAYKIT_PIPELINE_CACHE` (`off` turns the disk cache off), else
//! `$XDG_CACHE_HOME/raykit/pipelines`, else `$HOME/.cache/raykit/pipelines`. One file
//! per device, named by vendor, device and `pipelineCacheUUID`.
//!
//! A file is used only if it is whole and made for this device and driver. raykit
//! does not hand the driver data it has not checked: the file starts with raykit's own
//! header (magic, format version, vendor and device IDs, driver version,
//! `pipelineCacheUUID`, length and checksum of the data), and the data must start with
//! Vulkan's [`VkPipelineCacheHeaderVersionOne`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkPipelineCacheHeaderVersionOne.html)
//! for the same device. Anything else (another GPU, a driver update, a truncated or
//! corrupted file) is refused — [`CacheLoad::Rejected`] says why — and the cache starts
//! empty; pipelines are created as without a cache, and the file is rewritten on save.

use std::path::PathBuf;

/// Where the on-disk compile cache lives.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum PipelineCacheLocation {
    /// `$RAYKIT_PIPELINE_CACHE` if set (the value `off` turns the cache off), else
    /// `$XDG_CACHE_HOME/raykit/pipelines`, else `$HOME/.cache/raykit/pipelines`.
    #[default]
    Default,
    /// No disk cache: every pipeline is compiled from scratch.
    Off,
    /// This directory (created if missing).
    Dir(PathBuf),
}

impl PipelineCacheLocation {
    /// The directory this location stands for now, or `None` when off.
    pub fn resolve(&self) -> Option<PathBuf> {
        match self {
            PipelineCacheLocation::Off => None,
            PipelineCacheLocation::Dir(dir) => Some(dir.clone()),
            PipelineCacheLocation::Default => {
                let non_empty = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
                if let Some(dir) = non_empty("RAYKIT_PIPELINE_CACHE") {
                    return (dir != "off" && dir != "0").then(|| PathBuf::from(dir));
                }
                if let Some(xdg) = non_empty("XDG_CACHE_HOME") {
                    return Some(PathBuf::from(xdg).join("raykit").join("pipelines"));
                }
                non_empty("HOME").map(|home| PathBuf::from(home).join(".cache").join("raykit").join("pipelines"))
            }
        }
    }
}

/// What happened to the cache file when the context was created.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheLoad {
    /// The disk cache is off.
    Off,
    /// No file yet: the cache starts empty (a cold cache).
    Missing,
    /// The file was checked and given to the driver (a warm cache).
    Loaded {
        /// Bytes of cache data loaded.
        bytes: usize,
    },
    /// The file was refused; the cache starts empty and the file is rewritten on save.
    Rejected {
        /// Why: another device or driver, a truncated or corrupt file, an I/O error.
        reason: String,
    },
}

/// The state of a context's compile cache ([`crate::Context::pipeline_cache_info`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PipelineCacheInfo {
    /// The cache file, when the disk cache is on.
    pub path: Option<PathBuf>,
    /// What happened to the file at context creation.
    pub load: CacheLoad,
    /// Bytes of cache data the driver holds now (`vkGetPipelineCacheData`).
    pub current_bytes: usize,
}

impl PipelineCacheInfo {
    /// A cache that is off.
    pub(crate) fn off() -> PipelineCacheInfo {
        PipelineCacheInfo { path: None, load: CacheLoad::Off, current_bytes: 0 }
    }
}
