//! The descriptor bindings a module declares: every variable decorated with
//! `DescriptorSet` and `Binding`, with the kind of descriptor its type needs. The
//! host checks them against the one pipeline layout raykit creates.

use std::collections::HashMap;

use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Decoration, Op, StorageClass};

/// The kind of descriptor a variable needs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum DescriptorKind {
    /// A storage buffer (`StorageBuffer` storage class, or `Uniform` with `BufferBlock`).
    StorageBuffer,
    /// A uniform buffer (`Uniform` storage class with `Block`).
    UniformBuffer,
    /// An acceleration structure.
    AccelerationStructure,
    /// A combined image sampler (`OpTypeSampledImage`).
    CombinedImageSampler,
    /// An image, sampler or anything else in `UniformConstant`.
    Other,
}

impl std::fmt::Display for DescriptorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DescriptorKind::StorageBuffer => "a storage buffer",
            DescriptorKind::UniformBuffer => "a uniform buffer",
            DescriptorKind::AccelerationStructure => "an acceleration structure",
            DescriptorKind::CombinedImageSampler => "a combined image sampler",
            DescriptorKind::Other => "an image or sampler",
        })
    }
}

/// One descriptor binding a module declares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DescriptorBinding {
    /// `DescriptorSet` decoration.
    pub set: u32,
    /// `Binding` decoration.
    pub binding: u32,
    /// What it needs.
    pub kind: DescriptorKind,
    /// The variable's name (`OpName`), when the module has debug names.
    pub name: Option<String>,
}

/// The descriptor bindings of every entry point of `module`, by entry-point name:
/// the variables of its interface list (SPIR-V 1.4 and later list every global
/// there), or, for older modules, every descriptor variable of the module.
pub fn reflect_bindings(module: &Module) -> HashMap<String, Vec<DescriptorBinding>> {
    let mut set = HashMap::new();
    let mut binding = HashMap::new();
    let mut buffer_block = std::collections::HashSet::new();
    for inst in &module.annotations {
        if inst.class.opcode != Op::Decorate {
            continue;
        }
        let (Some(Operand::IdRef(target)), Some(Operand::Decoration(d))) =
            (inst.operands.first(), inst.operands.get(1))
        else {
            continue;
        };
        let value = match inst.operands.get(2) {
            Some(Operand::LiteralBit32(v)) => Some(*v),
            _ => None,
        };
        match (d, value) {
            (Decoration::DescriptorSet, Some(v)) => {
                set.insert(*target, v);
            }
            (Decoration::Binding, Some(v)) => {
                binding.insert(*target, v);
            }
            (Decoration::BufferBlock, _) => {
                buffer_block.insert(*target);
            }
            _ => {}
        }
    }
    let names: HashMap<u32, String> = module
        .debug_names
        .iter()
        .filter(|i| i.class.opcode == Op::Name)
        .filter_map(|i| match (i.operands.first(), i.operands.get(1)) {
            (Some(Operand::IdRef(id)), Some(Operand::LiteralString(n))) => Some((*id, n.clone())),
            _ => None,
        })
        .collect();
    let defs: HashMap<u32, &Instruction> =
        module.types_global_values.iter().filter_map(|i| i.result_id.map(|id| (id, i))).collect();
    let id = |inst: &Instruction, i: usize| match inst.operands.get(i) {
        Some(Operand::IdRef(id)) => Some(*id),
        _ => None,
    };
    // The innermost type under pointers and arrays.
    let inner = |mut ty: u32| {
        for _ in 0..8 {
            let Some(def) = defs.get(&ty) else { break };
            let next = match def.class.opcode {
                Op::TypePointer => id(def, 1),
                Op::TypeArray | Op::TypeRuntimeArray => id(def, 0),
                _ => None,
            };
            match next {
                Some(n) => ty = n,
                None => break,
            }
        }
        ty
    };
    let mut all = Vec::new();
    for var in &module.types_global_values {
        if var.class.opcode != Op::Variable {
            continue;
        }
        let Some(var_id) = var.result_id else { continue };
        let (Some(&s), Some(&b)) = (set.get(&var_id), binding.get(&var_id)) else { continue };
        let storage = match var.operands.first() {
            Some(Operand::StorageClass(c)) => *c,
            _ => continue,
        };
        let ty = inner(var.result_type.unwrap_or(0));
        let kind = match storage {
            StorageClass::StorageBuffer => DescriptorKind::StorageBuffer,
            StorageClass::Uniform if buffer_block.contains(&ty) => DescriptorKind::StorageBuffer,
            StorageClass::Uniform => DescriptorKind::UniformBuffer,
            _ if defs.get(&ty).is_some_and(|d| d.class.opcode == Op::TypeAccelerationStructureKHR) => {
                DescriptorKind::AccelerationStructure
            }
            _ if defs.get(&ty).is_some_and(|d| d.class.opcode == Op::TypeSampledImage) => {
                DescriptorKind::CombinedImageSampler
            }
            _ => DescriptorKind::Other,
        };
        all.push((var_id, DescriptorBinding { set: s, binding: b, kind, name: names.get(&var_id).cloned() }));
    }
    let lists_globals = module.header.as_ref().is_some_and(|h| h.version() >= (1, 4));
    let mut out = HashMap::new();
    for entry in &module.entry_points {
        let Some(Operand::LiteralString(name)) = entry.operands.get(2) else { continue };
        let interface: std::collections::HashSet<u32> = entry
            .operands
            .iter()
            .skip(3)
            .filter_map(|o| match o {
                Operand::IdRef(id) => Some(*id),
                _ => None,
            })
            .collect();
        let used =
            all.iter().filter(|(var, _)| !lists_globals || interface.contains(var)).map(|(_, b)| b.clone()).collect();
        out.insert(name.clone(), used);
    }
    out
}
