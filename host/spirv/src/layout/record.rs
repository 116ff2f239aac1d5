//! Reflection of the SBT record data each entry point reads: its
//! `ShaderRecordBufferKHR` block, which the host checks against the record the
//! SBT gives the program's group.

use std::collections::{HashMap, HashSet};

use rspirv::dr::Operand;
use rspirv::spirv::{Op, StorageClass};

use super::index::{id_operand, Index};
use super::{bad, Result};

/// The bytes of record data each entry point reads, by entry-point name: the
/// size of the `ShaderRecordBufferKHR` block it uses (up to the end of its last
/// member; a runtime array at the end counts for nothing), the largest when it
/// uses several. An entry point uses a block when its interface lists it
/// (SPIR-V 1.4 and later) or a function it reaches refers to it. Entry points
/// that read no record are absent.
pub fn reflect_record_sizes(module: &rspirv::dr::Module) -> Result<HashMap<String, u32>> {
    let index = Index::new(module);
    let mut records: HashMap<u32, u32> = HashMap::new();
    for inst in module.types_global_values.iter().filter(|i| i.class.opcode == Op::Variable) {
        let (Some(var), Some(Operand::StorageClass(StorageClass::ShaderRecordBufferKHR))) =
            (inst.result_id, inst.operands.first())
        else {
            continue;
        };
        let pointer = index.def(inst.result_type.ok_or_else(|| bad("OpVariable without type"))?)?;
        let pointee = id_operand(pointer, 1).ok_or_else(|| bad("shader record variable is not a pointer"))?;
        let (_, size) = index.describe(pointee, 0)?;
        records.insert(var, size);
    }
    if records.is_empty() {
        return Ok(HashMap::new());
    }
    // Per function: the record variables it names, and the functions it calls.
    let mut own: HashMap<u32, (Vec<u32>, Vec<u32>)> = HashMap::new();
    for function in &module.functions {
        let Some(id) = function.def_id() else { continue };
        let entry = own.entry(id).or_default();
        for inst in function.all_inst_iter() {
            for operand in &inst.operands {
                let Operand::IdRef(used) = operand else { continue };
                if inst.class.opcode == Op::FunctionCall && Some(operand) == inst.operands.first() {
                    entry.1.push(*used);
                } else if records.contains_key(used) {
                    entry.0.push(*used);
                }
            }
        }
    }
    let mut sizes = HashMap::new();
    for entry in &module.entry_points {
        let (Some(Operand::IdRef(function)), Some(Operand::LiteralString(name))) =
            (entry.operands.get(1), entry.operands.get(2))
        else {
            continue;
        };
        let mut used: Vec<u32> = entry
            .operands
            .iter()
            .skip(3)
            .filter_map(|op| match op {
                Operand::IdRef(var) if records.contains_key(var) => Some(*var),
                _ => None,
            })
            .collect();
        let mut seen = HashSet::new();
        let mut todo = vec![*function];
        while let Some(f) = todo.pop() {
            if !seen.insert(f) {
                continue;
            }
            if let Some((vars, callees)) = own.get(&f) {
                used.extend_from_slice(vars);
                todo.extend_from_slice(callees);
            }
        }
        if let Some(size) = used.iter().filter_map(|var| records.get(var)).copied().max() {
            sizes.insert(name.clone(), size);
        }
    }
    Ok(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::parse;
    use rspirv::binary::Assemble;
    use rspirv::spirv::{AddressingModel, Capability, Decoration, ExecutionModel, FunctionControl, MemoryModel};

    /// A module with a miss entry `uses` and one `ignores`, and a record block of
    /// `floats` f32 members followed by a runtime array; `listed` puts the block in
    /// the interface of `uses` (SPIR-V 1.4), otherwise `uses` only loads from it.
    fn module(floats: u32, listed: bool) -> Vec<u32> {
        let mut b = rspirv::dr::Builder::new();
        b.capability(Capability::Shader);
        b.capability(Capability::RayTracingKHR);
        b.memory_model(AddressingModel::Logical, MemoryModel::GLSL450);
        let f32_ty = b.type_float(32, None);
        let runtime = b.type_runtime_array(f32_ty);
        b.decorate(runtime, Decoration::ArrayStride, [Operand::LiteralBit32(4)]);
        let mut members = vec![f32_ty; floats as usize];
        members.push(runtime);
        let block = b.type_struct(members);
        b.decorate(block, Decoration::Block, []);
        for i in 0..=floats {
            b.member_decorate(block, i, Decoration::Offset, [Operand::LiteralBit32(4 * i)]);
        }
        let pointer = b.type_pointer(None, StorageClass::ShaderRecordBufferKHR, block);
        let var = b.variable(pointer, None, StorageClass::ShaderRecordBufferKHR, None);
        let member_pointer = b.type_pointer(None, StorageClass::ShaderRecordBufferKHR, f32_ty);
        let u32_ty = b.type_int(32, 0);
        let zero = b.constant_bit32(u32_ty, 0);
        let void = b.type_void();
        let fn_ty = b.type_function(void, []);
        let uses = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
        let _ = b.begin_block(None);
        let at = b.access_chain(member_pointer, None, var, [zero]).unwrap_or_default();
        let _ = b.load(f32_ty, None, at, None, []);
        let _ = b.ret();
        let _ = b.end_function();
        let ignores = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
        let _ = b.begin_block(None);
        let _ = b.ret();
        let _ = b.end_function();
        b.entry_point(ExecutionModel::MissKHR, uses, "uses", if listed { vec![var] } else { vec![] });
        b.entry_point(ExecutionModel::MissKHR, ignores, "ignores", []);
        b.module().assemble()
    }

    #[test]
    fn a_record_block_counts_up_to_its_last_sized_member_for_the_entry_that_uses_it() {
        for listed in [true, false] {
            let module = parse(&module(3, listed)).unwrap_or_else(|e| panic!("{e}"));
            let sizes = reflect_record_sizes(&module).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(sizes.get("uses"), Some(&12), "listed in the interface: {listed}");
            assert_eq!(sizes.get("ignores"), None);
        }
        let module = parse(&module(1003, true)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(reflect_record_sizes(&module).ok().and_then(|s| s.get("uses").copied()), Some(4012));
    }
}
