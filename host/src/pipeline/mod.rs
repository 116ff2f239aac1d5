//! Pipelines: program groups linked into a Vulkan ray-tracing pipeline, OptiX's
//! `optixPipelineCreate`.
//!
//! A [`Pipeline<P>`] is typed by its launch params `P` (a struct that derives
//! `LaunchParams`), and [`Pipeline::launch`] takes a `&P`. Linking checks every
//! program's params block in the SPIR-V against `P`'s layout (see
//! [`raykit_spirv::layout`]), as OptiX requires every module of a pipeline to agree on
//! its `PipelineCompileOptions`. `P` travels as push constants when it is at most
//! [`PUSH_CONSTANT_BUDGET`](raykit_device::PUSH_CONSTANT_BUDGET) bytes, otherwise
//! in a uniform buffer the pipeline owns (set 1, binding 0); `#[params]` in device
//! code follows the same rule. Every program sees the context's bindless buffer
//! table at set 0, binding 0.
//!
//! Pipelines are created with the dynamic stack-size state
//! (`VK_DYNAMIC_STATE_RAY_TRACING_PIPELINE_STACK_SIZE_KHR`): linking reads every
//! group's stack sizes from the driver ([`Pipeline::group_stack_sizes`]), and each
//! launch sets the size chosen with [`Pipeline::set_stack_size`] (by default the
//! value Vulkan defines for a pipeline without that state); see [`crate::stack`].
//! See [`vkCreateRayTracingPipelinesKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateRayTracingPipelinesKHR.html).
//!
//! A pipeline is linked from program groups ([`Pipeline::new`]) or from pipeline
//! libraries ([`library`], [`Pipeline::link`]), launched ([`launch`], and [`timing`]
//! for GPU-timed launches), and its Vulkan handles are reachable for interoperation
//! ([`raw`]).

pub mod launch;
pub mod library;
pub mod raw;

pub mod timing;

use std::fmt;
use std::marker::PhantomData;
use std::sync::atomic::Ordering;
use std::sync::Arc;

use raykit_device::LaunchParams;
use raykit_spirv::{InterfaceSizes, ParamsDelivery};

use crate::context::{Context, ContextRepr};
use crate::error::{DeviceError, LinkError};
use crate::error::{Error, Result};
use crate::program_group::ProgramGroup;
use crate::stack::{self, GroupRole, GroupStackSizes, StackSize, StackSizes};
pub use crate::types::program::params_delivery;
pub use crate::types::specialization::Specialization;
use crate::validate::link::{check_groups, PipelineInfo};
use crate::vulkan::module::SpirvGroup;
use crate::vulkan::pipeline::link::PipelineInner;
use library::{LibraryInner, PipelineLibrary};

/// Link options (OptiX's `OptixPipelineLinkOptions`).
#[derive(Copy, Clone, Debug)]
#[doc(alias("OptixPipelineLinkOptions"))]
pub struct LinkOptions {
    /// Maximum recursion depth of `trace` calls: 1 when only raygen traces.
    pub max_trace_depth: u32,
}

impl Default for LinkOptions {
    fn default() -> Self {
        LinkOptions { max_trace_depth: 1 }
    }
}

/// A linked ray-tracing pipeline whose programs take launch params `P`.
#[doc(alias("OptixPipeline"))]
pub struct Pipeline<P: LaunchParams> {
    /// What it was checked with, the same on both backends.
    pub(crate) info: Arc<PipelineInfo>,
    pub(crate) repr: PipelineRepr,
    _params: PhantomData<fn(&P)>,
}

/// What a [`Pipeline`] is underneath.
pub(crate) enum PipelineRepr {
    /// A Vulkan pipeline.
    Vulkan(Arc<PipelineInner>),
    /// The CPU backend's programs.
    Cpu(Arc<crate::cpu::program::PipelineData>),
}

impl<P: LaunchParams> Pipeline<P> {
    /// Links `groups` into a pipeline. There must be a raygen group.
    #[doc(alias("optixPipelineCreate", "vkCreateRayTracingPipelinesKHR"))]
    pub fn new(ctx: &Context, groups: &[&ProgramGroup], options: LinkOptions) -> Result<Pipeline<P>> {
        Self::with_specialization(ctx, groups, options, &Specialization::new())
    }

    /// Links `groups` like [`Pipeline::new`], with the specialization constants
    /// in `constants` (OptiX's parameter specialization): every program's
    /// `#[spec_constant(id = N)]` parameter takes the value set for `N`, or its
    /// default. One module can so give several pipelines that behave differently,
    /// with the branches on those constants compiled away by the driver.
    #[doc(alias("optixPipelineCreate", "OptixModuleCompileBoundValueEntry"))]
    pub fn with_specialization(
        ctx: &Context,
        groups: &[&ProgramGroup],
        options: LinkOptions,
        constants: &Specialization,
    ) -> Result<Pipeline<P>> {
        let groups = ProgramGroup::of_context(ctx, groups)?;
        let groups = groups.as_slice();
        let depth = options.max_trace_depth;
        check_groups::<P, _>(ctx.limits(), groups, depth)?;
        crate::validate::check_linkable(groups.iter().map(|g| g.kind()))?;
        let info = PipelineInfo::of::<P, _>(*ctx.limits(), ctx.launch_dimension_limits(), groups, depth);
        let repr =
            match ctx.repr() {
                ContextRepr::Vulkan(inner) => PipelineRepr::Vulkan(Arc::new(
                    crate::vulkan::pipeline::link::link_groups::<P>(inner, groups, depth, constants)?,
                )),
                ContextRepr::Cpu(cpu) => {
                    PipelineRepr::Cpu(Arc::new(crate::cpu::program::link(cpu, groups, depth, constants)))
                }
            };
        Ok(Pipeline { info: Arc::new(info), repr, _params: PhantomData })
    }

    /// Links a pipeline from `libraries` (OptiX's "program groups can be used
    /// across pipelines", on `VK_KHR_pipeline_library`): their program groups,
    /// compiled when each [`PipelineLibrary`] was made, become this pipeline's
    /// groups, so linking compiles nothing again. One library may go into many
    /// pipelines. Together the libraries need one raygen group, at most one
    /// exception group, and no group twice; every library must have been made with
    /// `options.max_trace_depth` and the same [`InterfaceSizes`]. The SBT, stack
    /// sizing and launches work as for [`Pipeline::new`].
    #[doc(alias("optixPipelineCreate"))]
    pub fn link(ctx: &Context, libraries: &[&PipelineLibrary<P>], options: LinkOptions) -> Result<Pipeline<P>> {
        if libraries.iter().any(|l| !l.info.ctx.is_same(ctx)) {
            return Err(Error::Device(DeviceError::ContextMismatch));
        }
        let interface = libraries.first().map(|l| l.info.interface).unwrap_or_default();
        for (index, library) in libraries.iter().enumerate() {
            if library.info.max_trace_depth != options.max_trace_depth {
                return Err(Error::Link(LinkError::LibraryMismatch {
                    what: "max_trace_depth",
                    index,
                    found: library.info.max_trace_depth.to_string(),
                    expected: options.max_trace_depth.to_string(),
                    fix: "Give LibraryOptions::max_trace_depth the pipeline's LinkOptions::max_trace_depth.",
                }));
            }
            if library.info.interface != interface {
                return Err(Error::Link(LinkError::LibraryMismatch {
                    what: "interface",
                    index,
                    found: describe_interface(library.info.interface),
                    expected: describe_interface(interface),
                    fix: "Make every library with LibraryOptions { interface: Some(PipelineLibrary::interface_for(&[every group of every library])), .. }.",
                }));
            }
        }
        let groups: Vec<&SpirvGroup> = libraries.iter().flat_map(|l| l.info.groups.iter()).collect();
        let mut owner: std::collections::HashMap<u64, usize> = std::collections::HashMap::new();
        for (index, library) in libraries.iter().enumerate() {
            for group in &library.info.groups {
                if let Some(first) = owner.insert(group.id, index) {
                    return Err(Error::Link(LinkError::GroupInSeveralLibraries {
                        kind: group.kind(),
                        first,
                        second: index,
                    }));
                }
            }
        }
        crate::validate::check_linkable(groups.iter().map(|g| g.kind()))?;
        // Each library's groups were checked when it was made.
        let depth = options.max_trace_depth;
        let info = PipelineInfo::of::<P, _>(*ctx.limits(), ctx.launch_dimension_limits(), &groups, depth);
        let repr = match ctx.repr() {
            ContextRepr::Vulkan(inner) => {
                if !inner.pipeline_library {
                    return Err(Error::Link(LinkError::PipelineLibrariesUnsupported));
                }
                // Libraries of a Vulkan context are Vulkan libraries.
                let compiled: Vec<&Arc<LibraryInner>> = libraries.iter().filter_map(|l| l.vulkan_inner()).collect();
                PipelineRepr::Vulkan(Arc::new(crate::vulkan::pipeline::link::link_libraries::<P>(
                    inner, &compiled, depth, interface,
                )?))
            }
            ContextRepr::Cpu(cpu) => {
                let parts: Vec<(Vec<&SpirvGroup>, &Specialization)> =
                    libraries.iter().map(|l| (l.info.groups.iter().collect(), &l.info.constants)).collect();
                PipelineRepr::Cpu(Arc::new(crate::cpu::program::link_parts(cpu, &parts, depth)))
            }
        };
        Ok(Pipeline { info: Arc::new(info), repr, _params: PhantomData })
    }

    /// The stack sizes the driver reports for `group`'s shaders in this pipeline
    /// (`vkGetRayTracingShaderGroupStackSizeKHR`; OptiX's
    /// `optixProgramGroupGetStackSize`). Vulkan knows them only once the group is
    /// linked, hence a pipeline method. Zeros on the CPU backend, whose programs
    /// run on its threads' own stacks.
    #[doc(alias("optixProgramGroupGetStackSize", "vkGetRayTracingShaderGroupStackSizeKHR"))]
    pub fn group_stack_sizes(&self, group: &ProgramGroup) -> Result<GroupStackSizes> {
        let index = self.group_index(group).ok_or(Error::Link(LinkError::GroupNotInPipeline { kind: group.kind() }))?;
        Ok(self.vulkan_inner().map_or_else(GroupStackSizes::default, |inner| inner.groups[index].stack_sizes))
    }

    /// Every group's role and stack sizes, in the order the groups were linked
    /// (none on the CPU backend).
    pub fn all_group_stack_sizes(&self) -> Vec<(GroupRole, GroupStackSizes)> {
        self.vulkan_inner()
            .map_or_else(Vec::new, |inner| inner.groups.iter().map(|g| (g.role, g.stack_sizes)).collect())
    }

    /// The maxima of the groups' stack sizes by program kind: the input of
    /// [`stack::conservative`], [`stack::refined`] and [`stack::vulkan_default`]
    /// (zeros on the CPU backend).
    #[doc(alias("optixUtilAccumulateStackSizes"))]
    pub fn stack_sizes(&self) -> StackSizes {
        self.vulkan_inner().map_or_else(StackSizes::default, |inner| {
            crate::vulkan::pipeline::shader_groups::stack_sizes(&inner.groups)
        })
    }

    /// What the validation layer reported while the pipeline was linked (OptiX's
    /// log string of `optixPipelineCreate`); see [`crate::log`].
    pub fn creation_log(&self) -> &[crate::log::ValidationMessage] {
        self.vulkan_inner().map_or(&[], |inner| &inner.pipeline.log)
    }

    /// The pipeline's `max_trace_depth` (`maxPipelineRayRecursionDepth`).
    pub fn max_trace_depth(&self) -> u32 {
        self.info.max_trace_depth
    }

    /// The stack size Vulkan defines for this pipeline were it made without the
    /// dynamic stack-size state ([`stack::vulkan_default`]); 0 on the CPU backend.
    pub fn driver_default_stack_size(&self) -> u64 {
        stack::vulkan_default(&self.stack_sizes(), self.max_trace_depth())
    }

    /// The size `choice` gives for this pipeline, in bytes, without setting it.
    /// `choice` is checked alike on both backends; on the CPU backend, whose
    /// program stack sizes are zeros, the formulas give 0 and `Explicit(n)` gives `n`.
    #[doc(alias("optixUtilComputeStackSizes"))]
    pub fn compute_stack_size(&self, choice: &StackSize<'_>) -> Result<u32> {
        let max_depth = self.max_trace_depth();
        let check_depth = |depth: u32| -> Result<()> {
            if depth > max_depth {
                return Err(Error::Link(LinkError::StackSize {
                    reason: format!("the estimate's trace depth {depth} is over the pipeline's max_trace_depth {max_depth}; raise LinkOptions::max_trace_depth or lower the estimate's"),
                }));
            }
            Ok(())
        };
        let bytes = match choice {
            StackSize::DriverDefault => self.driver_default_stack_size(),
            StackSize::Conservative(depths) => {
                check_depth(depths.max_trace_depth)?;
                stack::conservative(&self.stack_sizes(), depths).total()
            }
            StackSize::Refined(depths) => {
                check_depth(depths.max_trace_depth)?;
                stack::refined(&self.stack_sizes(), depths).total()
            }
            StackSize::CallGraph(graph) => {
                check_depth(graph.max_trace_depth())?;
                graph.estimate()?
            }
            StackSize::Explicit(bytes) => {
                crate::validate::check_explicit_stack(*bytes, &self.stack_sizes())?;
                u64::from(*bytes)
            }
        };
        crate::stack::stack_bytes(bytes)
    }

    /// Chooses the stack size every later launch sets
    /// (`vkCmdSetRayTracingPipelineStackSizeKHR`; OptiX's
    /// `optixPipelineSetStackSize`) and returns it in bytes. Until called, launches
    /// use [`StackSize::DriverDefault`]. On the CPU backend the choice is checked
    /// as on Vulkan and changes nothing: programs run on the threads' own stacks
    /// (64 MiB each), guarded against overflow.
    #[doc(alias("optixPipelineSetStackSize", "vkCmdSetRayTracingPipelineStackSizeKHR"))]
    pub fn set_stack_size(&self, choice: &StackSize<'_>) -> Result<u32> {
        let bytes = self.compute_stack_size(choice)?;
        if let Some(inner) = self.vulkan_inner() {
            inner.stack_size.store(bytes, Ordering::Relaxed);
        }
        Ok(bytes)
    }

    /// The stack size launches set, in bytes (0 on the CPU backend).
    pub fn stack_size(&self) -> u32 {
        self.vulkan_inner().map_or(0, |inner| inner.stack_size.load(Ordering::Relaxed))
    }

    /// How this pipeline delivers its params: push constants, or a uniform buffer
    /// for params over [`PUSH_CONSTANT_BUDGET`](raykit_device::PUSH_CONSTANT_BUDGET) bytes.
    pub fn params_delivery(&self) -> ParamsDelivery {
        params_delivery::<P>()
    }

    /// The position of `group` in this pipeline, if it was linked into it.
    pub(crate) fn group_index(&self, group: &ProgramGroup) -> Option<usize> {
        self.info.group_index(group.group.id)
    }

    /// Which backend runs it, for `Debug`.
    fn backend_name(&self) -> &'static str {
        match &self.repr {
            PipelineRepr::Vulkan(_) => "vulkan",
            PipelineRepr::Cpu(_) => "cpu",
        }
    }

    /// The Vulkan pipeline, when this is one.
    pub(crate) fn vulkan_inner(&self) -> Option<&Arc<PipelineInner>> {
        match &self.repr {
            PipelineRepr::Vulkan(inner) => Some(inner),
            PipelineRepr::Cpu(_) => None,
        }
    }
}

// Stack sizes exist only once a group is linked, so the pipeline module adds this
// query to program groups (which know nothing of pipelines).
impl ProgramGroup {
    /// This group's stack sizes in `pipeline`, as the driver reports them (OptiX's
    /// `optixProgramGroupGetStackSize`; Vulkan knows them once the group is linked):
    /// [`Pipeline::group_stack_sizes`].
    pub fn stack_sizes<P: LaunchParams>(&self, pipeline: &Pipeline<P>) -> Result<GroupStackSizes> {
        pipeline.group_stack_sizes(self)
    }
}

impl<P: LaunchParams> fmt::Debug for Pipeline<P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let groups: Vec<_> = self.info.groups.iter().map(|(_, kind)| *kind).collect();
        let libraries = self.vulkan_inner().map_or(0, |inner| inner.libraries.len());
        f.debug_struct("Pipeline")
            .field("backend", &self.backend_name())
            .field("params", &std::any::type_name::<P>())
            .field("params_delivery", &params_delivery::<P>())
            .field("groups", &groups)
            .field("libraries", &libraries)
            .field("max_trace_depth", &self.info.max_trace_depth)
            .field("stack_size", &self.stack_size())
            .finish()
    }
}

fn describe_interface(sizes: InterfaceSizes) -> String {
    format!("an interface of {} B of ray payload and {} B of hit attributes", sizes.payload, sizes.hit_attributes)
}
