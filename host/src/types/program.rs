//! What reflection and the params type say about programs: entry points of a
//! module, their program kinds, and how launch params are delivered.

use raykit_device::{LaunchParams, ProgramKind};
use raykit_spirv::{InterfaceSizes, ParamsBlock, ParamsDelivery};
use rspirv::spirv::ExecutionModel;

/// The program kind of a ray-tracing execution model; `None` for other stages.
pub(crate) fn kind_of(model: ExecutionModel) -> Option<ProgramKind> {
    raykit_abi::ExecutionModel::from_u32(model as u32).map(raykit_abi::ExecutionModel::kind)
}
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
    /// The launch-params blocks it declares (push constants, or the uniform
    /// buffer at set 1), with their layouts; empty when it takes no params.
    pub params: Vec<ParamsBlock>,
    /// The bytes of ray payload and hit attributes it declares, which a
    /// [`crate::PipelineLibrary`]'s interface must cover.
    pub interface: InterfaceSizes,
    /// The bytes of SBT record data it reads (its `ShaderRecordBufferKHR`
    /// block, up to the end of the last member); 0 when it reads none. Every
    /// SBT gives its group's records at least this much.
    pub record: u32,
    /// The rays it traces (through its call graph), with their constant SBT operands.
    pub traces: raykit_spirv::EntryTraces,
    /// The descriptor bindings it declares.
    pub bindings: Vec<raykit_spirv::DescriptorBinding>,
}
/// How raykit delivers params of type `P`.
pub fn params_delivery<P: LaunchParams>() -> ParamsDelivery {
    if raykit_device::uses_push_constants::<P>() {
        ParamsDelivery::PushConstants
    } else {
        ParamsDelivery::UniformBuffer { set: raykit_device::PARAMS_SET, binding: raykit_device::PARAMS_BINDING }
    }
}
