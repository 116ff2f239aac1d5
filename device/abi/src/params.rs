//! The description of a launch-params struct's layout, and how params reach the device.
//!
//! `#[derive(LaunchParams)]` records a struct's layout in these types as the
//! compiler of the crate being built laid it out; the host's SPIR-V reflection
//! compares it with the Offset, ArrayStride and MatrixStride decorations of the
//! params block.

/// One field of a launch-params struct.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    /// The field's name.
    pub name: &'static str,
    /// Its type, as written.
    pub type_name: &'static str,
    /// Byte offset from the struct's start.
    pub offset: u32,
    /// Size in bytes.
    pub size: u32,
    /// What kind of value it is, with its strides.
    pub shape: Shape,
}

/// The shape of a params field, as far as its layout is concerned.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A scalar or a vector whose offset and size are all that matter.
    Plain,
    /// A number or a vector of numbers: what its components mean is compared too.
    Numeric(Scalar),
    /// A `Buffer<T>` handle (a `u32`): the host checks it names a live buffer of
    /// the launching context at every launch.
    Buffer,
    /// A `Texture2D` handle (a `u32`): the host checks it names a live texture of
    /// the launching context at every launch.
    Texture,
    /// A `Traversable` (a `u64` device address): the host checks it names a live,
    /// up-to-date instance acceleration structure of the launching context.
    Traversable,
    /// A matrix stored column by column, `column_stride` bytes apart.
    Matrix {
        /// Number of columns.
        columns: u32,
        /// Bytes from one column to the next (SPIR-V's `MatrixStride`).
        column_stride: u32,
    },
    /// A fixed-size array.
    Array {
        /// Bytes from one element to the next (SPIR-V's `ArrayStride`).
        stride: u32,
        /// Number of elements.
        len: u32,
        /// The element's shape.
        element: &'static Shape,
    },
    /// A nested struct, itself deriving `LaunchParams`.
    Struct(&'static ParamsLayout),
}

/// What the bytes of a number mean: its kind and width.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Scalar {
    /// Unsigned, signed or floating point.
    pub kind: ScalarKind,
    /// Width in bits.
    pub bits: u32,
}

/// The kind of a number.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ScalarKind {
    /// An unsigned integer.
    Unsigned,
    /// A signed integer.
    Signed,
    /// A floating-point number.
    Float,
}

impl core::fmt::Display for Scalar {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let prefix = match self.kind {
            ScalarKind::Unsigned => 'u',
            ScalarKind::Signed => 'i',
            ScalarKind::Float => 'f',
        };
        write!(f, "{prefix}{}", self.bits)
    }
}

/// The layout of a launch-params struct.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct ParamsLayout {
    /// The struct's name.
    pub name: &'static str,
    /// `size_of` the struct.
    pub size: u32,
    /// Its fields, in declaration order.
    pub fields: &'static [FieldLayout],
}

/// Largest params struct delivered as push constants, in bytes: 128, the
/// `maxPushConstantsSize` every Vulkan device guarantees. Larger structs go in a
/// uniform buffer at [`PARAMS_SET`](crate::PARAMS_SET), [`PARAMS_BINDING`](crate::PARAMS_BINDING).
pub const PUSH_CONSTANT_BUDGET: usize = 128;

/// How params of type `P` reach the device: `true` for push constants.
pub const fn uses_push_constants<P>() -> bool {
    core::mem::size_of::<P>() <= PUSH_CONSTANT_BUDGET
}
