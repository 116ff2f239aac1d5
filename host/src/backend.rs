//! The seam between raykit's public types and its two backends, stated once.
//!
//! Every public resource holds one private `repr` whose variants are exactly
//! `Vulkan(..)` and `Cpu(..)` (`ContextRepr`, `ModuleRepr`, `PipelineRepr`,
//! `LaunchRepr`, `SbtRepr`, `GasRepr`, `IasRepr`, `TextureRepr`, `BufferRepr`,
//! `ReadRepr`). The public type checks what it is given, matches its `repr` once,
//! and hands the backend its own half (`vulkan::…` or `cpu::…`), never the public
//! type. Plain data both read lives in `types`; the launch checks both run are in
//! `validate::launch`.
//!
//! The rule: **backends never validate user input; they translate and run.**
//! Every check of what a user gave (SPIR-V bytes, program kinds, params
//! layouts, trace depth, SBT records, geometry, instances, launch sizes,
//! texture formats) runs in the public layer or `validate`, before the match
//! on `repr`, so both backends refuse the same input with the same error. What
//! stays on a backend's side is what only it can know: the Vulkan driver's own
//! refusals (out of memory, a lost device, the format support it reports) and
//! the CPU backend's faults while a program runs (a stack overflow, a panic).
//! A SPIR-V module is checked alike on both (its bytes, its entry points, the
//! validator), and only then refused by the CPU backend, which runs Rust.
//!
//! What each backend does:
//!
//! | operation | Vulkan | CPU backend |
//! |---|---|---|
//! | [`Context::new`](crate::Context::new), [`Context::all`](crate::Context::all) | yes | yes (one context) |
//! | [`Module::from_spirv`](crate::Module) and other SPIR-V modules (GLSL, WGSL) | yes | checked as on Vulkan, then refused: [`CpuRefusal::SpirvModule`] |
//! | [`Module::from_device_crate`](crate::Module) (Rust device crates) | yes (its SPIR-V) | yes (its host code) |
//! | program groups named by an [`EntryPoint`](raykit_device::EntryPoint) constant | yes | yes |
//! | program groups named by a string | yes | refused: [`CpuRefusal::NamedProgram`] |
//! | [`Pipeline::new`](crate::Pipeline::new), SBT, launches, user exceptions | yes | yes |
//! | [`PipelineLibrary`](crate::PipelineLibrary), [`Pipeline::link`](crate::Pipeline::link) | yes, with `VK_KHR_pipeline_library` | yes: the checked groups with their constants, joined at link |
//! | stack sizes ([`Pipeline::set_stack_size`](crate::Pipeline::set_stack_size)) | yes | checked as on Vulkan; no effect (the threads' own stacks) |
//! | GAS and IAS builds, refits | yes | yes |
//! | GAS compaction, size queries | yes | yes (compaction keeps the tree as it is) |
//! | buffers, textures | yes | yes |
//! | GPU timestamps ([`LaunchTimer`](crate::LaunchTimer)), the GPU timeline | yes | refused: [`CpuRefusal::VulkanOnly`] |
//! | raw Vulkan handles (`Context::raw_device`, …) | yes | `None` |
//! | the submission gate (test hook) | yes | yes |
//!
//! Every refusal is made by [`refused_on_cpu`], so each says the same three
//! things: what was asked, why the CPU backend cannot, and what to do instead.

use crate::error::DeviceError;
use crate::error::Error;

/// An operation the CPU backend refuses.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum CpuRefusal {
    /// A module of SPIR-V (GLSL, WGSL or `.spv` files).
    SpirvModule,
    /// A program named by a string instead of its `EntryPoint` constant.
    NamedProgram,
    /// Something that is part of Vulkan itself, named by what it is.
    VulkanOnly(&'static str),
}

/// The error for `refusal` on the CPU backend: what, why, and the fix.
pub(crate) fn refused_on_cpu(refusal: CpuRefusal) -> Error {
    let (what, why, fix) = match refusal {
        CpuRefusal::SpirvModule => (
            "a SPIR-V module",
            "the CPU backend runs the Rust device programs linked into this program, not SPIR-V (GLSL, WGSL and .spv files have no host code)",
            "load a Rust device crate with Module::from_device_crate (or from_embedded) and name its programs by their EntryPoint constants, or use Backend::Vulkan for SPIR-V modules",
        ),
        CpuRefusal::NamedProgram => (
            "a program named by a string",
            "the CPU backend calls the host-compiled programs that EntryPoint constants carry",
            "name the program by the EntryPoint constant its macro generated (e.g. my_device::RG)",
        ),
        CpuRefusal::VulkanOnly(what) => (what, "it is part of Vulkan", "use a Context of Backend::Vulkan for it"),
    };
    Error::Device(DeviceError::NotOnCpuBackend { what, why, fix })
}
