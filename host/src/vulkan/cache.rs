//! The Vulkan side of the compile cache (see [`crate::cache`]): a
//! [`VkPipelineCache`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkPipelineCache.html)
//! per context, loaded from and saved to its file, which starts with raykit's own
//! header so that the driver is never handed data raykit has not checked.

use std::path::{Path, PathBuf};

use ash::vk;

use crate::cache::{CacheLoad, PipelineCacheInfo, PipelineCacheLocation};
use crate::error::DeviceError;
use crate::error::{Error, Result};

const MAGIC: &[u8; 8] = b"RAYKITPC";
const FORMAT_VERSION: u32 = 1;
/// raykit's header: magic, format, vendor, device, driver, UUID, length, checksum.
const HEADER_BYTES: usize = 8 + 4 + 4 + 4 + 4 + 16 + 8 + 8;
/// `sizeof(VkPipelineCacheHeaderVersionOne)`.
const VK_HEADER_BYTES: usize = 32;

/// What a cache file must match.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct CacheKey {
    vendor_id: u32,
    device_id: u32,
    driver_version: u32,
    uuid: [u8; vk::UUID_SIZE],
}

impl CacheKey {
    pub(crate) fn of(props: &vk::PhysicalDeviceProperties) -> CacheKey {
        CacheKey {
            vendor_id: props.vendor_id,
            device_id: props.device_id,
            driver_version: props.driver_version,
            uuid: props.pipeline_cache_uuid,
        }
    }

    fn file_name(&self) -> String {
        let uuid: String = self.uuid.iter().map(|b| format!("{b:02x}")).collect();
        format!("{:04x}-{:04x}-{uuid}.raykit-cache", self.vendor_id, self.device_id)
    }
}

/// FNV-1a, 64 bits: catches truncation and corruption (not an adversary).
fn checksum(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    bytes.get(at..at + 4).and_then(|b| b.try_into().ok()).map_or(0, u32::from_le_bytes)
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    bytes.get(at..at + 8).and_then(|b| b.try_into().ok()).map_or(0, u64::from_le_bytes)
}

/// raykit's file: header, then the driver's data.
pub(crate) fn encode(key: &CacheKey, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + data.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&key.vendor_id.to_le_bytes());
    out.extend_from_slice(&key.device_id.to_le_bytes());
    out.extend_from_slice(&key.driver_version.to_le_bytes());
    out.extend_from_slice(&key.uuid);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// Checks a cache file against `key`; returns the driver's data inside it.
pub(crate) fn decode<'a>(key: &CacheKey, file: &'a [u8]) -> std::result::Result<&'a [u8], String> {
    if file.len() < HEADER_BYTES || &file[..8] != MAGIC {
        return Err(format!("not a raykit cache file ({} bytes, no raykit header)", file.len()));
    }
    let format = u32_at(file, 8);
    if format != FORMAT_VERSION {
        return Err(format!("cache format {format}, this raykit writes {FORMAT_VERSION}"));
    }
    let (vendor, device, driver) = (u32_at(file, 12), u32_at(file, 16), u32_at(file, 20));
    if (vendor, device) != (key.vendor_id, key.device_id) {
        return Err(format!(
            "made for device {vendor:04x}:{device:04x}, this is {:04x}:{:04x}",
            key.vendor_id, key.device_id
        ));
    }
    if driver != key.driver_version {
        return Err(format!("made by driver version {driver:#x}, this driver is {:#x}", key.driver_version));
    }
    if file[24..40] != key.uuid {
        return Err("made for another pipelineCacheUUID (another driver build)".to_owned());
    }
    let len = u64_at(file, 40);
    let data = &file[HEADER_BYTES..];
    if data.len() as u64 != len {
        return Err(format!("truncated or padded: the header says {len} bytes of data, the file has {}", data.len()));
    }
    if checksum(data) != u64_at(file, 48) {
        return Err("checksum mismatch: the file is corrupt".to_owned());
    }
    // Vulkan's own header, VkPipelineCacheHeaderVersionOne.
    if data.len() < VK_HEADER_BYTES {
        return Err(format!("{} bytes of data is shorter than Vulkan's 32-byte cache header", data.len()));
    }
    let (header_size, header_version) = (u32_at(data, 0), u32_at(data, 4));
    if (header_size as usize) < VK_HEADER_BYTES || header_size as usize > data.len() {
        return Err(format!("Vulkan cache header size {header_size} is invalid"));
    }
    if header_version != vk::PipelineCacheHeaderVersion::ONE.as_raw() as u32 {
        return Err(format!("Vulkan cache header version {header_version}, expected 1"));
    }
    if (u32_at(data, 8), u32_at(data, 12)) != (key.vendor_id, key.device_id) || data[16..32] != key.uuid {
        return Err("the Vulkan cache header names another device or pipelineCacheUUID".to_owned());
    }
    Ok(data)
}

/// A context's pipeline cache and its file.
pub(crate) struct DiskCache {
    pub(crate) handle: vk::PipelineCache,
    path: Option<PathBuf>,
    load: CacheLoad,
    key: CacheKey,
    /// Checksum of the data loaded (or last saved): saving skips unchanged data.
    saved_checksum: std::sync::Mutex<Option<u64>>,
}

impl DiskCache {
    /// Opens the cache for `key` under `location`. Never fails: a file that cannot
    /// be used is reported in [`CacheLoad`], and without a usable cache the handle
    /// is null (pipelines are then compiled without one).
    pub(crate) fn open(device: &ash::Device, key: CacheKey, location: &PipelineCacheLocation) -> DiskCache {
        let path = location.resolve().map(|dir| dir.join(key.file_name()));
        let mut load = CacheLoad::Off;
        let mut initial: Vec<u8> = Vec::new();
        let mut saved_checksum = None;
        if let Some(path) = &path {
            load = match not_a_regular_file(path) {
                // Reading a FIFO would block until a writer comes, forever.
                Some(reason) => CacheLoad::Rejected { reason },
                None => match std::fs::read(path) {
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => CacheLoad::Missing,
                    Err(e) => CacheLoad::Rejected { reason: format!("reading {}: {e}", path.display()) },
                    Ok(file) => match decode(&key, &file) {
                        Ok(data) => {
                            initial = data.to_vec();
                            saved_checksum = Some(checksum(data));
                            CacheLoad::Loaded { bytes: data.len() }
                        }
                        Err(reason) => CacheLoad::Rejected { reason },
                    },
                },
            };
        }
        let create = |data: &[u8]| {
            let info = vk::PipelineCacheCreateInfo::default().initial_data(data);
            // SAFETY: valid create info on a live device; the data was checked
            // against this device's cache header above.
            unsafe { device.create_pipeline_cache(&info, None) }
        };
        let handle = match create(&initial) {
            Ok(handle) => handle,
            Err(e) if !initial.is_empty() => {
                load = CacheLoad::Rejected { reason: format!("the driver refused the data: {e}") };
                saved_checksum = None;
                create(&[]).unwrap_or(vk::PipelineCache::null())
            }
            Err(_) => vk::PipelineCache::null(),
        };
        DiskCache { handle, path, load, key, saved_checksum: std::sync::Mutex::new(saved_checksum) }
    }

    /// The driver's current data.
    fn data(&self, device: &ash::Device) -> Result<Vec<u8>> {
        if self.handle == vk::PipelineCache::null() {
            return Ok(Vec::new());
        }
        // SAFETY: the cache is alive; vkGetPipelineCacheData needs no external
        // synchronisation of a cache made without EXTERNALLY_SYNCHRONIZED.
        unsafe { device.get_pipeline_cache_data(self.handle) }.map_err(Error::vk("vkGetPipelineCacheData"))
    }

    pub(crate) fn info(&self, device: &ash::Device) -> PipelineCacheInfo {
        PipelineCacheInfo {
            path: self.path.clone(),
            load: self.load.clone(),
            current_bytes: self.data(device).map_or(0, |d| d.len()),
        }
    }

    /// Writes the cache to its file if its data changed since it was loaded or saved.
    pub(crate) fn save(&self, device: &ash::Device) -> Result<Option<PathBuf>> {
        let Some(path) = &self.path else { return Ok(None) };
        if let Some(reason) = not_a_regular_file(path) {
            return Err(Error::Device(DeviceError::PipelineCacheIo {
                path: path.clone(),
                source: std::io::Error::other(reason),
            }));
        }
        let data = self.data(device)?;
        if data.is_empty() {
            return Ok(None);
        }
        let mut saved = self.saved_checksum.lock().unwrap_or_else(|p| p.into_inner());
        let sum = checksum(&data);
        if *saved == Some(sum) && path.exists() {
            return Ok(Some(path.clone()));
        }
        write_atomically(path, &encode(&self.key, &data))?;
        *saved = Some(sum);
        Ok(Some(path.clone()))
    }

    /// # Safety
    /// No pipeline creation may be using the cache.
    pub(crate) unsafe fn destroy(&self, device: &ash::Device) {
        if self.handle != vk::PipelineCache::null() {
            // SAFETY: per the contract above.
            unsafe { device.destroy_pipeline_cache(self.handle, None) };
        }
    }
}

/// Why `path` cannot be the cache file: it exists and is not a regular file (a
/// FIFO, a device, a directory). `None` when it is one, or does not exist.
fn not_a_regular_file(path: &Path) -> Option<String> {
    let meta = std::fs::metadata(path).ok()?;
    if meta.is_file() {
        return None;
    }
    Some(format!(
        "{} is not a regular file ({:?}); the pipeline cache (ContextOptions::pipeline_cache, or RAYKIT_PIPELINE_CACHE) must name a directory whose cache file can be a regular file: remove it or choose another directory",
        path.display(),
        meta.file_type()
    ))
}

/// Writes `bytes` to a temporary file next to `path`, then renames it over `path`,
/// so a reader sees the old file or the new one, never a partial one.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Device(DeviceError::PipelineCacheIo { path: path.to_owned(), source });
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{file_name}.{}.{nanos}.tmp", std::process::id()));
    let written = (|| {
        use std::io::Write;
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> CacheKey {
        CacheKey { vendor_id: 0x10005, device_id: 7, driver_version: 0x1234, uuid: [9; 16] }
    }

    fn vk_data(key: &CacheKey) -> Vec<u8> {
        let mut d = Vec::new();
        d.extend_from_slice(&32u32.to_le_bytes());
        d.extend_from_slice(&1u32.to_le_bytes());
        d.extend_from_slice(&key.vendor_id.to_le_bytes());
        d.extend_from_slice(&key.device_id.to_le_bytes());
        d.extend_from_slice(&key.uuid);
        d.extend_from_slice(b"driver payload");
        d
    }

    #[test]
    fn a_file_round_trips() {
        let data = vk_data(&key());
        assert_eq!(decode(&key(), &encode(&key(), &data)), Ok(&data[..]));
    }

    #[test]
    fn another_driver_device_or_a_damaged_file_is_refused() {
        let data = vk_data(&key());
        let file = encode(&key(), &data);
        let newer = CacheKey { driver_version: 0x1235, ..key() };
        assert!(decode(&newer, &file).unwrap_err().contains("driver version"));
        let other = CacheKey { device_id: 8, ..key() };
        assert!(decode(&other, &file).unwrap_err().contains("device"));
        let other_uuid = CacheKey { uuid: [1; 16], ..key() };
        assert!(decode(&other_uuid, &file).is_err());
        assert!(decode(&key(), &file[..file.len() - 1]).unwrap_err().contains("truncated"));
        let mut flipped = file.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        assert!(decode(&key(), &flipped).unwrap_err().contains("checksum"));
        assert!(decode(&key(), b"garbage").is_err());
        // A raykit header around data whose Vulkan header names another device.
        let foreign = vk_data(&other);
        assert!(decode(&key(), &encode(&key(), &foreign)).unwrap_err().contains("Vulkan cache header"));
    }
}
