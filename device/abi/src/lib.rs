//! # raykit-abi
//!
//! What raykit's device programs and its host must agree on, named once: the
//! program kinds (OptiX name prefix, Vulkan shader stage, SPIR-V execution model,
//! shader-group role), the descriptor sets and bindings raykit reserves, the
//! reserved specialization-constant IDs, and the description of a launch-params
//! struct's layout.
//!
//! The attribute macros (`raykit-macros`), the device crate (`raykit-device`, also
//! built for the SPIR-V target) and the host (`raykit`, `raykit-spirv`) all read
//! these definitions, so they cannot drift apart. The crate is `no_std` and has no
//! dependencies.
#![no_std]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod params;
pub mod program;

pub use params::{uses_push_constants, FieldLayout, ParamsLayout, Scalar, ScalarKind, Shape, PUSH_CONSTANT_BUDGET};
pub use program::{ExecutionModel, GroupRole, ProgramKind, ProgramPrefix};

/// Descriptor set of the bindless storage-buffer table every program sees.
pub const BUFFER_TABLE_SET: u32 = 0;
/// Binding of the bindless storage-buffer table in [`BUFFER_TABLE_SET`].
pub const BUFFER_TABLE_BINDING: u32 = 0;

/// Number of slots of the bindless storage-buffer table. Device programs mask a
/// `Buffer<T>` handle with `BUFFER_TABLE_SLOTS - 1`, so no handle value indexes
/// outside the table.
pub const BUFFER_TABLE_SLOTS: u32 = 4096;

/// Binding of the bindless sampled-texture table (combined image samplers) in
/// [`BUFFER_TABLE_SET`], beside the buffer table. `Texture2D` handles index it.
pub const TEXTURE_TABLE_BINDING: u32 = 1;

/// Number of slots of the bindless texture table. Device programs mask a
/// `Texture2D` handle with `TEXTURE_TABLE_SLOTS - 1`, as buffer handles.
pub const TEXTURE_TABLE_SLOTS: u32 = 4096;

/// Descriptor set of the params uniform buffer (for params over
/// [`PUSH_CONSTANT_BUDGET`] bytes).
pub const PARAMS_SET: u32 = 1;
/// Binding of the params uniform buffer in [`PARAMS_SET`].
pub const PARAMS_BINDING: u32 = 0;

/// The prefix of the entry point `#[derive(Element)]` gives a device crate's SPIR-V for
/// each buffer element struct (`__raykit_element__<Struct>`): a compute entry point that
/// declares the struct as its push constants, so the SPIR-V records the struct's layout for the check
/// against the host's. Never part of a pipeline.
pub const ELEMENT_LAYOUT_ENTRY_PREFIX: &str = "__raykit_element__";

/// Specialization-constant ID carrying the exception buffer's slot in the
/// bindless table (`"ra"` in its two high bytes). Reserved: programs may not
/// declare it, and the host sets it when it links a pipeline.
pub const EXCEPTION_SLOT_SPEC_ID: u32 = 0x7261_0000;

/// The specialization-constant ID of the pipeline's `max_trace_depth`, which miss
/// and closest-hit programs compare their trace depth with before tracing
/// (see `raykit_device::RayType::CHECK_DEPTH`). Reserved: the host sets it when it
/// links a pipeline; its default, `u32::MAX`, checks nothing.
pub const MAX_TRACE_DEPTH_SPEC_ID: u32 = 0x7261_0001;

/// The specialization-constant IDs raykit reserves for itself.
pub const RESERVED_SPEC_IDS: [u32; 2] = [EXCEPTION_SLOT_SPEC_ID, MAX_TRACE_DEPTH_SPEC_ID];

/// Whether `id` is a specialization-constant ID reserved by raykit.
pub const fn is_reserved_spec_id(id: u32) -> bool {
    let mut i = 0;
    while i < RESERVED_SPEC_IDS.len() {
        if RESERVED_SPEC_IDS[i] == id {
            return true;
        }
        i += 1;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exception_slot_id_is_reserved() {
        assert_eq!(EXCEPTION_SLOT_SPEC_ID, 1_918_959_616);
        assert!(is_reserved_spec_id(EXCEPTION_SLOT_SPEC_ID));
        assert!(is_reserved_spec_id(MAX_TRACE_DEPTH_SPEC_ID));
        assert!(!is_reserved_spec_id(0));
    }
}
