//! Where the programs of a module trace rays: the `OpTraceRayKHR` instructions each
//! entry point reaches through its call graph, with the SBT operands that are
//! constants. The host uses them to check that an SBT has the miss and hit records a
//! trace can select, and that a pipeline's `max_trace_depth` covers its programs.

use std::collections::{HashMap, HashSet};

use rspirv::dr::{Module, Operand};
use rspirv::spirv::Op;

/// One `OpTraceRayKHR` an entry point can reach. Operands that are not
/// constants in the module (computed at run time) are `None`.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct TraceCall {
    /// The SBT record offset (`sbtRecordOffset`, Vulkan uses its low 4 bits).
    pub sbt_offset: Option<u32>,
    /// The SBT record stride (`sbtRecordStride`, low 4 bits).
    pub sbt_stride: Option<u32>,
    /// The miss index (`missIndex`, low 16 bits).
    pub miss_index: Option<u32>,
}

/// What one entry point traces.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EntryTraces {
    /// The traces its function and every function it calls contain.
    pub calls: Vec<TraceCall>,
    /// Whether it calls callables (`OpExecuteCallableKHR`), whose traces count
    /// towards its depth.
    pub executes_callables: bool,
    /// The SBT index of each `OpExecuteCallableKHR` it reaches: the constant, or
    /// `None` when it is computed at run time.
    pub callables: Vec<Option<u32>>,
}

impl EntryTraces {
    /// Whether it traces at all.
    pub fn traces(&self) -> bool {
        !self.calls.is_empty()
    }
}

/// What one function contains: its traces, the functions it calls, and the SBT
/// indices of its callable calls.
type FunctionCalls = (Vec<TraceCall>, Vec<u32>, Vec<Option<u32>>);

/// The traces of every entry point of `module`, by entry-point name.
pub fn reflect_traces(module: &Module) -> HashMap<String, EntryTraces> {
    let constants: HashMap<u32, u32> = module
        .types_global_values
        .iter()
        .filter(|i| i.class.opcode == Op::Constant)
        .filter_map(|i| match (i.result_id, i.operands.first()) {
            (Some(id), Some(Operand::LiteralBit32(v))) => Some((id, *v)),
            _ => None,
        })
        .collect();
    let id_at = |ops: &[Operand], i: usize| match ops.get(i) {
        Some(Operand::IdRef(id)) => Some(*id),
        _ => None,
    };
    // Per function: its direct traces, callees and callable use.
    let mut own: HashMap<u32, FunctionCalls> = HashMap::new();
    for function in &module.functions {
        let Some(id) = function.def_id() else { continue };
        let entry = own.entry(id).or_default();
        for inst in function.all_inst_iter() {
            match inst.class.opcode {
                Op::TraceRayKHR => {
                    let constant = |i| id_at(&inst.operands, i).and_then(|id| constants.get(&id).copied());
                    entry.0.push(TraceCall {
                        sbt_offset: constant(3),
                        sbt_stride: constant(4),
                        miss_index: constant(5),
                    });
                }
                Op::FunctionCall => entry.1.extend(id_at(&inst.operands, 0)),
                Op::ExecuteCallableKHR | Op::ExecuteCallableNV => {
                    entry.2.push(id_at(&inst.operands, 0).and_then(|id| constants.get(&id).copied()));
                }
                _ => {}
            }
        }
    }
    let mut out = HashMap::new();
    for entry in &module.entry_points {
        let (Some(Operand::IdRef(function)), Some(Operand::LiteralString(name))) =
            (entry.operands.get(1), entry.operands.get(2))
        else {
            continue;
        };
        let mut traces = EntryTraces::default();
        let mut seen = HashSet::new();
        let mut todo = vec![*function];
        while let Some(f) = todo.pop() {
            if !seen.insert(f) {
                continue;
            }
            if let Some((calls, callees, callables)) = own.get(&f) {
                traces.calls.extend_from_slice(calls);
                traces.executes_callables |= !callables.is_empty();
                traces.callables.extend_from_slice(callables);
                todo.extend_from_slice(callees);
            }
        }
        out.insert(name.clone(), traces);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::parse;
    use rspirv::binary::Assemble;
    use rspirv::spirv::{AddressingModel, Capability, ExecutionModel, FunctionControl, MemoryModel, StorageClass};

    #[test]
    fn callable_indices_are_read_as_constants_or_as_computed() {
        let mut b = rspirv::dr::Builder::new();
        b.capability(Capability::Shader);
        b.capability(Capability::RayTracingKHR);
        b.memory_model(AddressingModel::Logical, MemoryModel::GLSL450);
        let u32_ty = b.type_int(32, 0);
        let three = b.constant_bit32(u32_ty, 3);
        let data_ptr = b.type_pointer(None, StorageClass::CallableDataKHR, u32_ty);
        let data = b.variable(data_ptr, None, StorageClass::CallableDataKHR, None);
        let void = b.type_void();
        let fn_ty = b.type_function(void, []);
        // A helper that calls callable 3, and the entry point, which calls it and
        // then calls the callable whose index its data holds.
        let helper = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
        let _ = b.begin_block(None);
        let _ = b.execute_callable_khr(three, data);
        let _ = b.ret();
        let _ = b.end_function();
        let main = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
        let _ = b.begin_block(None);
        let _ = b.function_call(void, None, helper, []);
        let computed = b.load(u32_ty, None, data, None, []).unwrap_or_default();
        let _ = b.execute_callable_khr(computed, data);
        let _ = b.ret();
        let _ = b.end_function();
        b.entry_point(ExecutionModel::RayGenerationKHR, main, "main", [data]);
        let module = parse(&b.module().assemble()).unwrap_or_else(|e| panic!("{e}"));
        let traces = reflect_traces(&module);
        let main = traces.get("main").cloned().unwrap_or_default();
        assert!(main.executes_callables);
        let mut callables = main.callables.clone();
        callables.sort();
        assert_eq!(callables, [None, Some(3)]);
    }
}
