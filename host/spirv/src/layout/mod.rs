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
//! interface, and the size of the SBT record data it reads
//! ([`reflect_record_sizes`]), which SBTs are checked against.
//!
//! The reader is rspirv's data representation (naga's SPIR-V front-end rejects
//! the ray-tracing stages).

// Layout errors carry the names and offsets that make them actionable; they are
// rare and built once, so their size does not matter.
#![allow(clippy::result_large_err)]

mod built;
mod compare;
mod describe;
mod element;
mod index;
mod interface;
mod record;

pub use built::{built_spirv_path, check_file};
pub use compare::check;
pub use describe::reflect_params;
pub use element::{check_element, check_element_blocks, check_element_file, element_entry};
pub use interface::reflect_interface_sizes;
pub use record::reflect_record_sizes;

use raykit_abi::{Scalar, PARAMS_BINDING, PARAMS_SET, PUSH_CONSTANT_BUDGET};

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
    /// A `#[derive(Element)]` struct's fields sit elsewhere in the SPIR-V than on the host.
    ElementMismatch {
        /// The struct's name.
        struct_name: &'static str,
        /// The first field that differs (dotted path for nested structs).
        field: String,
        /// Its offset and size on the host.
        host: String,
        /// Its offset and size in the SPIR-V.
        device: String,
    },
    /// The SPIR-V has no record of a `#[derive(Element)]` struct's device layout.
    ElementNotRecorded {
        /// The struct's name.
        struct_name: &'static str,
        /// The entry point that records it.
        entry: String,
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
        /// What usually causes this, and the fix.
        cause: String,
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
            LayoutError::ElementMismatch { struct_name, field, host, device } => write!(
                f,
                "buffer element `{struct_name}` is laid out differently on the host and in the SPIR-V: field \
                 `{field}` is at {host} on the host but at {device} in the SPIR-V, so the device would read other \
                 words than the host writes. Likely cause: the struct differs between the host and the device build \
                 (a field or its type behind `cfg(target_arch = \"spirv\")` or a feature enabled on one side only), \
                 or the SPIR-V was built from an older definition (rebuild it with `cargo xtask build-shaders`)"
            ),
            LayoutError::ElementNotRecorded { struct_name, entry } => write!(
                f,
                "the SPIR-V does not record the device layout of buffer element `{struct_name}` (it has no entry \
                 point `{entry}`): check the module of the device crate that defines `{struct_name}` \
                 (`#[derive(Element)]` records it only in crates with `[package.metadata.raykit] device = true`), \
                 built by `cargo xtask build-shaders`"
            ),
            LayoutError::Delivery { struct_name, size, entry, expected, found, cause } => write!(
                f,
                "`{entry}` reads its params from {found}, but raykit delivers `{struct_name}` ({size} bytes) in \
                 {expected}: params of at most {PUSH_CONSTANT_BUDGET} bytes go in push constants, larger ones in a \
                 uniform buffer at set {PARAMS_SET}, binding {PARAMS_BINDING}. Likely cause: {cause}"
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

/// A [`LayoutError::InvalidSpirv`] with this reason.
fn bad(reason: impl Into<String>) -> LayoutError {
    LayoutError::InvalidSpirv(reason.into())
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
