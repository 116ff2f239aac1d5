//! SBT record data: what a program reads with `#[record] data: &T`, and what the
//! host's `Sbt` builder and `Sbt::update` take.
//!
//! Every `bytemuck::Pod` type is record data, passed to the device as it is:
//! raykit does not look inside it, so `Buffer<T>` or `Traversable` handles in it
//! reach the device unchecked. A record type that derives
//! [`SbtRecordData`](macro@crate::SbtRecordData) (instead of `Pod`) has its layout
//! recorded, and every launch checks its handle fields against the launching
//! context's live objects, as it checks the handles in the launch params; a bad
//! one is refused naming the region, the record's index and the field.
//!
//! ```
//! use raykit_device::glam::Vec4;
//! use raykit_device::{Buffer, SbtRecordData};
//!
//! /// A hit record naming its material's colours.
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Zeroable, SbtRecordData)]
//! pub struct Material {
//!     pub colors: Buffer<Vec4>,
//!     pub index: u32,
//! }
//! assert_eq!(<Material as raykit_device::SbtRecordData>::FIELDS[0].name, "colors");
//! ```
//!
//! Handles stored in buffers are never checked; see [`crate::Buffer`] for what
//! the device reads through a bad one.

use crate::FieldLayout;

/// Data of an SBT record. Implemented for every `bytemuck::Pod` type (without
/// handle checks) and by `#[derive(SbtRecordData)]` (with them); see the
/// [module docs](self).
///
/// # Safety
/// `Self` has no padding and no uninitialised bytes (its bytes are copied into
/// the SBT), and [`SbtRecordData::FIELDS`] gives the true offsets and sizes of
/// its fields (the host reads handles there).
#[doc(alias("optixGetSbtDataPointer", "shaderRecordEXT"))]
pub unsafe trait SbtRecordData: Copy + 'static {
    /// The fields whose layout raykit knows (with their shapes, so the host finds
    /// the `Buffer<T>` and `Traversable` handles, nested ones included); empty for
    /// plain `Pod` data.
    const FIELDS: &'static [FieldLayout];

    /// The value's bytes, as the SBT record holds them.
    fn record_bytes(&self) -> &[u8] {
        // SAFETY: per the trait's contract every one of the `size_of::<Self>()`
        // bytes behind `self` is initialised; the slice borrows `self`.
        unsafe { core::slice::from_raw_parts((self as *const Self).cast::<u8>(), core::mem::size_of::<Self>()) }
    }
}

// SAFETY: `Pod` types have no padding or uninitialised bytes; no fields are listed.
unsafe impl<T: bytemuck::Pod> SbtRecordData for T {
    const FIELDS: &'static [FieldLayout] = &[];
}
