//! Pipeline libraries: program groups compiled once and linked into many
//! pipelines, OptiX's "program groups can be used across pipelines", on
//! [`VK_KHR_pipeline_library`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_pipeline_library.html).
//!
//! A [`PipelineLibrary<P>`] compiles its groups (with their specialization
//! constants and their own user-exception buffer) when it is made;
//! [`Pipeline::link`](crate::Pipeline::link) then joins libraries into a launchable pipeline
//! without compiling them again. Vulkan requires the libraries of one pipeline
//! and the pipeline itself to agree on the recursion depth and on the
//! *interface*: the largest ray payload and hit attributes any program uses
//! ([`InterfaceSizes`]). raykit reads both sizes from each program's SPIR-V, so a
//! library's interface defaults to what its programs declare; libraries meant to
//! be linked together take one interface covering all of them
//! ([`PipelineLibrary::interface_for`]).
//!
//! On the CPU backend, which compiles nothing at run time, a library is its
//! checked groups with their specialization constants, and linking joins them:
//! the same libraries are refused, and link, alike on both backends.
//!
//! lavapipe (Mesa 25) delivers push constants only to the stages of a pipeline
//! that it compiled itself (`lvp_compile_ray_tracing_stages` sets the push-constant
//! size in its loop over `pStages`, not over the libraries' stages), so a pipeline
//! linked only from libraries reads zeros. On lavapipe, raykit adds one empty
//! raygen stage of its own to every linked pipeline ([`raykit_spirv::empty_raygen`]);
//! no group uses it.

use std::fmt;
use std::marker::PhantomData;
use std::sync::Arc;

use raykit_device::LaunchParams;
use raykit_spirv::InterfaceSizes;

use super::Specialization;
use crate::context::{Context, ContextRepr};
use crate::error::LinkError;
use crate::error::{Error, Result};
use crate::program_group::ProgramGroup;
use crate::validate::link::check_groups;
use crate::vulkan::module::SpirvGroup;
pub(crate) use crate::vulkan::pipeline::link::LibraryInner;

/// Options of a [`PipelineLibrary`].
#[derive(Copy, Clone, Debug)]
pub struct LibraryOptions {
    /// Maximum recursion depth of `trace` calls; must equal the
    /// [`LinkOptions::max_trace_depth`](crate::LinkOptions::max_trace_depth) of every pipeline it is linked into.
    pub max_trace_depth: u32,
    /// The payload and hit-attribute sizes it is compiled for; `None` takes what
    /// its programs declare. Libraries linked together need the same interface.
    pub interface: Option<InterfaceSizes>,
}

impl Default for LibraryOptions {
    fn default() -> Self {
        LibraryOptions { max_trace_depth: 1, interface: None }
    }
}

/// Program groups compiled into a pipeline library (on Vulkan, a
/// `VK_KHR_pipeline_library` pipeline), ready to be linked into pipelines whose
/// programs take launch params `P`.
#[doc(alias("VK_KHR_pipeline_library"))]
pub struct PipelineLibrary<P: LaunchParams> {
    /// What it was checked with, the same on both backends.
    pub(crate) info: Arc<LibraryInfo>,
    pub(crate) repr: LibraryRepr,
    _params: PhantomData<fn(&P)>,
}

/// The backend-neutral facts of a [`PipelineLibrary`]: what linking checks.
pub(crate) struct LibraryInfo {
    /// The context it was made on.
    pub(crate) ctx: Context,
    /// Its groups, in library order.
    pub(crate) groups: Vec<SpirvGroup>,
    pub(crate) max_trace_depth: u32,
    pub(crate) interface: InterfaceSizes,
    /// The specialization constants fixed in it.
    pub(crate) constants: Specialization,
}

/// What a [`PipelineLibrary`] is underneath.
pub(crate) enum LibraryRepr {
    /// A compiled Vulkan pipeline library.
    Vulkan(Arc<LibraryInner>),
    /// Nothing more: the CPU backend links the groups of [`LibraryInfo`].
    Cpu,
}

impl<P: LaunchParams> PipelineLibrary<P> {
    /// Compiles `groups` into a library. Any groups may go in one (a library
    /// needs no raygen group); see [`Pipeline::link`](crate::Pipeline::link).
    pub fn new(ctx: &Context, groups: &[&ProgramGroup], options: LibraryOptions) -> Result<PipelineLibrary<P>> {
        Self::with_specialization(ctx, groups, options, &Specialization::new())
    }

    /// Compiles `groups` into a library like [`PipelineLibrary::new`], with the
    /// specialization constants in `constants` (see
    /// [`Pipeline::with_specialization`](crate::Pipeline::with_specialization)): they are fixed in the library.
    pub fn with_specialization(
        ctx: &Context,
        groups: &[&ProgramGroup],
        options: LibraryOptions,
        constants: &Specialization,
    ) -> Result<PipelineLibrary<P>> {
        if groups.is_empty() {
            return Err(Error::Link(LinkError::EmptyLibrary));
        }
        let needed = Self::interface_for(groups);
        let groups = ProgramGroup::of_context(ctx, groups)?;
        let groups = groups.as_slice();
        let limits = ctx.limits();
        check_groups::<P, _>(limits, groups, options.max_trace_depth)?;
        let interface = options.interface.unwrap_or(needed);
        check_interface(groups, interface)?;
        if interface.hit_attributes > limits.max_ray_hit_attribute_size {
            return Err(Error::Link(LinkError::HitAttributesTooLarge {
                size: interface.hit_attributes,
                limit: limits.max_ray_hit_attribute_size,
            }));
        }
        let repr = match ctx.repr() {
            ContextRepr::Vulkan(inner) => {
                if !inner.pipeline_library {
                    return Err(Error::Link(LinkError::PipelineLibrariesUnsupported));
                }
                let library = LibraryInner::new::<P>(inner, groups, options.max_trace_depth, interface, constants)?;
                LibraryRepr::Vulkan(Arc::new(library))
            }
            ContextRepr::Cpu(_) => LibraryRepr::Cpu,
        };
        let info = LibraryInfo {
            ctx: ctx.clone(),
            groups: groups.iter().map(|g| (*g).clone()).collect(),
            max_trace_depth: options.max_trace_depth,
            interface,
            constants: constants.clone(),
        };
        Ok(PipelineLibrary { info: Arc::new(info), repr, _params: PhantomData })
    }

    /// The interface that covers every program of `groups`: the largest ray
    /// payload and hit attributes their SPIR-V declares. Give it, for all the
    /// groups of all the libraries to be linked together, as each one's
    /// [`LibraryOptions::interface`].
    pub fn interface_for(groups: &[&ProgramGroup]) -> InterfaceSizes {
        groups
            .iter()
            .flat_map(|g| g.programs())
            .filter_map(|p| p.entry_info().map(|e| e.interface))
            .fold(InterfaceSizes::default(), InterfaceSizes::max)
    }

    /// The interface it was compiled for.
    pub fn interface(&self) -> InterfaceSizes {
        self.info.interface
    }

    /// Its `max_trace_depth`.
    pub fn max_trace_depth(&self) -> u32 {
        self.info.max_trace_depth
    }

    /// The compiled Vulkan library, when this is one.
    pub(crate) fn vulkan_inner(&self) -> Option<&Arc<LibraryInner>> {
        match &self.repr {
            LibraryRepr::Vulkan(inner) => Some(inner),
            LibraryRepr::Cpu => None,
        }
    }

    /// What the validation layer reported while it was compiled (nothing on the
    /// CPU backend); see [`crate::log`].
    pub fn creation_log(&self) -> &[crate::log::ValidationMessage] {
        self.vulkan_inner().map_or(&[], |inner| &inner.pipeline.log)
    }
}

impl<P: LaunchParams> fmt::Debug for PipelineLibrary<P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PipelineLibrary")
            .field("params", &std::any::type_name::<P>())
            .field("groups", &self.info.groups)
            .field("max_trace_depth", &self.info.max_trace_depth)
            .field("interface", &self.info.interface)
            .finish()
    }
}

/// Every program of `groups` fits `interface`.
fn check_interface(groups: &[&SpirvGroup], interface: InterfaceSizes) -> Result<()> {
    for program in groups.iter().flat_map(|g| g.programs()) {
        let Some(info) = program.entry_info() else { continue };
        let too_small = |what, needed, given| {
            Error::Link(LinkError::LibraryInterfaceTooSmall { program: info.name.clone(), what, needed, given })
        };
        if info.interface.payload > interface.payload {
            return Err(too_small("ray payload", info.interface.payload, interface.payload));
        }
        if info.interface.hit_attributes > interface.hit_attributes {
            return Err(too_small("hit attributes", info.interface.hit_attributes, interface.hit_attributes));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_empty_raygen_is_a_raygen_module() {
        let bytes: Vec<u8> = raykit_spirv::empty_raygen().iter().flat_map(|w| w.to_le_bytes()).collect();
        let entries = crate::module::reflect_entry_points(&bytes).map_err(|e| e.to_string());
        let entries = entries.as_deref().map(|e| e.iter().map(|e| (e.name.as_str(), e.kind)).collect::<Vec<_>>());
        assert_eq!(entries, Ok(vec![("main", Some(raykit_device::ProgramKind::Raygen))]));
    }
}
