//! Launch-params layouts: what the SPIR-V says, and the check against the host.
//!
//! OptiX leaves it to the user to keep the device's `Params` and the host's copy
//! in sync ("take care that CUDA vector types have specific alignment
//! requirements"). raykit reads the params block of every entry point from the
//! SPIR-V — the push-constant block, or the uniform block at set
//! [`PARAMS_SET`] — with its member `Offset`,
//! `ArrayStride` and `MatrixStride` decorations, and compares it with the layout
//! that `#[derive(LaunchParams)]` recorded on the host. A difference is a
//! [`LayoutError::Mismatch`] naming the struct, the field, both offsets and
//! sizes, and the likely cause.
//!
//! The same check runs in two places: when the host links a pipeline
//! (`raykit::Pipeline::new`), and right after `cargo xtask build-shaders` built a
//! device crate (the tests that `#[raygen]` and friends generate for programs
//! with `#[params]`), so a mismatch is caught before anything runs.
//!
//! The same reader gives each entry point's ray payload and hit attribute sizes
//! ([`reflect_interface_sizes`]), which pipeline libraries declare as their
//! interface.
//!
//! The reader is rspirv's data representation (naga's SPIR-V front-end rejects
//! the ray-tracing stages).

// Layout errors carry the names and offsets that make them actionable; they are
// rare and built once, so their size does not matter.
#![allow(clippy::result_large_err)]

use std::collections::HashMap;

use rspirv::dr::{Instruction, Operand};
use rspirv::spirv::{Decoration, Op, StorageClass};

use raykit_abi::{ParamsLayout, Scalar, ScalarKind, Shape, PARAMS_BINDING, PARAMS_SET, PUSH_CONSTANT_BUDGET};

/// Why a params block and a host layout cannot be used together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// The SPIR-V could not be read.
    InvalidSpirv(String),
    /// A field sits elsewhere, or has another size or stride, in the SPIR-V.
    Mismatch {
        /// The host struct's name.
        struct_name: &'static str,
        /// The entry point whose block differs.
        entry: String,
        /// The first field that differs (dotted path for nested structs).
        field: String,
        /// Its offset and size on the host.
        host: String,
        /// Its offset and size in the SPIR-V.
        device: String,
        /// What usually causes this, and the fix.
        cause: String,
    },
    /// The program reads its params another way than raykit delivers them.
    Delivery {
        /// The host struct's name.
        struct_name: &'static str,
        /// Its size.
        size: u32,
        /// The entry point.
        entry: String,
        /// How raykit delivers the struct.
        expected: String,
        /// How the program reads it.
        found: String,
    },
}

impl std::fmt::Display for LayoutError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LayoutError::InvalidSpirv(reason) => write!(f, "not a valid SPIR-V module: {reason}"),
            LayoutError::Mismatch { struct_name, entry, field, host, device, cause } => write!(
                f,
                "launch params `{struct_name}` do not match the SPIR-V of `{entry}`: field `{field}` is at {host} on the \
                 host but at {device} in the SPIR-V. Likely cause: {cause}"
            ),
            LayoutError::Delivery { struct_name, size, entry, expected, found } => write!(
                f,
                "`{entry}` reads its params from {found}, but raykit delivers `{struct_name}` ({size} bytes) in \
                 {expected}: params of at most {budget} bytes go in push constants, larger ones in a uniform buffer \
                 at set {set}, binding {binding}. Use `#[params]` in Rust programs; in GLSL declare the block \
                 accordingly (`layout(push_constant)` or `layout(set = {set}, binding = {binding}, scalar) uniform`)",
                budget = PUSH_CONSTANT_BUDGET,
                set = PARAMS_SET,
                binding = PARAMS_BINDING,
            ),
        }
    }
}

impl std::error::Error for LayoutError {}

type Result<T> = std::result::Result<T, LayoutError>;

/// How a params block reaches the programs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ParamsDelivery {
    /// A push-constant block.
    PushConstants,
    /// A uniform buffer at this descriptor set and binding.
    UniformBuffer {
        /// `DescriptorSet` decoration.
        set: u32,
        /// `Binding` decoration.
        binding: u32,
    },
}

impl std::fmt::Display for ParamsDelivery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamsDelivery::PushConstants => f.write_str("push constants"),
            ParamsDelivery::UniformBuffer { set, binding } => {
                write!(f, "a uniform buffer (set {set}, binding {binding})")
            }
        }
    }
}

/// One member of a block, as the SPIR-V lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockMember {
    /// `OpMemberName`, when the module has debug names.
    pub name: Option<String>,
    /// `Offset` decoration.
    pub offset: u32,
    /// Size in bytes (for arrays `stride × length`; for structs, up to the end of
    /// the last member).
    pub size: u32,
    /// What it is.
    pub ty: BlockType,
}

/// The type of a block member.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BlockType {
    /// Pointer, boolean or anything else without inner layout or known number kind.
    Plain(String),
    /// A number, or a vector of `components` numbers.
    Numeric {
        /// What each component is.
        scalar: Scalar,
        /// 1 for a scalar.
        components: u32,
    },
    /// A matrix with its `MatrixStride`.
    Matrix {
        /// Columns.
        columns: u32,
        /// `MatrixStride`.
        column_stride: u32,
    },
    /// An array with its `ArrayStride`.
    Array {
        /// `ArrayStride`.
        stride: u32,
        /// Length (0 for a runtime array).
        len: u32,
        /// The element.
        element: Box<BlockType>,
    },
    /// A struct with its members.
    Struct(Vec<BlockMember>),
}

/// The params block one entry point uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParamsBlock {
    /// How it is delivered.
    pub delivery: ParamsDelivery,
    /// The block's members, as laid out in the SPIR-V.
    pub members: Vec<BlockMember>,
    /// Size up to the end of the last member.
    pub size: u32,
}

type Decorations = HashMap<u32, Vec<(Decoration, Option<u32>)>>;
type MemberDecorations = HashMap<(u32, u32), Vec<(Decoration, Option<u32>)>>;

/// Indexes of a parsed module that the reflection needs.
struct Index<'m> {
    defs: HashMap<u32, &'m Instruction>,
    decorations: Decorations,
    member_decorations: MemberDecorations,
    member_names: HashMap<(u32, u32), String>,
    /// Types still to be described in this module: a struct may use another
    /// twice, so a few dozen types can describe 2^n members; this bounds the work.
    budget: std::cell::Cell<u32>,
}

/// Most type descriptions reflection makes per module (all params blocks of all
/// entry points together).
const DESCRIBE_BUDGET: u32 = 1 << 14;

fn id_operand(inst: &Instruction, i: usize) -> Option<u32> {
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

fn bad(reason: impl Into<String>) -> LayoutError {
    LayoutError::InvalidSpirv(reason.into())
}

impl<'m> Index<'m> {
    fn new(module: &'m rspirv::dr::Module) -> Index<'m> {
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

    fn decoration(&self, id: u32, which: Decoration) -> Option<Option<u32>> {
        self.decorations.get(&id)?.iter().find(|(d, _)| *d == which).map(|(_, v)| *v)
    }

    fn member_decoration(&self, id: u32, member: u32, which: Decoration) -> Option<u32> {
        self.member_decorations.get(&(id, member))?.iter().find(|(d, _)| *d == which).and_then(|(_, v)| *v)
    }

    fn def(&self, id: u32) -> Result<&'m Instruction> {
        self.defs.get(&id).copied().ok_or_else(|| bad(format!("type %{id} is used but not defined")))
    }

    /// The value of an integer constant.
    fn constant(&self, id: u32) -> Result<u32> {
        let inst = self.def(id)?;
        match (inst.class.opcode, inst.operands.first()) {
            (Op::Constant, Some(Operand::LiteralBit32(v))) => Ok(*v),
            (Op::Constant, Some(Operand::LiteralBit64(v))) => u32::try_from(*v).map_err(|_| bad("array length over 2^32")),
            _ => Err(bad(format!("array length %{id} is not a plain integer constant (specialization constants are not supported in params)"))),
        }
    }

    /// The type and size of type `id`; `depth` bounds recursion on malformed input.
    fn describe(&self, id: u32, depth: u32) -> Result<(BlockType, u32)> {
        if depth > 32 {
            return Err(bad("types nested more than 32 levels deep"));
        }
        match self.budget.get().checked_sub(1) {
            Some(left) => self.budget.set(left),
            None => {
                return Err(bad(format!(
                    "the params blocks have too many members (over {DESCRIBE_BUDGET} types described); launch params must be a plain struct"
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

    fn struct_members(&self, id: u32, depth: u32) -> Result<Vec<BlockMember>> {
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
    fn params_block(&self, var: u32) -> Result<Option<ParamsBlock>> {
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

/// The bytes of ray payload and hit attributes an entry point declares: what a
/// pipeline library's interface (`VkRayTracingPipelineInterfaceCreateInfoKHR`)
/// must cover.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct InterfaceSizes {
    /// The largest `RayPayloadKHR` or `IncomingRayPayloadKHR` variable.
    pub payload: u32,
    /// The largest `HitAttributeKHR` variable.
    pub hit_attributes: u32,
}

impl InterfaceSizes {
    /// The larger of each size.
    pub fn max(self, other: InterfaceSizes) -> InterfaceSizes {
        InterfaceSizes {
            payload: self.payload.max(other.payload),
            hit_attributes: self.hit_attributes.max(other.hit_attributes),
        }
    }
}

impl Index<'_> {
    /// Size and alignment of type `id` under std430-like rules (vec3 aligned as
    /// vec4), using `Offset`/`ArrayStride` decorations where the module has them.
    /// Payloads and attributes have no explicit layout; these rules give a size at
    /// least as large as any layout a driver may choose.
    fn natural(&self, id: u32, depth: u32) -> Result<(u32, u32)> {
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
    fn length_or_default(&self, id: u32) -> Result<u32> {
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
    fn interface_variable(&self, var: u32) -> Result<InterfaceSizes> {
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

/// Parses SPIR-V words with rspirv, turning its panics on malformed input into
/// errors. Callers facing untrusted input check the module's structure first
/// (`raykit::Module::new` does).
pub fn parse(words: &[u32]) -> Result<rspirv::dr::Module> {
    match std::panic::catch_unwind(|| rspirv::dr::load_words(words)) {
        Ok(Ok(module)) => Ok(module),
        Ok(Err(e)) => Err(bad(e.to_string())),
        Err(_) => Err(bad("malformed operands (the SPIR-V parser gave up)")),
    }
}

/// Checks entry point `entry` of the SPIR-V file `path` against `host`: what
/// the tests generated for `#[params]` programs run after
/// `cargo xtask build-shaders`.
pub fn check_file(path: &std::path::Path, entry: &str, host: &ParamsLayout, push_constants: bool) -> Result<()> {
    let bytes = std::fs::read(path).map_err(|e| {
        bad(format!("reading {}: {e}; build the device crates with `cargo xtask build-shaders`", path.display()))
    })?;
    if bytes.len() % 4 != 0 {
        return Err(bad(format!("{} is not a whole number of 32-bit words", path.display())));
    }
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let module = parse(&words)?;
    let blocks = reflect_params(&module)?;
    let Some(blocks) = blocks.get(entry) else {
        return Err(bad(format!("{} has no params block for entry point `{entry}`", path.display())));
    };
    let expected = if push_constants {
        ParamsDelivery::PushConstants
    } else {
        ParamsDelivery::UniformBuffer { set: PARAMS_SET, binding: PARAMS_BINDING }
    };
    check(host, entry, blocks, expected)
}

/// Where `cargo xtask build-shaders` put the SPIR-V of the device crate whose
/// manifest directory is `manifest_dir`: `$RAYKIT_SPIRV_DIR/<crate>.spv`, else
/// `target/spirv/<crate>.spv` in the nearest ancestor directory that has it.
pub fn built_spirv_path(manifest_dir: &str, crate_name: &str) -> std::path::PathBuf {
    let file = format!("{}.spv", crate_name.replace('-', "_"));
    if let Some(dir) = std::env::var_os("RAYKIT_SPIRV_DIR") {
        return std::path::PathBuf::from(dir).join(file);
    }
    let start = std::path::Path::new(manifest_dir);
    for dir in start.ancestors() {
        let candidate = dir.join("target").join("spirv").join(&file);
        if candidate.is_file() {
            return candidate;
        }
    }
    start.join("target").join("spirv").join(file)
}

/// A disagreement between the host's struct and the SPIR-V.
struct Mismatch {
    field: String,
    host: String,
    device: String,
    depth: usize,
}

fn describe_host(offset: u32, size: u32) -> String {
    format!("offset {offset}, size {size}")
}

/// How a message names SPIR-V member `index` (with its `OpMemberName` when the module has one).
fn member_label(member: &BlockMember, index: usize) -> String {
    match &member.name {
        Some(name) => format!("SPIR-V member {index} `{name}`"),
        None => format!("SPIR-V member {index}"),
    }
}

/// Compares the host layout with the block members, pairing each host field with
/// the member at its offset; `Err` on the first difference.
fn compare(
    host: &ParamsLayout,
    members: &[BlockMember],
    path: &str,
    depth: usize,
) -> std::result::Result<(), Mismatch> {
    let at = |name: &str| if path.is_empty() { name.to_owned() } else { format!("{path}.{name}") };
    for field in host.fields {
        let host_text = format!("{}, type {}", describe_host(field.offset, field.size), field.type_name);
        let Some((index, member)) = members.iter().enumerate().find(|(_, m)| m.offset == field.offset) else {
            let covering = members
                .iter()
                .enumerate()
                .find(|(_, m)| m.offset < field.offset && field.offset < m.offset.saturating_add(m.size.max(1)));
            let same_name = members.iter().enumerate().find(|(_, m)| m.name.as_deref() == Some(field.name));
            let device = match (same_name, covering) {
                (Some((i, m)), _) => format!("{}: offset {}, size {}", member_label(m, i), m.offset, m.size),
                (None, Some((i, m))) => format!(
                    "no member starts at offset {}: {} (offset {}, size {}) covers it",
                    field.offset,
                    member_label(m, i),
                    m.offset,
                    m.size
                ),
                (None, None) => {
                    let offsets: Vec<u32> = members.iter().map(|m| m.offset).collect();
                    format!("absent: no member at offset {} (the block's members start at {offsets:?})", field.offset)
                }
            };
            return Err(Mismatch { field: at(field.name), host: host_text, device, depth });
        };
        let mismatch = |device: String| Mismatch {
            field: at(field.name),
            host: host_text.clone(),
            device: format!("{}: {device}", member_label(member, index)),
            depth,
        };
        match (&field.shape, &member.ty) {
            (Shape::Struct(inner), BlockType::Struct(inner_members)) => {
                compare(inner, inner_members, &at(field.name), depth + 1)?;
            }
            (Shape::Array { stride, len, .. }, BlockType::Array { stride: s, len: l, .. }) => {
                if stride != s || len != l {
                    return Err(mismatch(format!("array of {l} with stride {s} (host: {len} with stride {stride})")));
                }
            }
            (Shape::Matrix { column_stride, .. }, BlockType::Matrix { column_stride: s, .. }) => {
                if column_stride != s {
                    return Err(mismatch(format!("matrix column stride {s} (host: {column_stride})")));
                }
            }
            // rust-gpu lays glam's matrices out as structs of column vectors.
            (Shape::Matrix { columns, column_stride }, BlockType::Struct(cols)) => {
                let stride_ok = cols.len() == *columns as usize
                    && cols
                        .iter()
                        .enumerate()
                        .all(|(k, c)| c.offset == k as u32 * column_stride && c.size <= *column_stride);
                if !stride_ok {
                    let offsets: Vec<u32> = cols.iter().map(|c| c.offset).collect();
                    return Err(mismatch(format!(
                        "offset {}, columns at relative offsets {offsets:?} (host: {columns} columns {column_stride} bytes apart)",
                        member.offset
                    )));
                }
            }
            (Shape::Numeric(host_scalar), BlockType::Numeric { scalar, components }) => {
                // A 64-bit integer as two 32-bit words (WGSL has no 64-bit integers).
                let split_u64 = host_scalar.bits == 64
                    && host_scalar.kind != ScalarKind::Float
                    && scalar.kind != ScalarKind::Float
                    && scalar.bits == 32
                    && *components == 2;
                if (host_scalar != scalar && !split_u64) || member.size > field.size {
                    let what = if *components == 1 {
                        scalar.to_string()
                    } else {
                        format!("vector of {components} × {scalar}")
                    };
                    return Err(mismatch(format!(
                        "offset {}, size {}, a {what} (the host field holds {host_scalar} components)",
                        member.offset, member.size
                    )));
                }
            }
            // Handles are structs on some targets: only where they are and their size matter.
            (Shape::Plain | Shape::Numeric(_) | Shape::Buffer | Shape::Texture | Shape::Traversable, _) => {
                if member.size > field.size {
                    return Err(mismatch(format!("offset {}, size {}", member.offset, member.size)));
                }
            }
            (_, other) => return Err(mismatch(format!("offset {}, a {}", member.offset, kind_name(other)))),
        }
    }
    if let Some((index, extra)) =
        members.iter().enumerate().find(|(_, m)| !host.fields.iter().any(|f| f.offset == m.offset))
    {
        return Err(Mismatch {
            field: at(extra.name.as_deref().unwrap_or("(unnamed)")),
            host: format!(
                "absent: `{}` has only {} fields, none at offset {}",
                host.name,
                host.fields.len(),
                extra.offset
            ),
            device: format!("{} at offset {}, size {}", member_label(extra, index), extra.offset, extra.size),
            depth,
        });
    }
    Ok(())
}

fn kind_name(ty: &BlockType) -> &'static str {
    match ty {
        BlockType::Plain(_) | BlockType::Numeric { .. } => "scalar or vector",
        BlockType::Matrix { .. } => "matrix",
        BlockType::Array { .. } => "array",
        BlockType::Struct(_) => "struct",
    }
}

/// The likely cause of a mismatch in a field of type `type_name`.
fn likely_cause(type_name: &str) -> String {
    let aligned = ["Vec3A", "Vec4", "Mat3A", "Mat4", "Quat", "UVec4", "IVec4", "Affine"];
    if let Some(t) = aligned.iter().find(|t| type_name.contains(*t)) {
        format!(
            "glam's `{t}` has a different alignment on the host (SIMD, 16 bytes) than on the SPIR-V target; \
             place it at an offset that is a multiple of 16 with explicit padding fields, or use `Vec3`/`[f32; 4]`"
        )
    } else {
        "the host and the SPIR-V were built from different definitions (rebuild the shaders with \
         `cargo xtask build-shaders`), or the pipeline's params type is not the one the program declares"
            .to_owned()
    }
}

/// Checks that entry point `entry`'s params block matches the host's layout.
///
/// `blocks` are the params blocks the entry point declares; the one delivered
/// the way raykit delivers `host` (`expected`) is compared.
pub fn check(host: &ParamsLayout, entry: &str, blocks: &[ParamsBlock], expected: ParamsDelivery) -> Result<()> {
    let Some(block) = blocks.iter().find(|b| b.delivery == expected) else {
        return Err(LayoutError::Delivery {
            struct_name: host.name,
            size: host.size,
            entry: entry.to_owned(),
            expected: expected.to_string(),
            found: blocks.iter().map(|b| b.delivery.to_string()).collect::<Vec<_>>().join(" and "),
        });
    };
    // rust-gpu wraps the struct in a one-member block; GLSL blocks are the struct.
    let mut candidates = vec![(block.members.as_slice(), 0usize)];
    if let [BlockMember { offset: 0, ty: BlockType::Struct(inner), .. }] = block.members.as_slice() {
        candidates.push((inner.as_slice(), 0));
    }
    let mut best: Option<Mismatch> = None;
    for (members, _) in candidates.iter().rev() {
        match compare(host, members, "", 0) {
            Ok(()) => return Ok(()),
            Err(m) => {
                if best.as_ref().is_none_or(|b| m.depth > b.depth) {
                    best = Some(m);
                }
            }
        }
    }
    let m = best.unwrap_or(Mismatch { field: String::new(), host: String::new(), device: String::new(), depth: 0 });
    let type_name = field_type(host, &m.field).unwrap_or("");
    Err(LayoutError::Mismatch {
        struct_name: host.name,
        entry: entry.to_owned(),
        field: m.field,
        host: m.host,
        device: m.device,
        cause: likely_cause(type_name),
    })
}

/// The type name of the field at dotted `path`.
fn field_type(host: &ParamsLayout, path: &str) -> Option<&'static str> {
    let mut layout = host;
    let mut parts = path.split('.').peekable();
    while let Some(part) = parts.next() {
        let field = layout.fields.iter().find(|f| f.name == part)?;
        if parts.peek().is_none() {
            return Some(field.type_name);
        }
        match field.shape {
            Shape::Struct(inner) => layout = inner,
            _ => return Some(field.type_name),
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use raykit_abi::FieldLayout;

    const INNER: ParamsLayout = ParamsLayout {
        name: "Inner",
        size: 8,
        fields: &[
            FieldLayout { name: "a", type_name: "u32", offset: 0, size: 4, shape: Shape::Plain },
            FieldLayout { name: "b", type_name: "f32", offset: 4, size: 4, shape: Shape::Plain },
        ],
    };
    const HOST: ParamsLayout = ParamsLayout {
        name: "P",
        size: 32,
        fields: &[
            FieldLayout { name: "x", type_name: "u32", offset: 0, size: 4, shape: Shape::Plain },
            FieldLayout { name: "inner", type_name: "Inner", offset: 4, size: 8, shape: Shape::Struct(&INNER) },
            FieldLayout { name: "v", type_name: "Vec4", offset: 16, size: 16, shape: Shape::Plain },
        ],
    };

    fn plain(offset: u32, size: u32) -> BlockMember {
        BlockMember { name: None, offset, size, ty: BlockType::Plain("f".into()) }
    }

    fn block(members: Vec<BlockMember>) -> ParamsBlock {
        ParamsBlock { delivery: ParamsDelivery::PushConstants, size: 32, members }
    }

    fn inner(b_offset: u32) -> BlockMember {
        BlockMember { name: None, offset: 4, size: 8, ty: BlockType::Struct(vec![plain(0, 4), plain(b_offset, 4)]) }
    }

    #[test]
    fn agreeing_layouts_pass_flat_and_wrapped() {
        let flat = block(vec![plain(0, 4), inner(4), plain(16, 16)]);
        assert!(check(&HOST, "e", std::slice::from_ref(&flat), ParamsDelivery::PushConstants).is_ok());
        let wrapped =
            block(vec![BlockMember { name: None, offset: 0, size: 32, ty: BlockType::Struct(flat.members.clone()) }]);
        assert!(check(&HOST, "e", std::slice::from_ref(&wrapped), ParamsDelivery::PushConstants).is_ok());
    }

    #[test]
    fn a_moved_field_is_named_with_both_offsets_and_the_cause() {
        let err = check(
            &HOST,
            "__raygen__rg",
            &[block(vec![plain(0, 4), inner(4), plain(12, 16)])],
            ParamsDelivery::PushConstants,
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("`P`") && err.contains("`v`") && err.contains("offset 16") && err.contains("offset 12"),
            "{err}"
        );
        assert!(err.contains("Vec4") && err.contains("alignment"), "{err}");
    }

    fn number(offset: u32, name: &str, kind: ScalarKind) -> BlockMember {
        BlockMember {
            name: Some(name.to_owned()),
            offset,
            size: 4,
            ty: BlockType::Numeric { scalar: Scalar { kind, bits: 32 }, components: 1 },
        }
    }

    const SAMPLES: ParamsLayout = ParamsLayout {
        name: "Settings",
        size: 8,
        fields: &[
            FieldLayout {
                name: "samples",
                type_name: "u32",
                offset: 0,
                size: 4,
                shape: Shape::Numeric(Scalar { kind: ScalarKind::Unsigned, bits: 32 }),
            },
            FieldLayout {
                name: "exposure",
                type_name: "f32",
                offset: 4,
                size: 4,
                shape: Shape::Numeric(Scalar { kind: ScalarKind::Float, bits: 32 }),
            },
        ],
    };

    #[test]
    fn swapped_fields_of_one_size_are_told_apart_by_their_kind() {
        let device = block(vec![number(0, "exposure", ScalarKind::Float), number(4, "samples", ScalarKind::Unsigned)]);
        let err = check(&SAMPLES, "__raygen__rg", &[device], ParamsDelivery::PushConstants).unwrap_err().to_string();
        assert!(err.contains("`samples`") && err.contains("SPIR-V member 0 `exposure`"), "{err}");
        assert!(err.contains("a f32") && err.contains("holds u32"), "{err}");
        let same = block(vec![number(0, "samples", ScalarKind::Unsigned), number(4, "exposure", ScalarKind::Float)]);
        assert!(check(&SAMPLES, "e", &[same], ParamsDelivery::PushConstants).is_ok());
    }

    #[test]
    fn fields_are_paired_by_offset_not_position() {
        // The SPIR-V lists its members out of order: still the same layout.
        let reordered =
            block(vec![number(4, "exposure", ScalarKind::Float), number(0, "samples", ScalarKind::Unsigned)]);
        assert!(check(&SAMPLES, "e", &[reordered], ParamsDelivery::PushConstants).is_ok());
        // A member moved to offset 2: the host field at 0 is named with what the
        // SPIR-V has around it.
        let moved = block(vec![number(2, "samples", ScalarKind::Unsigned), number(4, "exposure", ScalarKind::Float)]);
        let err = check(&SAMPLES, "e", &[moved], ParamsDelivery::PushConstants).unwrap_err().to_string();
        assert!(err.contains("`samples`") && err.contains("SPIR-V member 0 `samples`: offset 2"), "{err}");
    }

    #[test]
    fn nested_fields_are_compared_too() {
        let err =
            check(&HOST, "e", &[block(vec![plain(0, 4), inner(8), plain(16, 16)])], ParamsDelivery::PushConstants)
                .unwrap_err()
                .to_string();
        assert!(err.contains("inner.b"), "{err}");
    }

    #[test]
    fn missing_and_extra_members_and_delivery_are_reported() {
        let err = check(&HOST, "e", &[block(vec![plain(0, 4), inner(4)])], ParamsDelivery::PushConstants)
            .unwrap_err()
            .to_string();
        assert!(err.contains("`v`") && err.contains("absent"), "{err}");
        let err = check(
            &HOST,
            "e",
            &[block(vec![plain(0, 4), inner(4), plain(16, 16), plain(32, 4)])],
            ParamsDelivery::PushConstants,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("only 3 fields"), "{err}");
        let ubo = ParamsDelivery::UniformBuffer { set: PARAMS_SET, binding: PARAMS_BINDING };
        let err = check(&HOST, "e", &[block(vec![plain(0, 4), inner(4), plain(16, 16)])], ubo).unwrap_err();
        assert!(matches!(err, LayoutError::Delivery { .. }), "{err}");
    }
}

/// Reflection of hostile modules (found while fuzzing `raykit::module`): the
/// work must stay bounded whatever the types.
#[cfg(test)]
mod bounded {
    use super::*;
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
