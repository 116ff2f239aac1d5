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
//! `u64`, `i64`; glam's vectors and matrices; [`crate::Buffer`],
//! [`crate::Traversable`] and [`crate::Texture2D`] handles; arrays of these; and
//! other structs that derive `LaunchParams`. `bool`, `usize`, references and pointers are compile errors.
//!
//! ## Delivery
//!
//! raykit delivers params as push constants when `size_of::<P>()` is at most
//! [`PUSH_CONSTANT_BUDGET`] bytes, and in a uniform buffer (descriptor set
//! [`PARAMS_SET`], binding [`PARAMS_BINDING`]) otherwise. The rule depends only on
//! the struct, so device code (compiled once, before any device is known) and the
//! host always agree; `#[params]` hides the choice from the program.

pub use raykit_abi::{
    uses_push_constants, FieldLayout, ParamsLayout, Scalar, ScalarKind, Shape, PARAMS_BINDING, PARAMS_SET,
    PUSH_CONSTANT_BUDGET,
};

/// A struct that can be a pipeline's launch params. Derive it with
/// `#[derive(LaunchParams)]`; implemented for `()` (no params).
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a launch-params struct",
    label = "needs `#[derive(LaunchParams)]`",
    note = "add `#[repr(C)]` and `#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]` to `{Self}`, \
            so raykit can check its layout against the SPIR-V"
)]
#[doc(alias("pipelineLaunchParamsVariableName"))]
pub trait LaunchParams: Copy + bytemuck::Pod {
    /// The layout the compiler gave the struct.
    const LAYOUT: ParamsLayout;
}

impl LaunchParams for () {
    const LAYOUT: ParamsLayout = ParamsLayout { name: "()", size: 0, fields: &[] };
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

macro_rules! numeric_fields {
    ($kind:ident $bits:literal: $($ty:ty),* $(,)?) => {
        $(impl DeviceField for $ty {
            const SHAPE: Shape = Shape::Numeric(raykit_abi::Scalar { kind: raykit_abi::ScalarKind::$kind, bits: $bits });
        })*
    };
}

use spirv_std::glam;
numeric_fields!(Unsigned 32: u32, glam::UVec2, glam::UVec3, glam::UVec4);
numeric_fields!(Signed 32: i32, glam::IVec2, glam::IVec3, glam::IVec4);
numeric_fields!(Float 32: f32, glam::Vec2, glam::Vec3, glam::Vec3A, glam::Vec4, glam::Quat);
numeric_fields!(Unsigned 64: u64);
numeric_fields!(Signed 64: i64);

impl DeviceField for crate::Traversable {
    const SHAPE: Shape = Shape::Traversable;
}

impl DeviceField for crate::Texture2D {
    const SHAPE: Shape = Shape::Texture;
}

impl<T: 'static> DeviceField for crate::Buffer<T> {
    const SHAPE: Shape = Shape::Buffer;
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
