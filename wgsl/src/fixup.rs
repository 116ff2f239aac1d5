//! raykit's conventions applied to naga's SPIR-V (see the crate docs): shader
//! records and hit attributes get their storage classes, traversables are read
//! from params, `traceRay` gets the SBT offset, stride and miss index packed in
//! its cull mask, and the `Geometry` capability goes.

use std::collections::{HashMap, HashSet};

use rspirv::binary::Assemble;
use rspirv::dr::{Instruction, Module, Operand};
use rspirv::spirv::{Capability, Decoration, Op, StorageClass, Word};

/// The bind group whose bindings stand for params members holding traversables.
pub const TRAVERSABLE_GROUP: u32 = 2;
/// The bind group of the shader record and hit-attribute declarations.
pub const RECORD_AND_ATTRIBUTES_GROUP: u32 = 3;
/// `@group(3) @binding(0)`: the program's shader record.
pub const SHADER_RECORD_BINDING: u32 = 0;
/// `@group(3) @binding(1)`: the hit attributes.
pub const HIT_ATTRIBUTES_BINDING: u32 = 1;

/// The descriptor set and binding of the params uniform buffer.
const PARAMS_SET_BINDING: (u32, u32) = (raykit_abi::PARAMS_SET, raykit_abi::PARAMS_BINDING);

type Fix<T> = Result<T, String>;

fn id(inst: &Instruction, i: usize) -> Option<Word> {
    match inst.operands.get(i)? {
        Operand::IdRef(id) => Some(*id),
        _ => None,
    }
}

fn literal(inst: &Instruction, i: usize) -> Option<u32> {
    match inst.operands.get(i)? {
        Operand::LiteralBit32(v) => Some(*v),
        _ => None,
    }
}

fn storage_class(inst: &Instruction, i: usize) -> Option<StorageClass> {
    match inst.operands.get(i)? {
        Operand::StorageClass(s) => Some(*s),
        _ => None,
    }
}

struct Fixer {
    module: Module,
}

impl Fixer {
    fn next_id(&mut self) -> Fix<Word> {
        let header = self.module.header.as_mut().ok_or("naga wrote no SPIR-V header")?;
        let id = header.bound;
        header.bound += 1;
        Ok(id)
    }

    fn def(&self, id: Word) -> Option<&Instruction> {
        self.module.types_global_values.iter().find(|i| i.result_id == Some(id))
    }

    /// The decoration value of `target`, if it has `which`.
    fn decoration(&self, target: Word, which: Decoration) -> Option<u32> {
        self.module.annotations.iter().find_map(|a| {
            (a.class.opcode == Op::Decorate
                && id(a, 0) == Some(target)
                && a.operands.get(1) == Some(&Operand::Decoration(which)))
            .then(|| literal(a, 2).unwrap_or(0))
        })
    }

    fn remove_decorations(&mut self, target: Word, which: &[Decoration]) {
        self.module.annotations.retain(|a| {
            !(a.class.opcode == Op::Decorate
                && id(a, 0) == Some(target)
                && matches!(a.operands.get(1), Some(Operand::Decoration(d)) if which.contains(d)))
        });
    }

    /// `OpTypePointer class pointee`, found or added at the end of the types.
    fn pointer_type(&mut self, class: StorageClass, pointee: Word) -> Fix<Word> {
        let found = self.module.types_global_values.iter().find(|i| {
            i.class.opcode == Op::TypePointer && storage_class(i, 0) == Some(class) && id(i, 1) == Some(pointee)
        });
        if let Some(id) = found.and_then(|i| i.result_id) {
            // Moved up next to its pointee, so that a variable may use it.
            let (at, wanted) = (self.after(id) - 1, self.after(pointee));
            if at > wanted {
                let inst = self.module.types_global_values.remove(at);
                self.module.types_global_values.insert(wanted, inst);
            }
            return Ok(id);
        }
        let id = self.next_id()?;
        let inst = Instruction::new(
            Op::TypePointer,
            None,
            Some(id),
            vec![Operand::StorageClass(class), Operand::IdRef(pointee)],
        );
        let at = self.after(pointee);
        self.module.types_global_values.insert(at, inst);
        Ok(id)
    }

    /// The position just after the definition of `id` among the types and globals.
    fn after(&self, id: Word) -> usize {
        let at = self.module.types_global_values.iter().position(|i| i.result_id == Some(id));
        at.map_or(0, |at| at + 1)
    }

    fn u32_type(&mut self) -> Fix<Word> {
        let found = self
            .module
            .types_global_values
            .iter()
            .find(|i| i.class.opcode == Op::TypeInt && literal(i, 0) == Some(32) && literal(i, 1) == Some(0));
        if let Some(id) = found.and_then(|i| i.result_id) {
            return Ok(id);
        }
        let id = self.next_id()?;
        let inst =
            Instruction::new(Op::TypeInt, None, Some(id), vec![Operand::LiteralBit32(32), Operand::LiteralBit32(0)]);
        self.module.types_global_values.insert(0, inst);
        Ok(id)
    }

    fn u32_constant(&mut self, value: u32) -> Fix<Word> {
        let ty = self.u32_type()?;
        let found = self
            .module
            .types_global_values
            .iter()
            .find(|i| i.class.opcode == Op::Constant && i.result_type == Some(ty) && literal(i, 0) == Some(value));
        if let Some(id) = found.and_then(|i| i.result_id) {
            return Ok(id);
        }
        let id = self.next_id()?;
        let inst = Instruction::new(Op::Constant, Some(ty), Some(id), vec![Operand::LiteralBit32(value)]);
        let at = self.after(ty);
        self.module.types_global_values.insert(at, inst);
        Ok(id)
    }

    /// The global variables: (id, storage class, pointee type).
    fn variables(&self) -> Vec<(Word, StorageClass, Word)> {
        self.module
            .types_global_values
            .iter()
            .filter(|i| i.class.opcode == Op::Variable)
            .filter_map(|v| {
                let class = storage_class(v, 0)?;
                let pointer = self.def(v.result_type?)?;
                Some((v.result_id?, class, id(pointer, 1)?))
            })
            .collect()
    }

    /// Moves variable `var` (and every pointer derived from it) to storage class
    /// `class`, dropping its descriptor binding unless `keep_binding`.
    fn change_storage_class(&mut self, var: Word, class: StorageClass, what: &str, keep_binding: bool) -> Fix<()> {
        let (_, _, pointee) = self.variables().into_iter().find(|(v, ..)| *v == var).ok_or("variable not found")?;
        let pointer = self.pointer_type(class, pointee)?;
        for inst in self.module.types_global_values.iter_mut() {
            if inst.result_id == Some(var) {
                inst.result_type = Some(pointer);
                inst.operands[0] = Operand::StorageClass(class);
            }
        }
        // Pointers derived from the variable, to a fixed point (a use may come
        // before its definition in the function's block order).
        let mut derived: HashSet<Word> = HashSet::from([var]);
        loop {
            let mut retype = Vec::new();
            for inst in self.module.functions.iter().flat_map(|f| &f.blocks).flat_map(|b| &b.instructions) {
                let Some(result) = inst.result_id else { continue };
                let derives = matches!(
                    inst.class.opcode,
                    Op::AccessChain | Op::InBoundsAccessChain | Op::PtrAccessChain | Op::CopyObject
                );
                if derives && id(inst, 0).is_some_and(|base| derived.contains(&base)) && !derived.contains(&result) {
                    retype.push(result);
                }
                if inst.class.opcode == Op::FunctionCall
                    && inst.operands.iter().any(|o| matches!(o, Operand::IdRef(a) if derived.contains(a)))
                {
                    return Err(format!("the {what} is passed by pointer to a function; read it in the entry point"));
                }
            }
            if retype.is_empty() {
                break;
            }
            for result in retype {
                derived.insert(result);
                let old = self
                    .module
                    .functions
                    .iter()
                    .flat_map(|f| &f.blocks)
                    .flat_map(|b| &b.instructions)
                    .find(|i| i.result_id == Some(result))
                    .and_then(|i| i.result_type)
                    .ok_or("access chain without a type")?;
                let element = self.def(old).and_then(|p| id(p, 1)).ok_or("access chain type is not a pointer")?;
                let new = self.pointer_type(class, element)?;
                for inst in
                    self.module.functions.iter_mut().flat_map(|f| &mut f.blocks).flat_map(|b| &mut b.instructions)
                {
                    if inst.result_id == Some(result) {
                        inst.result_type = Some(new);
                    }
                }
            }
        }
        if !keep_binding {
            self.remove_decorations(var, &[Decoration::DescriptorSet, Decoration::Binding]);
        }
        // NonWritable (naga's `read`) is for storage buffers and images only.
        self.remove_decorations(var, &[Decoration::NonWritable, Decoration::NonReadable]);
        Ok(())
    }

    /// The params block: the push-constant variable, or the uniform buffer at
    /// raykit's params set and binding. (variable, storage class, struct type)
    fn params_block(&self) -> Option<(Word, StorageClass, Word)> {
        self.variables().into_iter().find(|(var, class, _)| match class {
            StorageClass::PushConstant => true,
            StorageClass::Uniform => {
                (self.decoration(*var, Decoration::DescriptorSet), self.decoration(*var, Decoration::Binding))
                    == (Some(PARAMS_SET_BINDING.0), Some(PARAMS_SET_BINDING.1))
            }
            _ => false,
        })
    }

    /// naga wraps a struct in a one-member block (`struct { Params }`); raykit's
    /// reflection compares the block's members with the host struct's fields, so
    /// the params variable gets the struct itself (made the block) and access
    /// chains lose their leading 0.
    fn unwrap_params(&mut self) -> Fix<()> {
        let Some((params, class, wrapper)) = self.params_block() else { return Ok(()) };
        let Some(inner) = self
            .def(wrapper)
            .filter(|w| w.class.opcode == Op::TypeStruct && w.operands.len() == 1)
            .and_then(|w| id(w, 0))
        else {
            return Ok(());
        };
        let named = self.module.debug_names.iter().any(|n| n.class.opcode == Op::Name && id(n, 0) == Some(wrapper));
        if named || self.def(inner).is_none_or(|t| t.class.opcode != Op::TypeStruct) {
            return Ok(());
        }
        let pointer = self.pointer_type(class, inner)?;
        for inst in self.module.types_global_values.iter_mut() {
            if inst.result_id == Some(params) {
                inst.result_type = Some(pointer);
            }
        }
        if self.decoration(inner, Decoration::Block).is_none() {
            self.module.annotations.push(Instruction::new(
                Op::Decorate,
                None,
                None,
                vec![Operand::IdRef(inner), Operand::Decoration(Decoration::Block)],
            ));
        }
        // The wrapper and its pointer types go (a block may not hold a block).
        let gone: HashSet<Word> = self
            .module
            .types_global_values
            .iter()
            .filter(|i| {
                i.result_id == Some(wrapper) || (i.class.opcode == Op::TypePointer && id(i, 1) == Some(wrapper))
            })
            .filter_map(|i| i.result_id)
            .collect();
        self.module.types_global_values.retain(|i| !i.result_id.is_some_and(|r| gone.contains(&r)));
        self.module.annotations.retain(|a| !id(a, 0).is_some_and(|t| gone.contains(&t)));
        self.module.debug_names.retain(|n| !id(n, 0).is_some_and(|t| gone.contains(&t)));
        let zero = self.u32_constant(0)?;
        let zeros: HashSet<Word> = self
            .module
            .types_global_values
            .iter()
            .filter(|i| i.class.opcode == Op::Constant && literal(i, 0) == Some(0))
            .filter_map(|i| i.result_id)
            .chain([zero])
            .collect();
        for inst in self.module.functions.iter_mut().flat_map(|f| &mut f.blocks).flat_map(|b| &mut b.instructions) {
            if !inst.operands.contains(&Operand::IdRef(params)) {
                continue;
            }
            let chain = matches!(inst.class.opcode, Op::AccessChain | Op::InBoundsAccessChain);
            match (chain, id(inst, 0), id(inst, 1)) {
                (true, Some(base), Some(first)) if base == params && zeros.contains(&first) => {
                    inst.operands.remove(1);
                }
                _ => return Err(format!("the params block is used in an unexpected way ({:?})", inst.class.opcode)),
            }
        }
        Ok(())
    }

    /// Replaces each load of acceleration-structure variable `var` by a read of
    /// params member `member` and `OpConvertUToAccelerationStructureKHR`.
    fn traversable_from_params(&mut self, var: Word, member: u32) -> Fix<()> {
        let Some((params, class, block)) = self.params_block() else {
            return Err(format!(
                "the acceleration_structure at @group({TRAVERSABLE_GROUP}) @binding({member}) stands for params member \
                 {member}, but the module declares no params (`var<immediate>`, or `var<storage, read>` at @group(1) \
                 @binding(0))"
            ));
        };
        let members: Vec<Word> =
            self.def(block).map(|s| (0..s.operands.len()).filter_map(|i| id(s, i)).collect()).unwrap_or_default();
        let Some(&member_ty) = members.get(member as usize) else {
            return Err(format!(
                "the acceleration_structure at @group({TRAVERSABLE_GROUP}) @binding({member}) stands for params member \
                 {member}, but the params struct has {} members; use the member index of its Traversable field",
                members.len()
            ));
        };
        let is_address = self.def(member_ty).is_some_and(|t| match t.class.opcode {
            Op::TypeInt => literal(t, 0) == Some(64),
            Op::TypeVector => {
                literal(t, 1) == Some(2)
                    && id(t, 0).and_then(|c| self.def(c)).is_some_and(|c| {
                        c.class.opcode == Op::TypeInt && literal(c, 0) == Some(32) && literal(c, 1) == Some(0)
                    })
            }
            _ => false,
        });
        if !is_address {
            return Err(format!(
                "the acceleration_structure at @group({TRAVERSABLE_GROUP}) @binding({member}) stands for params member \
                 {member}, which is not a Traversable: declare that member `vec2<u32>` (or `u64`)"
            ));
        }
        let pointer = self.pointer_type(class, member_ty)?;
        let index = self.u32_constant(member)?;
        let mut next = Vec::new();
        let loads: usize = self
            .module
            .functions
            .iter()
            .flat_map(|f| &f.blocks)
            .flat_map(|b| &b.instructions)
            .filter(|i| i.class.opcode == Op::Load && id(i, 0) == Some(var))
            .count();
        for _ in 0..loads {
            next.push((self.next_id()?, self.next_id()?));
        }
        let mut fresh = next.into_iter();
        for block in self.module.functions.iter_mut().flat_map(|f| &mut f.blocks) {
            let mut out = Vec::with_capacity(block.instructions.len());
            for inst in block.instructions.drain(..) {
                if inst.class.opcode == Op::Load && id(&inst, 0) == Some(var) {
                    let (chain, value) = fresh.next().ok_or("load count changed")?;
                    out.push(Instruction::new(
                        Op::AccessChain,
                        Some(pointer),
                        Some(chain),
                        vec![Operand::IdRef(params), Operand::IdRef(index)],
                    ));
                    out.push(Instruction::new(Op::Load, Some(member_ty), Some(value), vec![Operand::IdRef(chain)]));
                    out.push(Instruction::new(
                        Op::ConvertUToAccelerationStructureKHR,
                        inst.result_type,
                        inst.result_id,
                        vec![Operand::IdRef(value)],
                    ));
                } else {
                    if inst.operands.contains(&Operand::IdRef(var)) {
                        return Err(format!(
                            "the acceleration_structure at @group({TRAVERSABLE_GROUP}) @binding({member}) is used \
                             other than by value ({:?})",
                            inst.class.opcode
                        ));
                    }
                    out.push(inst);
                }
            }
            block.instructions = out;
        }
        // The variable goes; entry points that listed it list the params instead.
        self.module.types_global_values.retain(|i| i.result_id != Some(var));
        self.module.annotations.retain(|a| id(a, 0) != Some(var));
        self.module.debug_names.retain(|n| id(n, 0) != Some(var));
        for entry in &mut self.module.entry_points {
            if entry.operands.contains(&Operand::IdRef(var)) {
                entry.operands.retain(|o| *o != Operand::IdRef(var));
                if !entry.operands.contains(&Operand::IdRef(params)) {
                    entry.operands.push(Operand::IdRef(params));
                }
            }
        }
        Ok(())
    }

    /// Splits each `OpTraceRayKHR`'s cull mask into cull mask, SBT offset, SBT
    /// stride and miss index (bits 0-7, 8-15, 16-23, 24-31).
    fn ray_types_from_cull_masks(&mut self) -> Fix<()> {
        let traces = self
            .module
            .functions
            .iter()
            .flat_map(|f| &f.blocks)
            .flat_map(|b| &b.instructions)
            .filter(|i| i.class.opcode == Op::TraceRayKHR)
            .count();
        if traces == 0 {
            return Ok(());
        }
        let u32_ty = self.u32_type()?;
        let [c8, c16, c24, c255] =
            [self.u32_constant(8)?, self.u32_constant(16)?, self.u32_constant(24)?, self.u32_constant(255)?];
        let mut ids = Vec::new();
        for _ in 0..traces * 4 {
            ids.push(self.next_id()?);
        }
        let mut ids = ids.into_iter();
        for block in self.module.functions.iter_mut().flat_map(|f| &mut f.blocks) {
            let mut out = Vec::with_capacity(block.instructions.len());
            for mut inst in block.instructions.drain(..) {
                if inst.class.opcode == Op::TraceRayKHR {
                    let packed = id(&inst, 2).ok_or("OpTraceRayKHR without a cull mask")?;
                    let mut fresh = || ids.next().ok_or("trace count changed");
                    let (mask, offset, stride, miss) = (fresh()?, fresh()?, fresh()?, fresh()?);
                    let op = |op: Op, result: Word, operands: &[Word]| {
                        Instruction::new(
                            op,
                            Some(u32_ty),
                            Some(result),
                            operands.iter().map(|&o| Operand::IdRef(o)).collect(),
                        )
                    };
                    out.push(op(Op::BitwiseAnd, mask, &[packed, c255]));
                    out.push(op(Op::BitFieldUExtract, offset, &[packed, c8, c8]));
                    out.push(op(Op::BitFieldUExtract, stride, &[packed, c16, c8]));
                    out.push(op(Op::ShiftRightLogical, miss, &[packed, c24]));
                    for (i, value) in [(2, mask), (3, offset), (4, stride), (5, miss)] {
                        inst.operands[i] = Operand::IdRef(value);
                    }
                }
                out.push(inst);
            }
            block.instructions = out;
        }
        Ok(())
    }
}

/// Applies raykit's conventions to the SPIR-V naga wrote.
pub(crate) fn apply(words: &[u32]) -> Result<Vec<u32>, String> {
    let module = rspirv::dr::load_words(words).map_err(|e| format!("reading naga's SPIR-V: {e}"))?;
    let mut fixer = Fixer { module };

    // Records and hit attributes.
    let mut attribute_types = HashMap::new();
    for (var, class, pointee) in fixer.variables() {
        let set = fixer.decoration(var, Decoration::DescriptorSet);
        let binding = fixer.decoration(var, Decoration::Binding);
        if set != Some(RECORD_AND_ATTRIBUTES_GROUP) {
            continue;
        }
        let binding = binding.unwrap_or(u32::MAX);
        if class != StorageClass::StorageBuffer {
            return Err(format!(
                "@group({RECORD_AND_ATTRIBUTES_GROUP}) @binding({binding}) must be a `var<storage, read>` (raykit maps \
                 it to the shader record or the hit attributes)"
            ));
        }
        match binding {
            SHADER_RECORD_BINDING => {
                fixer.change_storage_class(var, StorageClass::ShaderRecordBufferKHR, "shader record", false)?;
            }
            HIT_ATTRIBUTES_BINDING => {
                fixer.change_storage_class(var, StorageClass::HitAttributeKHR, "hit attributes", false)?;
                attribute_types.insert(pointee, var);
            }
            other => {
                return Err(format!(
                    "@group({RECORD_AND_ATTRIBUTES_GROUP}) @binding({other}) means nothing to raykit: binding \
                     {SHADER_RECORD_BINDING} is the shader record, {HIT_ATTRIBUTES_BINDING} the hit attributes"
                ))
            }
        }
    }
    // Hit attributes have no explicit layout: the block naga wraps them in loses
    // its Block and Offset decorations.
    for pointee in attribute_types.keys() {
        fixer.remove_decorations(*pointee, &[Decoration::Block]);
        fixer.module.annotations.retain(|a| {
            !(a.class.opcode == Op::MemberDecorate
                && id(a, 0) == Some(*pointee)
                && a.operands.get(2) == Some(&Operand::Decoration(Decoration::Offset)))
        });
    }

    // Params over the push-constant budget: a `var<storage, read>` at raykit's
    // params binding becomes the uniform buffer raykit binds there (WGSL's
    // uniform layout rules would pad every struct member to 16 bytes; raykit's
    // device has scalarBlockLayout, so the storage layout is valid for Uniform).
    for (var, class, _) in fixer.variables() {
        let at = (fixer.decoration(var, Decoration::DescriptorSet), fixer.decoration(var, Decoration::Binding));
        if class == StorageClass::StorageBuffer && at == (Some(PARAMS_SET_BINDING.0), Some(PARAMS_SET_BINDING.1)) {
            fixer.change_storage_class(var, StorageClass::Uniform, "params block", true)?;
        }
    }
    fixer.unwrap_params()?;

    // Traversables.
    for (var, _, pointee) in fixer.variables() {
        let is_accel = fixer.def(pointee).is_some_and(|t| t.class.opcode == Op::TypeAccelerationStructureKHR);
        if !is_accel {
            continue;
        }
        match (fixer.decoration(var, Decoration::DescriptorSet), fixer.decoration(var, Decoration::Binding)) {
            (Some(TRAVERSABLE_GROUP), Some(member)) => fixer.traversable_from_params(var, member)?,
            (set, binding) => {
                return Err(format!(
                    "an acceleration_structure at @group({}) @binding({}): raykit has no descriptor for it; declare it \
                     at @group({TRAVERSABLE_GROUP}) @binding(K), K being the index of the params member that holds the \
                     Traversable",
                    set.map_or("?".to_owned(), |s| s.to_string()),
                    binding.map_or("?".to_owned(), |b| b.to_string()),
                ))
            }
        }
    }

    fixer.ray_types_from_cull_masks()?;
    // naga declares the bindless table (`binding_array<Words>` without a size) as
    // a runtime array of blocks but not the capability that allows it.
    let runtime_arrays = fixer
        .variables()
        .into_iter()
        .any(|(_, _, pointee)| fixer.def(pointee).is_some_and(|t| t.class.opcode == Op::TypeRuntimeArray));
    let declared =
        |c: Capability| fixer.module.capabilities.iter().any(|i| i.operands.first() == Some(&Operand::Capability(c)));
    if runtime_arrays && !declared(Capability::RuntimeDescriptorArray) {
        fixer.module.capabilities.push(Instruction::new(
            Op::Capability,
            None,
            None,
            vec![Operand::Capability(Capability::RuntimeDescriptorArray)],
        ));
    }
    fixer.module.capabilities.retain(|c| c.operands.first() != Some(&Operand::Capability(Capability::Geometry)));
    Ok(fixer.module.assemble())
}
