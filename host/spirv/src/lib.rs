//! # raykit-spirv
//!
//! raykit's host-side SPIR-V tooling, on rspirv (naga's SPIR-V reader rejects the
//! ray-tracing stages):
//!
//! * [`layout`]: each entry point's launch-params block (`Offset`, `ArrayStride`,
//!   `MatrixStride` decorations), ray-payload, hit-attribute and record sizes, and the
//!   check of a params block against the layout `#[derive(LaunchParams)]`
//!   recorded on the host;
//! * [`bindings`]: the descriptor bindings each entry point declares;
//! * [`trace`]: the `OpTraceRayKHR` calls each entry point reaches, with their
//!   constant SBT operands;
//! * [`generate`]: small modules raykit builds itself, such as an empty raygen.
//!
//! The runtime (`raykit`) uses it when it loads modules and links pipelines; build
//! tooling uses it to check freshly built SPIR-V before anything runs.
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod bindings;
pub mod generate;
pub mod layout;
pub mod trace;

pub use bindings::{reflect_bindings, DescriptorBinding, DescriptorKind};
pub use generate::empty_raygen;
pub use layout::{
    built_spirv_path, check, check_element, check_element_file, check_file, element_entry, parse,
    reflect_interface_sizes, reflect_params, reflect_record_sizes, BlockMember, BlockType, InterfaceSizes, LayoutError,
    ParamsBlock, ParamsDelivery,
};
pub use trace::{reflect_traces, EntryTraces, TraceCall};
