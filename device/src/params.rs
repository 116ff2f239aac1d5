//! Launch params: the one struct host and device share, with its layout recorded.
//!
//! `#[derive(LaunchParams)]` (on a `#[repr(C)]`, `Copy`, `bytemuck::Pod` struct)
//! records each field's name, offset, size and shape (array stride, matrix column
//! stride, nested struct) as seen by the compiler of the crate being built. The
//! host compares that layout with the Offset, ArrayStride and MatrixStride
//! decorations of the SPIR-V it loads, so a struct whose layout differs between the
//! host and the SPIR-V target is an error naming the field, not garbage pixels.
//!
//! Every field's type must be a [`DeviceField`]: the scalars `u32`, `i32`, `f32`,
//! `u64`, `i64`; glam's vectors and matrices; [`crate::Buffer`] and
//! [`crate::Traversable`] handles; arrays of these; and other structs that derive
//! `LaunchParams`. `bool`, `usize`, references and pointers are compile errors.
//!
//! ## Delivery
//!
//! raykit delivers params as push constants when `size_of::<P>()` is at most
//! [`PUSH_CONSTANT_BUDGET`] bytes, and in a uniform buffer (descriptor set
//! [`PARAMS_SET`], binding [`PARAMS_BINDING`]) otherwise. The rule depends only on
//! the struct, so device code (compiled once, before any device is known) and the
//! host always agree; `#[params]` hides the choice from the program.

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
    /// A scalar, a vector or a handle: only offset and size matter.
    Plain,
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

/// A struct that can be a pipeline's launch params. Derive it with
/// `#[derive(LaunchParams)]`; implemented for `()` (no params).
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a launch-params struct",
    label = "needs `#[derive(LaunchParams)]`",
    note = "add `#[repr(C)]` and `#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]` to `{Self}`, \
            so raykit can check its layout against the SPIR-V"
)]
pub trait LaunchParams: Copy + bytemuck::Pod {
    /// The layout the compiler gave the struct.
    const LAYOUT: ParamsLayout;
}

impl LaunchParams for () {
    const LAYOUT: ParamsLayout = ParamsLayout { name: "()", size: 0, fields: &[] };
}

/// Largest params struct delivered as push constants, in bytes: 128, the
/// `maxPushConstantsSize` every Vulkan device guarantees. Larger structs go in a
/// uniform buffer.
pub const PUSH_CONSTANT_BUDGET: usize = 128;

/// Descriptor set of the params uniform buffer (for params over
/// [`PUSH_CONSTANT_BUDGET`]).
pub const PARAMS_SET: u32 = 1;
/// Binding of the params uniform buffer in [`PARAMS_SET`].
pub const PARAMS_BINDING: u32 = 0;

/// How params of type `P` reach the device: `true` for push constants.
pub const fn uses_push_constants<P>() -> bool {
    core::mem::size_of::<P>() <= PUSH_CONSTANT_BUDGET
}

/// A type that may be a field of launch params (or of SBT record data): its
/// layout can be compared with the SPIR-V's.
#[diagnostic::on_unimplemented(
    message = "`{Self}` cannot be a launch-params field",
    label = "not a device type",
    note = "params fields are u32, i32, f32, u64, i64, glam vectors and matrices, Buffer<T>, Traversable, arrays of these, \
            or structs that `#[derive(LaunchParams)]`; use u32 for bool and a Buffer<T> handle for pointers"
)]
pub trait DeviceField: Copy + bytemuck::Pod {
    /// The field's shape.
    const SHAPE: Shape;
}

macro_rules! plain_fields {
    ($($ty:ty),* $(,)?) => { $(impl DeviceField for $ty { const SHAPE: Shape = Shape::Plain; })* };
}

use spirv_std::glam;
plain_fields!(
    u32,
    i32,
    f32,
    u64,
    i64,
    glam::Vec2,
    glam::Vec3,
    glam::Vec3A,
    glam::Vec4,
    glam::Quat,
    glam::UVec2,
    glam::UVec3,
    glam::UVec4,
    glam::IVec2,
    glam::IVec3,
    glam::IVec4,
    crate::Traversable,
);

impl<T: 'static> DeviceField for crate::Buffer<T> {
    const SHAPE: Shape = Shape::Plain;
}

macro_rules! matrix_fields {
    ($($ty:ty => $cols:literal, $col:ty);* $(;)?) => {
        $(impl DeviceField for $ty {
            const SHAPE: Shape = Shape::Matrix { columns: $cols, column_stride: core::mem::size_of::<$col>() as u32 };
        })*
    };
}
matrix_fields!(
    glam::Mat2 => 2, glam::Vec2;
    glam::Mat3 => 3, glam::Vec3;
    glam::Mat3A => 3, glam::Vec3A;
    glam::Mat4 => 4, glam::Vec4;
);

impl<T: DeviceField, const N: usize> DeviceField for [T; N]
where
    [T; N]: bytemuck::Pod,
{
    const SHAPE: Shape = Shape::Array { stride: core::mem::size_of::<T>() as u32, len: N as u32, element: &T::SHAPE };
}
