//! Modules: SPIR-V loaded onto the device and reflected, like OptiX's
//! `OptixModule` made from PTX.
//!
//! A [`Module`] is made from SPIR-V bytes or a `.spv` file (what
//! `cargo xtask build-shaders` writes). raykit reads the module with rspirv (naga's
//! SPIR-V reader rejects the ray-tracing stages) and lists its entry points with
//! their stages, so program groups can be checked before Vulkan sees them. See
//! [`vkCreateShaderModule`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateShaderModule.html).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use ash::vk;
use raykit_device::ProgramKind;
use rspirv::spirv::ExecutionModel;

use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};

const SPIRV_MAGIC: u32 = 0x0723_0203;

/// One entry point of a module.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EntryPointInfo {
    /// Its name, e.g. `__raygen__rg` (or `main` for GLSL).
    pub name: String,
    /// The ray-tracing program kind of its execution model; `None` for other
    /// stages (vertex, compute, …).
    pub kind: Option<ProgramKind>,
    /// The SPIR-V execution model, as text (`RayGenerationKHR`, …).
    pub execution_model: String,
}

/// A SPIR-V module on the device, with its entry points.
#[derive(Clone)]
pub struct Module {
    pub(crate) inner: Arc<ModuleInner>,
}

pub(crate) struct ModuleInner {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) shader: vk::ShaderModule,
    pub(crate) entry_points: Vec<EntryPointInfo>,
}

fn kind_of(model: ExecutionModel) -> Option<ProgramKind> {
    match model {
        ExecutionModel::RayGenerationKHR => Some(ProgramKind::Raygen),
        ExecutionModel::MissKHR => Some(ProgramKind::Miss),
        ExecutionModel::ClosestHitKHR => Some(ProgramKind::ClosestHit),
        ExecutionModel::AnyHitKHR => Some(ProgramKind::AnyHit),
        ExecutionModel::IntersectionKHR => Some(ProgramKind::Intersection),
        ExecutionModel::CallableKHR => Some(ProgramKind::Callable),
        _ => None,
    }
}

/// Turns bytes into SPIR-V words, checking size and magic number.
pub(crate) fn words_of(bytes: &[u8]) -> Result<Vec<u32>> {
    if bytes.len() < 20 {
        return Err(Error::InvalidSpirv { reason: format!("{} bytes is shorter than a SPIR-V header (20 bytes)", bytes.len()) });
    }
    if bytes.len() % 4 != 0 {
        return Err(Error::InvalidSpirv { reason: format!("{} bytes is not a whole number of 32-bit words", bytes.len()) });
    }
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words[0] != SPIRV_MAGIC {
        return Err(Error::InvalidSpirv { reason: format!("magic number {:#010x}, expected {SPIRV_MAGIC:#010x}", words[0]) });
    }
    Ok(words)
}

/// Lists the entry points of a SPIR-V module.
pub fn reflect_entry_points(bytes: &[u8]) -> Result<Vec<EntryPointInfo>> {
    let words = words_of(bytes)?;
    let module = rspirv::dr::load_words(&words).map_err(|e| Error::InvalidSpirv { reason: e.to_string() })?;
    let mut entries = Vec::new();
    for inst in &module.entry_points {
        let (Some(rspirv::dr::Operand::ExecutionModel(model)), Some(rspirv::dr::Operand::LiteralString(name))) =
            (inst.operands.first(), inst.operands.get(2))
        else {
            return Err(Error::InvalidSpirv { reason: "malformed OpEntryPoint".to_owned() });
        };
        entries.push(EntryPointInfo { name: name.clone(), kind: kind_of(*model), execution_model: format!("{model:?}") });
    }
    Ok(entries)
}

impl Module {
    /// Loads a module from SPIR-V bytes.
    pub fn new(ctx: &Context, spirv: &[u8]) -> Result<Module> {
        let entry_points = reflect_entry_points(spirv)?;
        if !entry_points.iter().any(|e| e.kind.is_some()) {
            return Err(Error::NoRayTracingEntryPoints {
                available: entry_points.iter().map(|e| (e.name.clone(), e.kind)).collect(),
            });
        }
        let words = words_of(spirv)?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: `words` is a parsed SPIR-V module; the device is live.
        let shader = unsafe { ctx.inner.device.create_shader_module(&info, None) }
            .map_err(Error::vk("vkCreateShaderModule"))?;
        Ok(Module { inner: Arc::new(ModuleInner { ctx: ctx.inner.clone(), shader, entry_points }) })
    }

    /// Loads the SPIR-V that `cargo xtask build-shaders` built for the device crate
    /// `crate_name` (e.g. `"triangle-device"`), found by [`spirv_path`].
    pub fn from_device_crate(ctx: &Context, crate_name: &str) -> Result<Module> {
        Module::from_file(ctx, spirv_path(crate_name))
    }

    /// Loads a module from a `.spv` file.
    pub fn from_file(ctx: &Context, path: impl AsRef<Path>) -> Result<Module> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| Error::SpirvFile { path: path.to_owned(), source })?;
        Module::new(ctx, &bytes)
    }

    /// The module's entry points and their stages.
    pub fn entry_points(&self) -> &[EntryPointInfo] {
        &self.inner.entry_points
    }

    pub(crate) fn entry_list(&self) -> Vec<(String, Option<ProgramKind>)> {
        self.inner.entry_points.iter().map(|e| (e.name.clone(), e.kind)).collect()
    }
}

/// Where `cargo xtask build-shaders` puts the SPIR-V of device crate
/// `crate_name`: `$RAYKIT_SPIRV_DIR/<crate_name>.spv` when that variable is set,
/// else `spirv/<crate_name>.spv` in the nearest ancestor directory of the running
/// executable that has one (so `target/debug/app` finds `target/spirv/`), else
/// `target/spirv/<crate_name>.spv` under the current directory.
pub fn spirv_path(crate_name: &str) -> PathBuf {
    let file = format!("{}.spv", crate_name.replace('-', "_"));
    if let Some(dir) = std::env::var_os("RAYKIT_SPIRV_DIR") {
        return PathBuf::from(dir).join(file);
    }
    if let Ok(exe) = std::env::current_exe() {
        for dir in exe.ancestors().skip(1) {
            let candidate = dir.join("spirv").join(&file);
            if candidate.is_file() {
                return candidate;
            }
        }
    }
    PathBuf::from("target").join("spirv").join(file)
}

impl Drop for ModuleInner {
    fn drop(&mut self) {
        // SAFETY: pipelines made from this module hold an `Arc` to it; none is alive.
        unsafe { self.ctx.device.destroy_shader_module(self.shader, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bytes_that_are_not_spirv() {
        assert!(matches!(reflect_entry_points(b"hello"), Err(Error::InvalidSpirv { .. })));
        assert!(matches!(reflect_entry_points(&[0u8; 21]), Err(Error::InvalidSpirv { .. })));
        let err = reflect_entry_points(&[0u8; 24]).unwrap_err().to_string();
        assert!(err.contains("magic number"), "{err}");
    }
}
