//! Reflection of launch-params blocks: each entry point's push-constant block or
//! uniform block at the params binding, described member by member.

use std::collections::HashMap;

use rspirv::dr::Operand;
use rspirv::spirv::{Decoration, Op, StorageClass};

use raykit_abi::{Scalar, ScalarKind, PARAMS_BINDING, PARAMS_SET};

use super::index::{id_operand, literal, Index, DESCRIBE_BUDGET};
use super::{bad, BlockMember, BlockType, ParamsBlock, ParamsDelivery, Result};

impl Index<'_> {
    /// The type and size of type `id`; `depth` bounds recursion on malformed input.
    pub(super) fn describe(&self, id: u32, depth: u32) -> Result<(BlockType, u32)> {
        if depth > 32 {
            return Err(bad("types nested more than 32 levels deep"));
        }
        match self.budget.get().checked_sub(1) {
            Some(left) => self.budget.set(left),
            None => {
                return Err(bad(format!(
                    "the params or record blocks have too many members (over {DESCRIBE_BUDGET} types described); launch params and records must be plain structs"
                )))
            }
        }
        let inst = self.def(id)?;
        let plain = |size: u32| Ok((BlockType::Plain(format!("{:?}", inst.class.opcode)), size));
        match inst.class.opcode {
            Op::TypeInt | Op::TypeFloat => {
                let bits = literal(inst, 0).ok_or_else(|| bad("OpTypeInt/Float without width"))?;
                let kind = match (inst.class.opcode, literal(inst, 1)) {
                    (Op::TypeFloat, _) => ScalarKind::Float,
                    (_, Some(0)) => ScalarKind::Unsigned,
                    _ => ScalarKind::Signed,
                };
                Ok((BlockType::Numeric { scalar: Scalar { kind, bits }, components: 1 }, bits / 8))
            }
            Op::TypeBool => plain(4),
            Op::TypeVector => {
                let component = id_operand(inst, 0).ok_or_else(|| bad("OpTypeVector without component"))?;
                let count = literal(inst, 1).ok_or_else(|| bad("OpTypeVector without count"))?;
                let (component, size) = self.describe(component, depth + 1)?;
                let ty = match component {
                    BlockType::Numeric { scalar, .. } => BlockType::Numeric { scalar, components: count },
                    _ => BlockType::Plain(format!("vector of {count}")),
                };
                Ok((ty, size.saturating_mul(count)))
            }
            Op::TypePointer => plain(8),
            Op::TypeMatrix => {
                let column = id_operand(inst, 0).ok_or_else(|| bad("OpTypeMatrix without column type"))?;
                let columns = literal(inst, 1).ok_or_else(|| bad("OpTypeMatrix without column count"))?;
                let (_, column_size) = self.describe(column, depth + 1)?;
                // The stride is a member decoration; the caller fills it in.
                Ok((BlockType::Matrix { columns, column_stride: column_size }, column_size.saturating_mul(columns)))
            }
            Op::TypeArray | Op::TypeRuntimeArray => {
                let element = id_operand(inst, 0).ok_or_else(|| bad("array without element type"))?;
                let len = match inst.class.opcode {
                    Op::TypeArray => {
                        self.constant(id_operand(inst, 1).ok_or_else(|| bad("OpTypeArray without length"))?)?
                    }
                    _ => 0,
                };
                let (element_ty, element_size) = self.describe(element, depth + 1)?;
                let stride = match self.decoration(id, Decoration::ArrayStride) {
                    Some(Some(stride)) => stride,
                    _ => element_size,
                };
                Ok((BlockType::Array { stride, len, element: Box::new(element_ty) }, stride.saturating_mul(len)))
            }
            Op::TypeStruct => {
                let members = self.struct_members(id, depth + 1)?;
                let size = members.iter().map(|m| m.offset.saturating_add(m.size)).max().unwrap_or(0);
                Ok((BlockType::Struct(members), size))
            }
            other => Ok((BlockType::Plain(format!("{other:?}")), 0)),
        }
    }

    /// The members of struct `id`, each with its `Offset` (and `MatrixStride`).
    pub(super) fn struct_members(&self, id: u32, depth: u32) -> Result<Vec<BlockMember>> {
        let inst = self.def(id)?;
        let mut members = Vec::with_capacity(inst.operands.len());
        for (i, _) in inst.operands.iter().enumerate() {
            let member_ty = id_operand(inst, i).ok_or_else(|| bad(format!("struct %{id} member {i} is not a type")))?;
            let i = i as u32;
            let offset = self.member_decoration(id, i, Decoration::Offset).ok_or_else(|| {
                bad(format!("struct %{id} member {i} has no Offset decoration (blocks need an explicit layout)"))
            })?;
            let (mut ty, mut size) = self.describe(member_ty, depth)?;
            if let BlockType::Matrix { columns, column_stride } = &mut ty {
                if let Some(stride) = self.member_decoration(id, i, Decoration::MatrixStride) {
                    *column_stride = stride;
                    size = stride.saturating_mul(*columns);
                }
            }
            members.push(BlockMember { name: self.member_names.get(&(id, i)).cloned(), offset, size, ty });
        }
        Ok(members)
    }

    /// The params block behind global variable `var`, if it is one.
    pub(super) fn params_block(&self, var: u32) -> Result<Option<ParamsBlock>> {
        let Some(inst) = self.defs.get(&var) else { return Ok(None) };
        if inst.class.opcode != Op::Variable {
            return Ok(None);
        }
        let Some(Operand::StorageClass(storage)) = inst.operands.first() else { return Ok(None) };
        let delivery = match storage {
            StorageClass::PushConstant => ParamsDelivery::PushConstants,
            StorageClass::Uniform => {
                let set = self.decoration(var, Decoration::DescriptorSet).flatten().unwrap_or(0);
                let binding = self.decoration(var, Decoration::Binding).flatten().unwrap_or(0);
                if (set, binding) != (PARAMS_SET, PARAMS_BINDING) {
                    return Ok(None);
                }
                ParamsDelivery::UniformBuffer { set, binding }
            }
            _ => return Ok(None),
        };
        let pointer = self.def(inst.result_type.ok_or_else(|| bad("OpVariable without type"))?)?;
        let pointee = id_operand(pointer, 1).ok_or_else(|| bad("params variable is not a pointer"))?;
        match self.describe(pointee, 0)? {
            (BlockType::Struct(members), size) => Ok(Some(ParamsBlock { delivery, members, size })),
            _ => Err(bad(format!("the {delivery} variable %{var} is not a struct block"))),
        }
    }
}

/// The params blocks each entry point uses, by entry name (entry points without
/// params are absent).
pub fn reflect_params(module: &rspirv::dr::Module) -> Result<HashMap<String, Vec<ParamsBlock>>> {
    let index = Index::new(module);
    let mut blocks = HashMap::new();
    for entry in &module.entry_points {
        let Some(Operand::LiteralString(name)) = entry.operands.get(2) else { continue };
        // SPIR-V ≥ 1.4 lists every global an entry point uses in its interface.
        let mut found: Vec<ParamsBlock> = Vec::new();
        for op in entry.operands.iter().skip(3) {
            if let Operand::IdRef(var) = op {
                if let Some(block) = index.params_block(*var)? {
                    found.push(block);
                }
            }
        }
        if !found.is_empty() {
            blocks.insert(name.clone(), found);
        }
    }
    Ok(blocks)
}

/// Reflection of hostile modules (found while fuzzing `raykit::module`): the
/// work must stay bounded whatever the types.
#[cfg(test)]
mod bounded {
    use super::*;
    use crate::layout::parse;
    use rspirv::binary::Assemble;
    use rspirv::spirv::{AddressingModel, Capability, ExecutionModel, FunctionControl, MemoryModel};

    /// A push-constant block whose type is a chain of `levels` structs, each with
    /// two members of the previous one: `levels` + 1 types, 2^`levels` leaves.
    fn doubling_struct_module(levels: u32) -> Vec<u32> {
        let mut b = rspirv::dr::Builder::new();
        b.capability(Capability::Shader);
        b.capability(Capability::RayTracingKHR);
        b.memory_model(AddressingModel::Logical, MemoryModel::GLSL450);
        let mut ty = b.type_int(32, 0);
        let mut size = 4;
        for _ in 0..levels {
            let s = b.type_struct([ty, ty]);
            b.decorate(s, Decoration::Block, []);
            b.member_decorate(s, 0, Decoration::Offset, [Operand::LiteralBit32(0)]);
            b.member_decorate(s, 1, Decoration::Offset, [Operand::LiteralBit32(size)]);
            size = size.saturating_mul(2);
            ty = s;
        }
        let pointer = b.type_pointer(None, StorageClass::PushConstant, ty);
        let var = b.variable(pointer, None, StorageClass::PushConstant, None);
        let void = b.type_void();
        let fn_ty = b.type_function(void, []);
        let f = b.begin_function(void, None, FunctionControl::NONE, fn_ty).unwrap_or_default();
        let _ = b.begin_block(None);
        let _ = b.ret();
        let _ = b.end_function();
        b.entry_point(ExecutionModel::RayGenerationKHR, f, "main", [var]);
        b.module().assemble()
    }

    #[test]
    fn a_type_dag_of_exponential_size_is_refused_quickly() {
        let words = doubling_struct_module(30);
        let started = std::time::Instant::now();
        let module = parse(&words).unwrap_or_else(|e| panic!("{e}"));
        let result = reflect_params(&module);
        assert!(started.elapsed().as_secs() < 2, "reflection took {:?}", started.elapsed());
        let err = result.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(err.contains("too many members"), "{err}");
        // A small one of the same shape still reflects.
        let module = parse(&doubling_struct_module(3)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(reflect_params(&module).map(|blocks| blocks.len()).ok(), Some(1));
    }
}
