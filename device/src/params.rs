//! Launch params: the one struct host and device share, with its layout recorded.
//!
//! `#[derive(LaunchParams)]` (on a `#[repr(C)]`, `Copy`, `bytemuck::Pod` struct)
//! records each field's name, offset and size as seen by the compiler of the crate
//! being built. The host compares that layout with the Offset decorations of the
//! SPIR-V it loads, so a struct whose layout differs between the host and the
//! SPIR-V target (glam's `Vec4`, `Vec3A` and `Mat4` are 16-byte aligned on one and
//! may not be on the other) is an error naming the field, not garbage pixels.

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
pub trait LaunchParams: Copy + bytemuck::Pod {
    /// The layout the compiler gave the struct.
    const LAYOUT: ParamsLayout;
}

impl LaunchParams for () {
    const LAYOUT: ParamsLayout = ParamsLayout { name: "()", size: 0, fields: &[] };
}
