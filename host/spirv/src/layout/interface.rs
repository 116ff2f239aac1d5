//! Reflection of the ray payload and hit attribute sizes each entry point
//! declares.

use std::collections::HashMap;

use rspirv::dr::Operand;
use rspirv::spirv::{Decoration, Op, StorageClass};

use super::index::{id_operand, literal, Index, DESCRIBE_BUDGET};
use super::{bad, InterfaceSizes, Result};

impl Index<'_> {
    /// Size and alignment of type `id` under std430-like rules (vec3 aligned as
    /// vec4), using `Offset`/`ArrayStride` decorations where the module has them.
    /// Payloads and attributes have no explicit layout; these rules give a size at
    /// least as large as any layout a driver may choose.
    pub(super) fn natural(&self, id: u32, depth: u32) -> Result<(u32, u32)> {
        if depth > 32 {
            return Err(bad("types nested more than 32 levels deep"));
        }
        match self.budget.get().checked_sub(1) {
            Some(left) => self.budget.set(left),
            None => {
                return Err(bad(format!(
                    "payload or attribute types too large (over {DESCRIBE_BUDGET} types described)"
                )))
            }
        }
        let inst = self.def(id)?;
        let round = |size: u32, align: u32| size.div_ceil(align.max(1)).saturating_mul(align.max(1));
        Ok(match inst.class.opcode {
            Op::TypeInt | Op::TypeFloat => {
                let bytes = (literal(inst, 0).ok_or_else(|| bad("OpTypeInt/Float without width"))? / 8).max(1);
                (bytes, bytes)
            }
            Op::TypeBool => (4, 4),
            Op::TypePointer | Op::TypeAccelerationStructureKHR => (8, 8),
            Op::TypeVector => {
                let component = id_operand(inst, 0).ok_or_else(|| bad("OpTypeVector without component"))?;
                let count = literal(inst, 1).ok_or_else(|| bad("OpTypeVector without count"))?;
                let (size, _) = self.natural(component, depth + 1)?;
                let align_count = if count == 3 { 4 } else { count };
                (size.saturating_mul(count), size.saturating_mul(align_count))
            }
            Op::TypeMatrix => {
                let column = id_operand(inst, 0).ok_or_else(|| bad("OpTypeMatrix without column type"))?;
                let columns = literal(inst, 1).ok_or_else(|| bad("OpTypeMatrix without column count"))?;
                let (size, align) = self.natural(column, depth + 1)?;
                (round(size, align).saturating_mul(columns), align)
            }
            Op::TypeArray => {
                let element = id_operand(inst, 0).ok_or_else(|| bad("array without element type"))?;
                let len =
                    self.length_or_default(id_operand(inst, 1).ok_or_else(|| bad("OpTypeArray without length"))?)?;
                let (size, align) = self.natural(element, depth + 1)?;
                let stride = match self.decoration(id, Decoration::ArrayStride) {
                    Some(Some(stride)) => stride.max(size),
                    _ => round(size, align),
                };
                (stride.saturating_mul(len), align)
            }
            Op::TypeStruct => {
                let (mut end, mut align) = (0u32, 1u32);
                for i in 0..inst.operands.len() {
                    let member =
                        id_operand(inst, i).ok_or_else(|| bad(format!("struct %{id} member {i} is not a type")))?;
                    let (size, member_align) = self.natural(member, depth + 1)?;
                    let offset = match self.member_decoration(id, i as u32, Decoration::Offset) {
                        Some(offset) => offset,
                        None => round(end, member_align),
                    };
                    end = end.max(offset.saturating_add(size));
                    align = align.max(member_align);
                }
                (round(end, align), align)
            }
            // Opaque or unsized types carry no payload bytes.
            _ => (0, 1),
        })
    }

    /// An array length: a constant's value, or a specialization constant's
    /// default (the value unless a pipeline specializes it).
    pub(super) fn length_or_default(&self, id: u32) -> Result<u32> {
        let inst = self.def(id)?;
        match (inst.class.opcode, inst.operands.first()) {
            (Op::SpecConstant, Some(Operand::LiteralBit32(v))) => Ok(*v),
            (Op::SpecConstant, Some(Operand::LiteralBit64(v))) => {
                u32::try_from(*v).map_err(|_| bad("array length over 2^32"))
            }
            (Op::Constant, _) => self.constant(id),
            _ => Err(bad(format!("the length %{id} of an array in a ray payload or hit attributes is not a constant"))),
        }
    }

    /// The interface sizes of global variable `var`, if it is a payload or attribute.
    pub(super) fn interface_variable(&self, var: u32) -> Result<InterfaceSizes> {
        let Some(inst) = self.defs.get(&var) else { return Ok(InterfaceSizes::default()) };
        let Some(Operand::StorageClass(storage)) = inst.operands.first() else { return Ok(InterfaceSizes::default()) };
        if inst.class.opcode != Op::Variable
            || !matches!(
                storage,
                StorageClass::RayPayloadKHR | StorageClass::IncomingRayPayloadKHR | StorageClass::HitAttributeKHR
            )
        {
            return Ok(InterfaceSizes::default());
        }
        let pointer = self.def(inst.result_type.ok_or_else(|| bad("OpVariable without type"))?)?;
        let pointee = id_operand(pointer, 1).ok_or_else(|| bad("payload variable is not a pointer"))?;
        let (size, _) = self.natural(pointee, 0)?;
        Ok(match storage {
            StorageClass::HitAttributeKHR => InterfaceSizes { payload: 0, hit_attributes: size },
            _ => InterfaceSizes { payload: size, hit_attributes: 0 },
        })
    }
}

/// The ray payload and hit attribute sizes of each entry point, by name. From
/// SPIR-V 1.4 on, an entry point lists every global it uses; older modules get the
/// largest variables of the whole module for every entry point.
pub fn reflect_interface_sizes(module: &rspirv::dr::Module) -> Result<HashMap<String, InterfaceSizes>> {
    let index = Index::new(module);
    let lists_all_globals = module.header.as_ref().is_some_and(|h| h.version >= 0x0001_0400);
    let module_wide = if lists_all_globals {
        InterfaceSizes::default()
    } else {
        let mut sizes = InterfaceSizes::default();
        for inst in module.types_global_values.iter().filter(|i| i.class.opcode == Op::Variable) {
            if let Some(var) = inst.result_id {
                sizes = sizes.max(index.interface_variable(var)?);
            }
        }
        sizes
    };
    let mut sizes = HashMap::new();
    for entry in &module.entry_points {
        let Some(Operand::LiteralString(name)) = entry.operands.get(2) else { continue };
        let mut entry_sizes = module_wide;
        for op in entry.operands.iter().skip(3) {
            if let Operand::IdRef(var) = op {
                entry_sizes = entry_sizes.max(index.interface_variable(*var)?);
            }
        }
        sizes.insert(name.clone(), entry_sizes);
    }
    Ok(sizes)
}
