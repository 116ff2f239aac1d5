//! Errors of the device and the backend: the loader, device selection, Vulkan calls and memory, a lost
//! device, the compile cache, and what the CPU backend refuses.

use ash::vk;

/// Why a physical device cannot run raykit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceReport {
    /// The device's name as the driver reports it.
    pub name: String,
    /// Device type (discrete GPU, CPU, …).
    pub device_type: String,
    /// The Vulkan version it supports, `major.minor.patch`.
    pub api_version: String,
    /// Extensions and features it lacks; empty when the device is usable.
    pub missing: Vec<String>,
}

impl std::fmt::Display for DeviceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, Vulkan {})", self.name, self.device_type, self.api_version)?;
        if self.missing.is_empty() {
            write!(f, ": usable")
        } else {
            write!(f, ": lacks {}", self.missing.join(", "))
        }
    }
}

fn list_devices(devices: &[DeviceReport]) -> String {
    if devices.is_empty() {
        return "no Vulkan devices at all".to_owned();
    }
    devices.iter().map(|d| format!("\n  - {d}")).collect()
}

/// Why raykit needs `VK_EXT_robustness2`, and the fix, when a device lacks it.
fn robustness_hint(devices: &[DeviceReport]) -> &'static str {
    let lacks = devices
        .iter()
        .flat_map(|d| &d.missing)
        .any(|m| m.contains("VK_EXT_robustness2") || m.contains("robustBufferAccess2") || m.contains("nullDescriptor"));
    if lacks {
        "\nVK_EXT_robustness2 with robustBufferAccess2 and nullDescriptor is required: device programs index buffers \
         without bounds checks, and rely on it for a read through a null, dropped or never-written handle, or past a \
         buffer's end, to give zero (and such a write to be discarded). Update the GPU driver to one that has it \
         (NVIDIA's, Mesa ≥ 25)."
    } else {
        ""
    }
}

/// Errors of the device and the backend.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DeviceError {
    /// Something that only the Vulkan backend has was asked of a context of the
    /// CPU backend (see [`crate::cpu`]).
    #[error("{what} is not available on the CPU backend: {why}; {fix}")]
    NotOnCpuBackend {
        /// What was asked.
        what: &'static str,
        /// Why the CPU backend has no such thing.
        why: &'static str,
        /// What to do instead.
        fix: &'static str,
    },

    /// The CPU backend's thread pool could not be made.
    ///
    /// A fault, not a refusal: the system could not start threads.
    #[error("cannot start the CPU backend's threads: {reason}")]
    CpuThreads {
        /// What the system said.
        reason: String,
    },

    /// The Vulkan loader (`libvulkan.so.1`) could not be loaded.
    ///
    /// A fault, not a refusal: the machine lacks the loader, whatever the input.
    #[error("cannot load the Vulkan loader: {0}. Install it (Debian: `apt-get install libvulkan1`) or run `cargo xtask test`, which installs what is missing")]
    LoaderMissing(String),

    /// No physical device supports Vulkan ray-tracing pipelines.
    #[error("no Vulkan device with ray-tracing pipelines and the features raykit needs; devices seen:{}{}\nOn a machine without a GPU, install Mesa ≥ 25 lavapipe (Debian bookworm: `mesa-vulkan-drivers` from bookworm-backports) — `cargo xtask test` does this when run as root; or run the programs on the CPU backend (`ContextOptions::backend`, `RAYKIT_BACKEND=cpu`)", list_devices(.devices), robustness_hint(.devices))]
    NoRayTracingDevice {
        /// Each device seen, with what it lacks.
        devices: Vec<DeviceReport>,
    },

    /// A Vulkan call failed.
    ///
    /// A fault, not a refusal: the driver failed a call raykit made with checked arguments.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan {
        /// The function that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },

    /// Device memory could not be allocated.
    ///
    /// A fault, not a refusal: the device is out of memory.
    #[error("allocating {what}: {source}; drop buffers and acceleration structures that are no longer needed, or make smaller ones")]
    Allocation {
        /// What the memory was for.
        what: &'static str,
        /// The allocator's error.
        #[source]
        source: gpu_allocator::AllocationError,
    },

    /// Validation was asked for but the Khronos validation layer is not installed.
    ///
    /// A fault, not a refusal: the machine lacks the layer.
    #[error("validation requested but VK_LAYER_KHRONOS_validation is not installed (Debian: `apt-get install vulkan-validationlayers`)")]
    ValidationLayerMissing,

    /// Objects of different contexts were combined: a pipeline's program groups,
    /// or the GASes an IAS instances.
    #[error("objects of different Contexts were combined (the program groups of one pipeline, or the GASes of an IAS); make them all with the same Context")]
    ContextMismatch,

    /// Reading or writing the compile cache file failed.
    ///
    /// A fault, not a refusal: the file system failed to read or write the cache.
    #[error("pipeline cache file {path}: {source}; set ContextOptions::pipeline_cache (or RAYKIT_PIPELINE_CACHE) to a writable directory, or turn the cache off")]
    PipelineCacheIo {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The GPU stopped responding.
    ///
    /// A fault, not a refusal: the GPU stopped, whatever the input.
    #[error(
        "the device was lost during {during}; every Context on it refuses new work from now on — drop them and \
         create a new Context (it gets a new device)"
    )]
    DeviceLost {
        /// What was running.
        during: &'static str,
    },

    /// [`crate::ContextOptions::device_index`] is past the usable devices.
    #[error("device index {index} is out of range: {} usable ray-tracing device(s): {}; use an index below {}", .usable.len(), .usable.join(", "), .usable.len())]
    DeviceIndexOutOfRange {
        /// The index asked for.
        index: usize,
        /// The names of the usable devices, in the order indices count.
        usable: Vec<String>,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_without_robustness2_is_reported_with_the_reason_and_the_fix() {
        let report = |missing: &[&str]| DeviceReport {
            name: "Some GPU".to_owned(),
            device_type: "DISCRETE_GPU".to_owned(),
            api_version: "1.3.0".to_owned(),
            missing: missing.iter().map(|m| m.to_string()).collect(),
        };
        let text =
            DeviceError::NoRayTracingDevice { devices: vec![report(&["extension VK_EXT_robustness2"])] }.to_string();
        assert!(text.contains("Some GPU (DISCRETE_GPU, Vulkan 1.3.0): lacks extension VK_EXT_robustness2"), "{text}");
        assert!(text.contains("without bounds checks") && text.contains("Update the GPU driver"), "{text}");
        let text =
            DeviceError::NoRayTracingDevice { devices: vec![report(&["extension VK_KHR_ray_tracing_pipeline"])] }
                .to_string();
        assert!(!text.contains("robustness2"), "{text}");
    }
}
