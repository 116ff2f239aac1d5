//! Modules on Vulkan: the `VkShaderModule` of a checked SPIR-V module (see
//! [`crate::module`]), with what pipelines need of it.

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::types::group::{Group, GroupPrograms, Program, SpirvCode};
use crate::types::program::EntryPointInfo;
use crate::vulkan::context::ContextInner;

/// A SPIR-V module on a Vulkan device: its shader module, entry points and words.
pub(crate) struct ModuleInner {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) shader: vk::ShaderModule,
    pub(crate) entry_points: Vec<EntryPointInfo>,
    /// Its SPIR-V, validated again with each pipeline's specialization constants.
    pub(crate) words: Vec<u32>,
    /// Messages reported while it was created.
    pub(crate) log: Vec<crate::log::ValidationMessage>,
    /// Whether it declares the user-exception buffer's specialization constant: only
    /// then can its programs throw (rust-gpu leaves the constant out of modules
    /// that never call `throw_exception`), and only then do launches collect
    /// exceptions for it.
    pub(crate) records_exceptions: bool,
}

/// A program group of SPIR-V programs, as pipelines link it.
pub(crate) type SpirvGroup = Group<Arc<ModuleInner>>;
/// The programs of a [`SpirvGroup`].
pub(crate) type SpirvGroupPrograms = GroupPrograms<Arc<ModuleInner>>;
/// A program of a [`SpirvGroup`].
pub(crate) type SpirvProgram = Program<Arc<ModuleInner>>;

impl SpirvCode for Arc<ModuleInner> {
    fn entry_points(&self) -> &[EntryPointInfo] {
        &self.entry_points
    }

    fn words(&self) -> &[u32] {
        &self.words
    }

    fn identity(&self) -> *const () {
        Arc::as_ptr(self).cast()
    }
}

/// Creates the shader module of `words` (a parsed, validated SPIR-V module),
/// named after `name`, capturing what the validation layer reports meanwhile.
pub(crate) fn create(
    vulkan: &Arc<ContextInner>,
    entry_points: Vec<EntryPointInfo>,
    words: Vec<u32>,
    records_exceptions: bool,
    name: &str,
) -> Result<ModuleInner> {
    let info = vk::ShaderModuleCreateInfo::default().code(&words);
    let (shader, log) = crate::log::capture(|| {
        // SAFETY: `words` is a parsed SPIR-V module; the device is live.
        unsafe { vulkan.device.create_shader_module(&info, None) }
    });
    let shader = shader.map_err(Error::vk("vkCreateShaderModule"))?;
    vulkan.set_name(shader, &format!("raykit module {name}"));
    Ok(ModuleInner { ctx: vulkan.clone(), shader, entry_points, words, log, records_exceptions })
}

impl Drop for ModuleInner {
    fn drop(&mut self) {
        // SAFETY: pipelines made from this module hold an `Arc` to it; none is alive.
        unsafe { self.ctx.device.destroy_shader_module(self.shader, None) };
    }
}

#[cfg(test)]
mod tests {
    use ash::vk;
    use rspirv::spirv::ExecutionModel;

    use crate::types::program::kind_of;

    /// raykit-abi types its numbers in (it has no dependencies): they must be
    /// rspirv's execution models and ash's shader stages.
    #[test]
    fn the_abi_numbers_are_spirv_and_vulkan_ones() {
        use raykit_abi::ExecutionModel as Abi;
        for (abi, spirv, stage) in [
            (Abi::RayGeneration, ExecutionModel::RayGenerationKHR, vk::ShaderStageFlags::RAYGEN_KHR),
            (Abi::Intersection, ExecutionModel::IntersectionKHR, vk::ShaderStageFlags::INTERSECTION_KHR),
            (Abi::AnyHit, ExecutionModel::AnyHitKHR, vk::ShaderStageFlags::ANY_HIT_KHR),
            (Abi::ClosestHit, ExecutionModel::ClosestHitKHR, vk::ShaderStageFlags::CLOSEST_HIT_KHR),
            (Abi::Miss, ExecutionModel::MissKHR, vk::ShaderStageFlags::MISS_KHR),
            (Abi::Callable, ExecutionModel::CallableKHR, vk::ShaderStageFlags::CALLABLE_KHR),
        ] {
            assert_eq!(abi.to_u32(), spirv as u32, "{abi:?}");
            assert_eq!(vk::ShaderStageFlags::from_raw(abi.vulkan_stage()), stage, "{abi:?}");
            assert_eq!(kind_of(spirv), Some(abi.kind()));
        }
        assert_eq!(kind_of(ExecutionModel::GLCompute), None);
    }
}
