//! SPIR-V modules raykit generates itself, built with rspirv's `dr::Builder`.

use rspirv::binary::Assemble;
use rspirv::spirv::{AddressingModel, Capability, ExecutionModel, FunctionControl, MemoryModel};

/// The entry-point name of [`empty_raygen`].
pub const EMPTY_RAYGEN_ENTRY: &str = "main";

/// An empty raygen shader (`void main() {}`) as SPIR-V 1.4 words: capability
/// `RayTracingKHR`, extension `SPV_KHR_ray_tracing`, one `RayGenerationKHR` entry
/// point named [`EMPTY_RAYGEN_ENTRY`] that returns at once. Valid for
/// `spirv-val --target-env vulkan1.2`.
pub fn empty_raygen() -> Vec<u32> {
    let mut b = rspirv::dr::Builder::new();
    b.set_version(1, 4);
    b.capability(Capability::RayTracingKHR);
    b.extension("SPV_KHR_ray_tracing");
    b.memory_model(AddressingModel::Logical, MemoryModel::GLSL450);
    let void = b.type_void();
    let fn_ty = b.type_function(void, []);
    // The builder only fails on misnested blocks and functions, which this straight-line code cannot produce.
    let main = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
    let _ = b.begin_block(None);
    let _ = b.ret();
    let _ = b.end_function();
    b.entry_point(ExecutionModel::RayGenerationKHR, main, EMPTY_RAYGEN_ENTRY, []);
    b.module().assemble()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_empty_raygen_reads_back_as_one_raygen_entry_point() {
        let module = crate::parse(&empty_raygen()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(module.header.as_ref().map(|h| h.version()), Some((1, 4)));
        assert_eq!(module.entry_points.len(), 1);
        let entry = &module.entry_points[0];
        assert_eq!(entry.operands[0], rspirv::dr::Operand::ExecutionModel(ExecutionModel::RayGenerationKHR));
        assert_eq!(entry.operands[2], rspirv::dr::Operand::LiteralString(EMPTY_RAYGEN_ENTRY.into()));
        assert_eq!(module.functions.len(), 1);
    }
}
