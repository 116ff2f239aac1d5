//! Linking on Vulkan: ray-tracing pipelines created from program groups or from
//! pipeline libraries, and the libraries themselves (see [`crate::pipeline`] and
//! [`PipelineLibrary`](crate::PipelineLibrary)).

use std::sync::atomic::AtomicU32;
use std::sync::{Arc, Mutex};

use ash::vk;
use raykit_device::LaunchParams;
use raykit_spirv::InterfaceSizes;

use crate::error::{Error, Result};
use crate::stack;
use crate::types::specialization::Specialization;
use crate::vulkan::context::ContextInner;
use crate::vulkan::memory::RawBuffer;
use crate::vulkan::module::SpirvGroup;
use crate::vulkan::pipeline::exceptions::ExceptionBuffer;
use crate::vulkan::pipeline::handle::PipelineHandle;
use crate::vulkan::pipeline::layout::{ParamsUniform, PipelineLayout};
use crate::vulkan::pipeline::shader_groups::{CompiledGroup, LinkedGroup, ShaderGroups};

/// A created pipeline with everything it owns.
pub(crate) struct PipelineInner {
    // Field order is drop order: the pipeline, then the params uniform (its set was
    // allocated with the layout's params set layout), then the layout, then the
    // libraries the pipeline was linked from.
    pub(crate) pipeline: PipelineHandle,
    /// The params uniform buffer, for params over the push-constant budget.
    pub(crate) params_uniform: Option<ParamsUniform>,
    pub(crate) layout: PipelineLayout,
    /// The libraries it was linked from, kept alive as long as it is.
    pub(crate) libraries: Vec<Arc<LibraryInner>>,
    pub(crate) ctx: Arc<ContextInner>,
    /// Its groups, in pipeline order.
    pub(crate) groups: Vec<LinkedGroup>,
    /// `shaderGroupHandleSize` bytes per group, in pipeline order.
    pub(crate) handles: Vec<u8>,
    /// `maxPipelineRayRecursionDepth`.
    pub(crate) max_trace_depth: u32,
    /// The stack size every launch sets (`vkCmdSetRayTracingPipelineStackSizeKHR`).
    pub(crate) stack_size: AtomicU32,
    /// Where programs record user exceptions: one buffer per set of programs
    /// compiled together (the pipeline itself, or each linked library). Launches
    /// zero and copy them on the device (see [`super::record`]).
    pub(crate) exceptions: Vec<Arc<ExceptionBuffer>>,
    /// Those of `exceptions` whose programs can throw: the ones launches zero,
    /// copy and read back.
    pub(crate) throwing: Vec<Arc<ExceptionBuffer>>,
    /// Finished launches' exception readback buffers, reused by later launches
    /// (an allocation per launch is slow on some drivers).
    pub(crate) readbacks: Mutex<Vec<RawBuffer>>,
}

/// What a pipeline is made of besides its stages: its groups, its user-exception
/// buffers and the libraries it is linked from.
pub(crate) struct PipelineParts<'g> {
    groups: Vec<CompiledGroup<'g>>,
    exceptions: Vec<Arc<ExceptionBuffer>>,
    libraries: Vec<Arc<LibraryInner>>,
}

impl PipelineInner {
    /// Creates the pipeline for params `P` from `create_info` (its stages, groups
    /// and libraries) with its own layout, params uniform buffer (for params over
    /// the push-constant budget), recursion depth and the dynamic stack-size state;
    /// names it `name`; reads its groups' handles and stack sizes, and sets the
    /// default stack size.
    fn new<P: LaunchParams>(
        ctx: &Arc<ContextInner>,
        max_trace_depth: u32,
        create_info: vk::RayTracingPipelineCreateInfoKHR<'_>,
        name: &str,
        parts: PipelineParts<'_>,
    ) -> Result<PipelineInner> {
        let layout = PipelineLayout::new::<P>(ctx)?;
        let params_uniform = ParamsUniform::for_layout::<P>(ctx, &layout)?;
        // The stack size is set by every launch (see `crate::stack`).
        let dynamic_states = [vk::DynamicState::RAY_TRACING_PIPELINE_STACK_SIZE_KHR];
        let dynamic_state = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let create_info = create_info
            .max_pipeline_ray_recursion_depth(max_trace_depth)
            .dynamic_state(&dynamic_state)
            .layout(layout.handle);
        let pipeline = PipelineHandle::create(ctx, &create_info, name)?;
        let count = parts.groups.len();
        let handle_size = ctx.limits.shader_group_handle_size as usize;
        // SAFETY: the pipeline is live and has exactly `count` groups.
        let handles = unsafe {
            ctx.rt.get_ray_tracing_shader_group_handles(pipeline.handle, 0, count as u32, count * handle_size)
        }
        .map_err(Error::vk("vkGetRayTracingShaderGroupHandlesKHR"))?;
        let groups: Vec<LinkedGroup> =
            parts.groups.iter().map(|g| LinkedGroup::read(ctx, pipeline.handle, g)).collect();
        let default = stack::vulkan_default(&super::shader_groups::stack_sizes(&groups), max_trace_depth);
        Ok(PipelineInner {
            pipeline,
            params_uniform,
            layout,
            libraries: parts.libraries,
            ctx: ctx.clone(),
            groups,
            handles,
            max_trace_depth,
            stack_size: AtomicU32::new(crate::stack::stack_bytes(default)?),
            throwing: parts.exceptions.iter().filter(|e| e.recorded).cloned().collect(),
            exceptions: parts.exceptions,
            readbacks: Mutex::new(Vec::new()),
        })
    }
}

/// Links checked `groups` (a raygen group, at most one exception group) into a
/// pipeline for params `P`, with the specialization constants `constants`.
pub(crate) fn link_groups<P: LaunchParams>(
    inner: &Arc<ContextInner>,
    groups: &[&SpirvGroup],
    max_trace_depth: u32,
    constants: &Specialization,
) -> Result<PipelineInner> {
    let exceptions = Arc::new(ExceptionBuffer::new(inner, groups)?);
    let shaders = ShaderGroups::new(groups, exceptions.slot, max_trace_depth, constants);
    crate::validate::check_spirv_modules(groups, &shaders.spec_values())?;
    let specialization = shaders.specialization();
    let stages = shaders.stages(&specialization);
    let create_info = vk::RayTracingPipelineCreateInfoKHR::default()
        .flags(primitive_flags(inner, &shaders))
        .stages(&stages)
        .groups(&shaders.group_infos);
    let name = format!("raykit pipeline [{}]", shaders.names().join(", "));
    let parts = PipelineParts {
        groups: groups
            .iter()
            .enumerate()
            .map(|(i, g)| CompiledGroup { group: g, library: None, index: i as u32 })
            .collect(),
        exceptions: vec![exceptions],
        libraries: Vec::new(),
    };
    PipelineInner::new::<P>(inner, max_trace_depth, create_info, &name, parts)
}

/// `SKIP_AABBS` for a pipeline none of whose hit groups has an intersection
/// program, where the device can cull primitives: traversal then never visits
/// AABB geometry, which such a pipeline could not intersect anyway (OptiX's
/// `usesPrimitiveTypeFlags = TRIANGLE`). Libraries are linked without it: a
/// linked pipeline and its libraries must agree on the flag.
fn primitive_flags(ctx: &ContextInner, shaders: &ShaderGroups) -> vk::PipelineCreateFlags {
    let procedural = shaders.group_infos.iter().any(|g| g.ty == vk::RayTracingShaderGroupTypeKHR::PROCEDURAL_HIT_GROUP);
    if ctx.primitive_culling && !procedural {
        vk::PipelineCreateFlags::RAY_TRACING_SKIP_AABBS_KHR
    } else {
        vk::PipelineCreateFlags::empty()
    }
}

/// Links a pipeline for params `P` from checked `libraries` (made with
/// `max_trace_depth` and `interface`, together a launchable set of groups).
pub(crate) fn link_libraries<P: LaunchParams>(
    inner: &Arc<ContextInner>,
    libraries: &[&Arc<LibraryInner>],
    max_trace_depth: u32,
    interface: InterfaceSizes,
) -> Result<PipelineInner> {
    let library_pipelines: Vec<vk::Pipeline> = libraries.iter().map(|l| l.pipeline.handle).collect();
    let library_info = vk::PipelineLibraryCreateInfoKHR::default().libraries(&library_pipelines);
    let interface_create = interface_info(interface);
    // lavapipe gives push constants only to pipelines that compile a stage
    // themselves (see `PipelineLibrary`); give it one that does nothing.
    let carrier = if inner.lavapipe { Some(PushConstantCarrier::new(inner)?) } else { None };
    let carrier_stage: Vec<vk::PipelineShaderStageCreateInfo<'_>> =
        carrier.iter().map(PushConstantCarrier::stage).collect();
    let create_info = vk::RayTracingPipelineCreateInfoKHR::default()
        .stages(&carrier_stage)
        .library_info(&library_info)
        .library_interface(&interface_create);
    let name = format!("raykit pipeline linked from {} libraries", libraries.len());
    let parts = PipelineParts {
        groups: libraries
            .iter()
            .flat_map(|l| {
                l.groups.iter().enumerate().map(|(i, group)| CompiledGroup {
                    group,
                    library: Some(l.pipeline.handle),
                    index: i as u32,
                })
            })
            .collect(),
        exceptions: libraries.iter().map(|l| l.exceptions.clone()).collect(),
        libraries: libraries.iter().map(|l| (*l).clone()).collect(),
    };
    PipelineInner::new::<P>(inner, max_trace_depth, create_info, &name, parts)
}

/// An empty raygen shader ([`raykit_spirv::empty_raygen`]) that a linked pipeline
/// compiles itself on lavapipe, so that lavapipe gives the pipeline's programs
/// their push constants (see the module docs); alive while the pipeline is created.
pub(crate) struct PushConstantCarrier {
    ctx: Arc<ContextInner>,
    module: vk::ShaderModule,
}

impl PushConstantCarrier {
    pub(crate) fn new(ctx: &Arc<ContextInner>) -> Result<PushConstantCarrier> {
        let code = raykit_spirv::empty_raygen();
        let info = vk::ShaderModuleCreateInfo::default().code(&code);
        // SAFETY: `empty_raygen` is valid SPIR-V (checked with spirv-val); the device is live.
        let module =
            unsafe { ctx.device.create_shader_module(&info, None) }.map_err(Error::vk("vkCreateShaderModule"))?;
        Ok(PushConstantCarrier { ctx: ctx.clone(), module })
    }

    /// Its stage, for a linked pipeline's `pStages`.
    pub(crate) fn stage(&self) -> vk::PipelineShaderStageCreateInfo<'static> {
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::RAYGEN_KHR)
            .module(self.module)
            .name(c"main")
    }
}

impl Drop for PushConstantCarrier {
    fn drop(&mut self) {
        // SAFETY: only used while creating a pipeline, which is done.
        unsafe { self.ctx.device.destroy_shader_module(self.module, None) };
    }
}

/// A compiled pipeline library and what it was made with.
pub(crate) struct LibraryInner {
    // Field order is drop order: the library goes before its layout.
    pub(crate) pipeline: PipelineHandle,
    /// The layout it was compiled with, kept as long as the library.
    _layout: PipelineLayout,
    /// Its groups, in library order.
    pub(crate) groups: Vec<SpirvGroup>,
    /// Where its programs record user exceptions (their slot was specialized in).
    pub(crate) exceptions: Arc<ExceptionBuffer>,
}

/// `sizes` as Vulkan takes them (`VkRayTracingPipelineInterfaceCreateInfoKHR`).
pub(crate) fn interface_info(sizes: InterfaceSizes) -> vk::RayTracingPipelineInterfaceCreateInfoKHR<'static> {
    vk::RayTracingPipelineInterfaceCreateInfoKHR::default()
        .max_pipeline_ray_payload_size(sizes.payload)
        .max_pipeline_ray_hit_attribute_size(sizes.hit_attributes)
}

impl LibraryInner {
    /// Compiles checked `groups` into a library for params `P`, with
    /// `max_trace_depth`, `interface` and the specialization constants `constants`.
    pub(crate) fn new<P: LaunchParams>(
        inner: &Arc<ContextInner>,
        groups: &[&SpirvGroup],
        max_trace_depth: u32,
        interface: InterfaceSizes,
        constants: &Specialization,
    ) -> Result<LibraryInner> {
        let exceptions = Arc::new(ExceptionBuffer::new(inner, groups)?);
        let layout = PipelineLayout::new::<P>(inner)?;
        let shaders = ShaderGroups::new(groups, exceptions.slot, max_trace_depth, constants);
        crate::validate::check_spirv_modules(groups, &shaders.spec_values())?;
        let specialization = shaders.specialization();
        let stages = shaders.stages(&specialization);
        let interface_create = interface_info(interface);
        let create_info = vk::RayTracingPipelineCreateInfoKHR::default()
            .flags(vk::PipelineCreateFlags::LIBRARY_KHR)
            .stages(&stages)
            .groups(&shaders.group_infos)
            .max_pipeline_ray_recursion_depth(max_trace_depth)
            .library_interface(&interface_create)
            .layout(layout.handle);
        let name = format!("raykit pipeline library [{}]", shaders.names().join(", "));
        let pipeline = PipelineHandle::create(inner, &create_info, &name)?;
        let library = LibraryInner {
            pipeline,
            _layout: layout,
            groups: groups.iter().map(|g| (*g).clone()).collect(),
            exceptions,
        };
        Ok(library)
    }
}
