//! Entry points: the names and stages the macros give to device programs.
//!
//! Each `#[raygen] fn rg` emits, beside the SPIR-V entry point `__raygen__rg`, a
//! constant `RG: EntryPoint` that the host uses to refer to the program, so host
//! and device are never coupled by a hand-written string.

pub use raykit_abi::{ProgramKind, ProgramPrefix};

/// A device program as the host refers to it: its SPIR-V entry-point name and kind.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct EntryPoint {
    /// The SPIR-V entry-point name, e.g. `__raygen__rg`.
    pub name: &'static str,
    /// The program kind, matching the name's prefix.
    pub kind: ProgramKind,
}
