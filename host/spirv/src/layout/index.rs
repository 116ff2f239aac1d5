//! The index of a parsed module that reflection reads: definitions, decorations
//! and member names by id, and the budget that bounds the work on one module.

use std::collections::HashMap;

use rspirv::dr::{Instruction, Operand};
use rspirv::spirv::{Decoration, Op};

use super::{bad, Result};

type Decorations = HashMap<u32, Vec<(Decoration, Option<u32>)>>;
type MemberDecorations = HashMap<(u32, u32), Vec<(Decoration, Option<u32>)>>;

/// Indexes of a parsed module that the reflection needs.
pub(super) struct Index<'m> {
    pub(super) defs: HashMap<u32, &'m Instruction>,
    decorations: Decorations,
    member_decorations: MemberDecorations,
    pub(super) member_names: HashMap<(u32, u32), String>,
    /// Types still to be described in this module: a struct may use another
    /// twice, so a few dozen types can describe 2^n members; this bounds the work.
    pub(super) budget: std::cell::Cell<u32>,
}

/// Most type descriptions reflection makes per module (all params blocks of all
/// entry points together).
pub(super) const DESCRIBE_BUDGET: u32 = 1 << 14;

/// Operand `i` of `inst`, when it is an id.
pub(super) fn id_operand(inst: &Instruction, i: usize) -> Option<u32> {
    match inst.operands.get(i)? {
        Operand::IdRef(id) => Some(*id),
        _ => None,
    }
}

/// Operand `i` of `inst`, when it is a 32-bit literal.
pub(super) fn literal(inst: &Instruction, i: usize) -> Option<u32> {
    match inst.operands.get(i)? {
        Operand::LiteralBit32(v) => Some(*v),
        _ => None,
    }
}

impl<'m> Index<'m> {
    /// Indexes the types, decorations and debug names of `module`.
    pub(super) fn new(module: &'m rspirv::dr::Module) -> Index<'m> {
        let mut defs = HashMap::new();
        for inst in &module.types_global_values {
            if let Some(id) = inst.result_id {
                defs.insert(id, inst);
            }
        }
        let mut decorations = Decorations::new();
        let mut member_decorations = MemberDecorations::new();
        for inst in &module.annotations {
            match inst.class.opcode {
                Op::Decorate => {
                    if let (Some(target), Some(Operand::Decoration(d))) = (id_operand(inst, 0), inst.operands.get(1)) {
                        decorations.entry(target).or_default().push((*d, literal(inst, 2)));
                    }
                }
                Op::MemberDecorate => {
                    if let (Some(target), Some(member), Some(Operand::Decoration(d))) =
                        (id_operand(inst, 0), literal(inst, 1), inst.operands.get(2))
                    {
                        member_decorations.entry((target, member)).or_default().push((*d, literal(inst, 3)));
                    }
                }
                _ => {}
            }
        }
        let mut member_names = HashMap::new();
        for inst in &module.debug_names {
            if inst.class.opcode == Op::MemberName {
                if let (Some(target), Some(member), Some(Operand::LiteralString(name))) =
                    (id_operand(inst, 0), literal(inst, 1), inst.operands.get(2))
                {
                    member_names.insert((target, member), name.clone());
                }
            }
        }
        Index { defs, decorations, member_decorations, member_names, budget: std::cell::Cell::new(DESCRIBE_BUDGET) }
    }

    /// The value of decoration `which` on `id`: `None` when absent, `Some(None)`
    /// when it has no literal.
    pub(super) fn decoration(&self, id: u32, which: Decoration) -> Option<Option<u32>> {
        self.decorations.get(&id)?.iter().find(|(d, _)| *d == which).map(|(_, v)| *v)
    }

    /// The literal of decoration `which` on member `member` of struct `id`.
    pub(super) fn member_decoration(&self, id: u32, member: u32, which: Decoration) -> Option<u32> {
        self.member_decorations.get(&(id, member))?.iter().find(|(d, _)| *d == which).and_then(|(_, v)| *v)
    }

    /// The instruction that defines `id`.
    pub(super) fn def(&self, id: u32) -> Result<&'m Instruction> {
        self.defs.get(&id).copied().ok_or_else(|| bad(format!("type %{id} is used but not defined")))
    }

    /// The value of an integer constant.
    pub(super) fn constant(&self, id: u32) -> Result<u32> {
        let inst = self.def(id)?;
        match (inst.class.opcode, inst.operands.first()) {
            (Op::Constant, Some(Operand::LiteralBit32(v))) => Ok(*v),
            (Op::Constant, Some(Operand::LiteralBit64(v))) => u32::try_from(*v).map_err(|_| bad("array length over 2^32")),
            _ => Err(bad(format!("array length %{id} is not a plain integer constant (specialization constants are not supported in params)"))),
        }
    }
}
