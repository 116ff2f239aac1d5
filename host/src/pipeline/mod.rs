//! Pipelines: program groups linked into a Vulkan ray-tracing pipeline, OptiX's
//! `optixPipelineCreate`.
//!
//! A [`Pipeline<P>`] is typed by its launch params `P` (a struct that derives
//! `LaunchParams`), and [`Pipeline::launch`] takes a `&P`. Linking checks every
//! program's params block in the SPIR-V against `P`'s layout (see
//! [`raykit_device::layout`]), as OptiX requires every module of a pipeline to agree on
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

pub mod launch;
pub mod library;
pub mod raw;
pub mod timing;

use std::marker::PhantomData;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;

use crate::buffer_table::RT_STAGES;
use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use crate::library::{interface_info, LibraryInner, PipelineLibrary, PushConstantCarrier};
use crate::memory::RawBuffer;
use crate::program_group::{GroupPrograms, Program, ProgramGroup};
use crate::stack::{self, GroupRole, GroupStackSizes, StackSize, StackSizes};
use raykit_device::layout::InterfaceSizes;
use raykit_device::layout::ParamsDelivery;
use raykit_device::LaunchParams;

/// Link options (OptiX's `OptixPipelineLinkOptions`).
#[derive(Copy, Clone, Debug)]
pub struct LinkOptions {
    /// Maximum recursion depth of `trace` calls: 1 when only raygen traces.
    pub max_trace_depth: u32,
}

impl Default for LinkOptions {
    fn default() -> Self {
        LinkOptions { max_trace_depth: 1 }
    }
}

/// Values of specialization constants for [`Pipeline::with_specialization`]:
/// `u32`s by constant ID (device programs declare them as
/// `#[spec_constant(id = N, default = D)] x: u32`).
#[derive(Clone, Debug, Default)]
#[must_use]
pub struct Specialization {
    values: Vec<(u32, u32)>,
}

impl Specialization {
    /// No constants set: every program sees its defaults.
    pub fn new() -> Self {
        Specialization::default()
    }

    /// Sets constant `id` to `value` (a later value for the same ID replaces it).
    /// ID 0x72610000 is reserved by raykit and ignored here.
    pub fn set(mut self, id: u32, value: u32) -> Self {
        if id != raykit_device::exception::EXCEPTION_SLOT_SPEC_ID {
            self.values.retain(|(i, _)| *i != id);
            self.values.push((id, value));
        }
        self
    }

    /// Sets constant `id` to the bits of `value`.
    pub fn set_f32(self, id: u32, value: f32) -> Self {
        self.set(id, value.to_bits())
    }
}

/// A linked ray-tracing pipeline whose programs take launch params `P`.
pub struct Pipeline<P: LaunchParams> {
    pub(crate) inner: Arc<PipelineInner>,
    _params: PhantomData<fn(&P)>,
}

pub(crate) struct PipelineInner {
    pub(crate) ctx: Arc<ContextInner>,
    pub(crate) pipeline: vk::Pipeline,
    pub(crate) layout: vk::PipelineLayout,
    /// Group ids in pipeline order, with their kind names.
    pub(crate) groups: Vec<(u64, &'static str)>,
    /// `shaderGroupHandleSize` bytes per group, in pipeline order.
    pub(crate) handles: Vec<u8>,
    pub(crate) push_constant_size: u32,
    /// The params uniform buffer, for params over the push-constant budget.
    pub(crate) params_uniform: Option<ParamsUniform>,
    /// `maxPipelineRayRecursionDepth`.
    pub(crate) max_trace_depth: u32,
    /// Each group's role and driver-reported stack sizes, in pipeline order.
    pub(crate) group_stacks: Vec<(GroupRole, GroupStackSizes)>,
    /// The stack size every launch sets (`vkCmdSetRayTracingPipelineStackSizeKHR`).
    pub(crate) stack_size: AtomicU32,
    /// Where programs record user exceptions: one buffer per set of programs
    /// compiled together (the pipeline itself, or each linked library). Launches
    /// zero and copy them on the device (see [`crate::launch`]).
    pub(crate) exceptions: Vec<Arc<ExceptionBuffer>>,
    /// The libraries it was linked from, kept alive as long as it is.
    pub(crate) libraries: Vec<Arc<LibraryInner>>,
    /// Finished launches' exception readback buffers, reused by later launches
    /// (an allocation per launch is slow on some drivers).
    pub(crate) readbacks: Mutex<Vec<RawBuffer>>,
    /// Messages reported while it was created.
    pub(crate) log: Vec<crate::log::ValidationMessage>,
}

/// A pipeline's user-exception buffer (see `raykit_device::exception`): a
/// device buffer in the bindless table. Every launch zeroes its counter and
/// copies it into the launch's own readback buffer, on the device, so launches in
/// flight never share host-visible state.
pub(crate) struct ExceptionBuffer {
    ctx: Arc<ContextInner>,
    pub(crate) buffer: RawBuffer,
    pub(crate) slot: u32,
}

impl ExceptionBuffer {
    /// Bytes of one exception buffer.
    pub(crate) const SIZE: u64 = raykit_device::exception::EXCEPTION_BUFFER_WORDS as u64 * 4;

    pub(crate) fn new(ctx: &Arc<ContextInner>) -> Result<ExceptionBuffer> {
        let buffer = RawBuffer::new(
            ctx,
            "user exception buffer",
            Self::SIZE,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
            16,
        )?;
        let slot = ctx.buffer_table.insert(&ctx.device, buffer.buffer)?;
        Ok(ExceptionBuffer { ctx: ctx.clone(), buffer, slot })
    }

    /// The exceptions in a copy of an exception buffer: `(total thrown, records)`.
    pub(crate) fn parse(bytes: &[u8]) -> (u32, Vec<crate::error::UserException>) {
        use raykit_device::exception::{EXCEPTION_CAPACITY, EXCEPTION_RECORD_WORDS};
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
        let total = words.first().copied().unwrap_or(0);
        let stored = total.min(EXCEPTION_CAPACITY) as usize;
        let records = (0..stored)
            .filter_map(|i| {
                let at =
                    (raykit_device::exception::EXCEPTION_RECORDS_WORD + i as u32 * EXCEPTION_RECORD_WORDS) as usize;
                let r = words.get(at..at + 4)?;
                Some(crate::error::UserException { code: r[0], launch_index: [r[1], r[2], r[3]] })
            })
            .collect();
        (total, records)
    }
}

impl Drop for ExceptionBuffer {
    fn drop(&mut self) {
        self.ctx.buffer_table.remove(self.slot);
    }
}

/// A uniform buffer holding the launch params, with its descriptor set.
pub(crate) struct ParamsUniform {
    ctx: Arc<ContextInner>,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    /// Device memory, written by each launch's command buffer
    /// (`vkCmdUpdateBuffer`), so every launch carries its own params and launches in
    /// flight never share host-visible state.
    pub(crate) buffer: Option<RawBuffer>,
    /// Bytes each launch writes (the params' size rounded up to 4, as
    /// `vkCmdUpdateBuffer` requires).
    pub(crate) size: u64,
}

impl ParamsUniform {
    fn new(ctx: &Arc<ContextInner>, size: u64) -> Result<ParamsUniform> {
        let device = &ctx.device;
        let set_layout = params_set_layout(ctx)?;
        // Wrapped at once, so an early return frees what exists.
        let mut uniform = ParamsUniform {
            ctx: ctx.clone(),
            set_layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            buffer: None,
            size,
        };
        let sizes = [vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 1 }];
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        // SAFETY: valid create info on a live device.
        uniform.pool =
            unsafe { device.create_descriptor_pool(&pool_info, None) }.map_err(Error::vk("vkCreateDescriptorPool"))?;
        let layouts = [set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(uniform.pool).set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        uniform.set =
            unsafe { device.allocate_descriptor_sets(&alloc) }.map_err(Error::vk("vkAllocateDescriptorSets"))?[0];
        let buffer = RawBuffer::new(
            ctx,
            "launch params uniform buffer",
            size,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
            ctx.limits.min_uniform_buffer_offset_alignment.max(16),
        )?;
        let buffer_info = [vk::DescriptorBufferInfo { buffer: buffer.buffer, offset: 0, range: size }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(uniform.set)
            .dst_binding(raykit_device::PARAMS_BINDING)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .buffer_info(&buffer_info);
        // SAFETY: the set and buffer are alive; the set is not in use yet.
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        uniform.buffer = Some(buffer);
        Ok(uniform)
    }
}

impl Drop for ParamsUniform {
    fn drop(&mut self) {
        // SAFETY: every launch holds an `Arc` of the pipeline that owns this, and
        // waits before dropping it, so the set is idle; freeing the pool frees it.
        unsafe {
            self.ctx.device.destroy_descriptor_pool(self.pool, None);
            self.ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// How raykit delivers params of type `P`.
pub fn params_delivery<P: LaunchParams>() -> ParamsDelivery {
    if raykit_device::uses_push_constants::<P>() {
        ParamsDelivery::PushConstants
    } else {
        ParamsDelivery::UniformBuffer { set: raykit_device::PARAMS_SET, binding: raykit_device::PARAMS_BINDING }
    }
}

impl<P: LaunchParams> Pipeline<P> {
    /// Links `groups` into a pipeline. There must be a raygen group.
    pub fn new(ctx: &Context, groups: &[&ProgramGroup], options: LinkOptions) -> Result<Pipeline<P>> {
        Self::with_specialization(ctx, groups, options, &Specialization::new())
    }

    /// Links `groups` like [`Pipeline::new`], with the specialization constants
    /// in `constants` (OptiX's parameter specialization): every program's
    /// `#[spec_constant(id = N)]` parameter takes the value set for `N`, or its
    /// default. One module can so give several pipelines that behave differently,
    /// with the branches on those constants compiled away by the driver.
    pub fn with_specialization(
        ctx: &Context,
        groups: &[&ProgramGroup],
        options: LinkOptions,
        constants: &Specialization,
    ) -> Result<Pipeline<P>> {
        let inner = &ctx.inner;
        check_groups::<P>(inner, groups, options.max_trace_depth)?;
        check_linkable(groups.iter().copied())?;
        let exceptions = Arc::new(ExceptionBuffer::new(inner)?);
        let mut pipeline_inner = PipelineInner::new::<P>(inner, options.max_trace_depth)?;
        pipeline_inner.exceptions.push(exceptions.clone());
        let shaders = ShaderGroups::new(groups, exceptions.slot, constants);
        let specialization = shaders.specialization();
        let stages = shaders.stages(&specialization);
        let create_info = vk::RayTracingPipelineCreateInfoKHR::default().stages(&stages).groups(&shaders.group_infos);
        let name = format!("raykit pipeline [{}]", shaders.names().join(", "));
        let compiled = groups.iter().enumerate().map(|(i, g)| (*g, vk::Pipeline::null(), i as u32));
        pipeline_inner.create(create_info, &name, compiled)
    }

    /// Links a pipeline from `libraries` (OptiX's "program groups can be used
    /// across pipelines", on `VK_KHR_pipeline_library`): their program groups,
    /// compiled when each [`PipelineLibrary`] was made, become this pipeline's
    /// groups, so linking compiles nothing again. One library may go into many
    /// pipelines. Together the libraries need one raygen group, at most one
    /// exception group, and no group twice; every library must have been made with
    /// `options.max_trace_depth` and the same [`InterfaceSizes`]. The SBT, stack
    /// sizing and launches work as for [`Pipeline::new`].
    pub fn link(ctx: &Context, libraries: &[&PipelineLibrary<P>], options: LinkOptions) -> Result<Pipeline<P>> {
        let inner = &ctx.inner;
        if !inner.pipeline_library {
            return Err(Error::PipelineLibrariesUnsupported);
        }
        if libraries.iter().any(|l| !Arc::ptr_eq(&l.inner.ctx, inner)) {
            return Err(Error::ContextMismatch);
        }
        let interface = libraries.first().map(|l| l.inner.interface).unwrap_or_default();
        for (index, library) in libraries.iter().enumerate() {
            if library.inner.max_trace_depth != options.max_trace_depth {
                return Err(Error::LibraryMismatch {
                    what: "max_trace_depth",
                    index,
                    found: library.inner.max_trace_depth.to_string(),
                    expected: options.max_trace_depth.to_string(),
                    fix: "Give LibraryOptions::max_trace_depth the pipeline's LinkOptions::max_trace_depth.",
                });
            }
            if library.inner.interface != interface {
                return Err(Error::LibraryMismatch {
                    what: "interface",
                    index,
                    found: describe_interface(library.inner.interface),
                    expected: describe_interface(interface),
                    fix: "Make every library with LibraryOptions { interface: Some(PipelineLibrary::interface_for(&[every group of every library])), .. }.",
                });
            }
        }
        let groups: Vec<&ProgramGroup> = libraries.iter().flat_map(|l| l.inner.groups.iter()).collect();
        let mut owner: std::collections::HashMap<u64, usize> = std::collections::HashMap::new();
        for (index, library) in libraries.iter().enumerate() {
            for group in &library.inner.groups {
                if let Some(first) = owner.insert(group.id, index) {
                    return Err(Error::GroupInSeveralLibraries { kind: group.kind_name(), first, second: index });
                }
            }
        }
        check_linkable(groups.iter().copied())?;
        let mut pipeline_inner = PipelineInner::new::<P>(inner, options.max_trace_depth)?;
        pipeline_inner.exceptions = libraries.iter().map(|l| l.inner.exceptions.clone()).collect();
        pipeline_inner.libraries = libraries.iter().map(|l| l.inner.clone()).collect();
        let library_pipelines: Vec<vk::Pipeline> = libraries.iter().map(|l| l.inner.pipeline).collect();
        let library_info = vk::PipelineLibraryCreateInfoKHR::default().libraries(&library_pipelines);
        let interface_create = interface_info(interface);
        // lavapipe gives push constants only to pipelines that compile a stage
        // themselves (see `crate::library`); give it one that does nothing.
        let carrier = if inner.lavapipe { Some(PushConstantCarrier::new(inner)?) } else { None };
        let carrier_stage: Vec<vk::PipelineShaderStageCreateInfo<'_>> =
            carrier.iter().map(PushConstantCarrier::stage).collect();
        let create_info = vk::RayTracingPipelineCreateInfoKHR::default()
            .stages(&carrier_stage)
            .library_info(&library_info)
            .library_interface(&interface_create);
        let name = format!("raykit pipeline linked from {} libraries", libraries.len());
        let compiled = libraries
            .iter()
            .flat_map(|l| l.inner.groups.iter().enumerate().map(|(i, g)| (g, l.inner.pipeline, i as u32)));
        pipeline_inner.create(create_info, &name, compiled)
    }

    /// The stack sizes the driver reports for `group`'s shaders in this pipeline
    /// (`vkGetRayTracingShaderGroupStackSizeKHR`; OptiX's
    /// `optixProgramGroupGetStackSize`). Vulkan knows them only once the group is
    /// linked, hence a pipeline method.
    pub fn group_stack_sizes(&self, group: &ProgramGroup) -> Result<GroupStackSizes> {
        let index = self.group_index(group).ok_or(Error::GroupNotInPipeline { kind: group.kind_name() })?;
        Ok(self.inner.group_stacks[index].1)
    }

    /// Every group's role and stack sizes, in the order the groups were linked.
    pub fn all_group_stack_sizes(&self) -> Vec<(GroupRole, GroupStackSizes)> {
        self.inner.group_stacks.clone()
    }

    /// The maxima of the groups' stack sizes by program kind: the input of
    /// [`stack::conservative`], [`stack::refined`] and [`stack::vulkan_default`].
    pub fn stack_sizes(&self) -> StackSizes {
        StackSizes::from_groups(self.inner.group_stacks.iter().copied())
    }

    /// What the validation layer reported while the pipeline was linked (OptiX's
    /// log string of `optixPipelineCreate`); see [`crate::log`].
    pub fn creation_log(&self) -> &[crate::log::ValidationMessage] {
        &self.inner.log
    }

    /// The pipeline's `max_trace_depth` (`maxPipelineRayRecursionDepth`).
    pub fn max_trace_depth(&self) -> u32 {
        self.inner.max_trace_depth
    }

    /// The stack size Vulkan defines for this pipeline were it made without the
    /// dynamic stack-size state ([`stack::vulkan_default`]).
    pub fn driver_default_stack_size(&self) -> u64 {
        stack::vulkan_default(&self.stack_sizes(), self.inner.max_trace_depth)
    }

    /// The size `choice` gives for this pipeline, in bytes, without setting it.
    pub fn compute_stack_size(&self, choice: &StackSize<'_>) -> Result<u32> {
        let max_depth = self.inner.max_trace_depth;
        let check_depth = |depth: u32| -> Result<()> {
            if depth > max_depth {
                return Err(Error::StackSize {
                    reason: format!("the estimate's trace depth {depth} is over the pipeline's max_trace_depth {max_depth}; raise LinkOptions::max_trace_depth or lower the estimate's"),
                });
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
            StackSize::Explicit(bytes) => u64::from(*bytes),
        };
        stack_bytes(bytes)
    }

    /// Chooses the stack size every later launch sets
    /// (`vkCmdSetRayTracingPipelineStackSizeKHR`; OptiX's
    /// `optixPipelineSetStackSize`) and returns it in bytes. Until called, launches
    /// use [`StackSize::DriverDefault`].
    pub fn set_stack_size(&self, choice: &StackSize<'_>) -> Result<u32> {
        let bytes = self.compute_stack_size(choice)?;
        self.inner.stack_size.store(bytes, Ordering::Relaxed);
        Ok(bytes)
    }

    /// The stack size launches set, in bytes.
    pub fn stack_size(&self) -> u32 {
        self.inner.stack_size.load(Ordering::Relaxed)
    }

    /// How this pipeline delivers its params: push constants, or a uniform buffer
    /// for params over [`PUSH_CONSTANT_BUDGET`](raykit_device::PUSH_CONSTANT_BUDGET) bytes.
    pub fn params_delivery(&self) -> ParamsDelivery {
        params_delivery::<P>()
    }

    /// The position of `group` in this pipeline, if it was linked into it.
    pub(crate) fn group_index(&self, group: &ProgramGroup) -> Option<usize> {
        self.inner.groups.iter().position(|(id, _)| *id == group.id)
    }
}

fn describe_interface(sizes: InterfaceSizes) -> String {
    format!("an interface of {} B of ray payload and {} B of hit attributes", sizes.payload, sizes.hit_attributes)
}

/// What every set of program groups compiled together (a pipeline or a library)
/// must satisfy: one context, a trace depth within the device's limit, and
/// every program's params block laid out as `P` (OptiX's rule that all modules
/// agree on their `PipelineCompileOptions`).
pub(crate) fn check_groups<P: LaunchParams>(
    inner: &Arc<ContextInner>,
    groups: &[&ProgramGroup],
    max_trace_depth: u32,
) -> Result<()> {
    let limits = inner.limits;
    if max_trace_depth > limits.max_ray_recursion_depth {
        return Err(Error::TraceDepthTooLarge { requested: max_trace_depth, limit: limits.max_ray_recursion_depth });
    }
    if groups.iter().any(|g| !Arc::ptr_eq(&g.ctx, inner)) {
        return Err(Error::ContextMismatch);
    }
    let params_size = std::mem::size_of::<P>();
    let delivery = params_delivery::<P>();
    // Launches write uniform params with `vkCmdUpdateBuffer`, which takes at most 65536 bytes.
    let uniform_limit = limits.max_uniform_buffer_range.min(65536);
    if delivery != ParamsDelivery::PushConstants && params_size > uniform_limit as usize {
        return Err(Error::ParamsTooLarge { size: params_size, limit: uniform_limit });
    }
    for group in groups {
        for program in group.programs() {
            let Some(info) = program.entry_info() else { continue };
            if !info.params.is_empty() {
                raykit_device::layout::check(&P::LAYOUT, &info.name, &info.params, delivery)?;
            }
        }
    }
    Ok(())
}

/// What the groups of a launchable pipeline must have: a raygen group, and at
/// most one exception group.
fn check_linkable<'g>(groups: impl Iterator<Item = &'g ProgramGroup> + Clone) -> Result<()> {
    if groups.clone().filter(|g| matches!(g.programs, GroupPrograms::Exception(_))).count() > 1 {
        return Err(Error::SeveralExceptionPrograms);
    }
    if !groups.clone().any(|g| matches!(g.programs, GroupPrograms::Raygen(_))) {
        return Err(Error::NoRaygen);
    }
    Ok(())
}

/// The params uniform buffer, when `P` is over the push-constant budget.
fn new_params_uniform<P: LaunchParams>(inner: &Arc<ContextInner>) -> Result<Option<ParamsUniform>> {
    match params_delivery::<P>() {
        ParamsDelivery::PushConstants => Ok(None),
        ParamsDelivery::UniformBuffer { .. } => {
            Ok(Some(ParamsUniform::new(inner, (std::mem::size_of::<P>() as u64).next_multiple_of(4))?))
        }
    }
}

/// The set layout of the params uniform buffer (set 1).
pub(crate) fn params_set_layout(inner: &ContextInner) -> Result<vk::DescriptorSetLayout> {
    let bindings = [vk::DescriptorSetLayoutBinding::default()
        .binding(raykit_device::PARAMS_BINDING)
        .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
        .descriptor_count(1)
        .stage_flags(RT_STAGES)];
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    // SAFETY: valid create info on a live device.
    unsafe { inner.device.create_descriptor_set_layout(&info, None) }.map_err(Error::vk("vkCreateDescriptorSetLayout"))
}

/// The pipeline layout for params `P`: the bindless table at set 0, and either a
/// push-constant range or `params_set` (the uniform's set layout) at set 1.
/// Pipelines and libraries made for the same `P` get compatible layouts, as
/// linking requires.
pub(crate) fn create_layout<P: LaunchParams>(
    inner: &ContextInner,
    params_set: Option<vk::DescriptorSetLayout>,
) -> Result<vk::PipelineLayout> {
    let mut set_layouts = vec![inner.buffer_table.layout];
    set_layouts.extend(params_set);
    let push_constant_size = if params_set.is_some() { 0 } else { std::mem::size_of::<P>() as u32 };
    let push_ranges = [vk::PushConstantRange { stage_flags: RT_STAGES, offset: 0, size: push_constant_size }];
    let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
    if push_constant_size > 0 {
        layout_info = layout_info.push_constant_ranges(&push_ranges);
    }
    // SAFETY: valid create info; the set layouts outlive the layout's users.
    let layout = unsafe { inner.device.create_pipeline_layout(&layout_info, None) }
        .map_err(Error::vk("vkCreatePipelineLayout"))?;
    inner.set_name(layout, "raykit pipeline layout");
    Ok(layout)
}

/// Creates one ray-tracing pipeline (or library) through the context's pipeline
/// cache; returns it with what was reported during the call.
pub(crate) fn create_ray_tracing_pipeline(
    inner: &ContextInner,
    create_info: &vk::RayTracingPipelineCreateInfoKHR<'_>,
) -> Result<(vk::Pipeline, Vec<crate::log::ValidationMessage>)> {
    let (pipelines, log) = crate::log::capture(|| {
        // SAFETY: the callers' create infos are valid: every stage's module is
        // alive, libraries are live pipeline libraries of this device, and the
        // recursion depth was checked against the device limit.
        unsafe {
            inner.rt.create_ray_tracing_pipelines(
                vk::DeferredOperationKHR::null(),
                inner.pipeline_cache.handle,
                std::slice::from_ref(create_info),
                None,
            )
        }
    });
    match pipelines {
        Ok(p) => Ok((p[0], log)),
        Err((p, e)) => {
            for pipeline in p.into_iter().filter(|p| *p != vk::Pipeline::null()) {
                // SAFETY: never used.
                unsafe { inner.device.destroy_pipeline(pipeline, None) };
            }
            Err(Error::vk("vkCreateRayTracingPipelinesKHR")(e))
        }
    }
}

/// The shader stages and groups of a set of program groups compiled together,
/// with the specialization every stage gets: the exception buffer's slot and
/// the user's constants.
pub(crate) struct ShaderGroups {
    programs: Vec<Program>,
    pub(crate) group_infos: Vec<vk::RayTracingShaderGroupCreateInfoKHR<'static>>,
    spec_data: Vec<u8>,
    spec_entries: Vec<vk::SpecializationMapEntry>,
}

impl ShaderGroups {
    pub(crate) fn new(groups: &[&ProgramGroup], exception_slot: u32, constants: &Specialization) -> ShaderGroups {
        // One shader stage per program; groups refer to stages by index.
        let mut programs: Vec<Program> = Vec::new();
        let mut stage_index = |p: Option<&Program>| -> u32 {
            match p {
                Some(p) => {
                    programs.push(p.clone());
                    programs.len() as u32 - 1
                }
                None => vk::SHADER_UNUSED_KHR,
            }
        };
        let mut group_infos = Vec::with_capacity(groups.len());
        for group in groups {
            let info = match &group.programs {
                GroupPrograms::Raygen(p)
                | GroupPrograms::Miss(p)
                | GroupPrograms::Callable(p)
                | GroupPrograms::Exception(p) => vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
                    .general_shader(stage_index(Some(p)))
                    .closest_hit_shader(vk::SHADER_UNUSED_KHR)
                    .any_hit_shader(vk::SHADER_UNUSED_KHR)
                    .intersection_shader(vk::SHADER_UNUSED_KHR),
                GroupPrograms::Hit { closest_hit, any_hit, intersection } => {
                    let ty = if intersection.is_some() {
                        vk::RayTracingShaderGroupTypeKHR::PROCEDURAL_HIT_GROUP
                    } else {
                        vk::RayTracingShaderGroupTypeKHR::TRIANGLES_HIT_GROUP
                    };
                    vk::RayTracingShaderGroupCreateInfoKHR::default()
                        .ty(ty)
                        .general_shader(vk::SHADER_UNUSED_KHR)
                        .closest_hit_shader(stage_index(closest_hit.as_ref()))
                        .any_hit_shader(stage_index(any_hit.as_ref()))
                        .intersection_shader(stage_index(intersection.as_ref()))
                }
            };
            group_infos.push(info);
        }
        // The user-exception buffer's slot, for every program as a specialization
        // constant (modules without that constant ignore it).
        let mut values = vec![(raykit_device::exception::EXCEPTION_SLOT_SPEC_ID, exception_slot)];
        values.extend(constants.values.iter().copied());
        let spec_data: Vec<u8> = values.iter().flat_map(|(_, v)| v.to_ne_bytes()).collect();
        let spec_entries: Vec<vk::SpecializationMapEntry> = values
            .iter()
            .enumerate()
            .map(|(i, (id, _))| vk::SpecializationMapEntry {
                constant_id: *id,
                offset: (i * std::mem::size_of::<u32>()) as u32,
                size: std::mem::size_of::<u32>(),
            })
            .collect();
        ShaderGroups { programs, group_infos, spec_data, spec_entries }
    }

    /// The specialization every stage gets; it borrows `self`.
    pub(crate) fn specialization(&self) -> vk::SpecializationInfo<'_> {
        vk::SpecializationInfo::default().map_entries(&self.spec_entries).data(&self.spec_data)
    }

    /// One stage create info per program, each with `specialization`.
    pub(crate) fn stages<'a>(
        &'a self,
        specialization: &'a vk::SpecializationInfo<'a>,
    ) -> Vec<vk::PipelineShaderStageCreateInfo<'a>> {
        self.programs
            .iter()
            .map(|p| {
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(stage_flag(p.kind))
                    .module(p.module.shader)
                    .name(&p.name)
                    .specialization_info(specialization)
            })
            .collect()
    }

    /// The programs' entry-point names, for debug names.
    pub(crate) fn names(&self) -> Vec<&str> {
        self.programs.iter().filter_map(|p| p.name.to_str().ok()).collect()
    }
}

impl PipelineInner {
    /// A pipeline for params `P`, not created yet: its params uniform buffer
    /// (for params over the push-constant budget) and layout.
    fn new<P: LaunchParams>(inner: &Arc<ContextInner>, max_trace_depth: u32) -> Result<PipelineInner> {
        let params_uniform = new_params_uniform::<P>(inner)?;
        let layout = create_layout::<P>(inner, params_uniform.as_ref().map(|u| u.set_layout))?;
        Ok(PipelineInner {
            ctx: inner.clone(),
            pipeline: vk::Pipeline::null(),
            layout,
            groups: Vec::new(),
            handles: Vec::new(),
            push_constant_size: if params_uniform.is_some() { 0 } else { std::mem::size_of::<P>() as u32 },
            params_uniform,
            max_trace_depth,
            group_stacks: Vec::new(),
            stack_size: AtomicU32::new(0),
            exceptions: Vec::new(),
            libraries: Vec::new(),
            readbacks: Mutex::new(Vec::new()),
            log: Vec::new(),
        })
    }

    /// Creates the pipeline from `create_info` (its stages, groups and libraries),
    /// with this pipeline's layout, recursion depth and the dynamic stack-size
    /// state, names it `name`, and reads its groups (see [`PipelineInner::finish`]).
    fn create<'g, P: LaunchParams>(
        mut self,
        create_info: vk::RayTracingPipelineCreateInfoKHR<'_>,
        name: &str,
        compiled: impl Iterator<Item = (&'g ProgramGroup, vk::Pipeline, u32)>,
    ) -> Result<Pipeline<P>> {
        // The stack size is set by every launch (see `crate::stack`).
        let dynamic_states = [vk::DynamicState::RAY_TRACING_PIPELINE_STACK_SIZE_KHR];
        let dynamic_state = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let create_info = create_info
            .max_pipeline_ray_recursion_depth(self.max_trace_depth)
            .dynamic_state(&dynamic_state)
            .layout(self.layout);
        let (pipeline, log) = create_ray_tracing_pipeline(&self.ctx, &create_info)?;
        self.pipeline = pipeline;
        self.log = log;
        self.ctx.set_name(pipeline, name);
        self.finish(compiled)?;
        Ok(Pipeline { inner: Arc::new(self), _params: PhantomData })
    }

    /// Reads the created pipeline's group handles and stack sizes, for `groups`
    /// in pipeline order, and sets the default stack size. Each group's stack
    /// sizes are asked of the pipeline that compiled it (`self`, or a library)
    /// at its index there, as `vkGetRayTracingShaderGroupStackSizeKHR` requires.
    fn finish<'g>(&mut self, groups: impl Iterator<Item = (&'g ProgramGroup, vk::Pipeline, u32)>) -> Result<()> {
        let compiled: Vec<(&ProgramGroup, vk::Pipeline, u32)> = groups.collect();
        let groups: Vec<&ProgramGroup> = compiled.iter().map(|(g, _, _)| *g).collect();
        self.groups = groups.iter().map(|g| (g.id, g.kind_name())).collect();
        let handle_size = self.ctx.limits.shader_group_handle_size as usize;
        // SAFETY: `self.pipeline` is live and has exactly `groups.len()` groups.
        self.handles = unsafe {
            self.ctx.rt.get_ray_tracing_shader_group_handles(
                self.pipeline,
                0,
                groups.len() as u32,
                groups.len() * handle_size,
            )
        }
        .map_err(Error::vk("vkGetRayTracingShaderGroupHandlesKHR"))?;
        for (group, pipeline, index) in &compiled {
            let pipeline = if *pipeline == vk::Pipeline::null() { self.pipeline } else { *pipeline };
            let sizes = query_group_stack_sizes(&self.ctx, pipeline, *index, &group.programs);
            self.group_stacks.push((group_role(&group.programs), sizes));
        }
        let default =
            stack::vulkan_default(&StackSizes::from_groups(self.group_stacks.iter().copied()), self.max_trace_depth);
        self.stack_size = AtomicU32::new(stack_bytes(default)?);
        Ok(())
    }
}

/// A stack size as `vkCmdSetRayTracingPipelineStackSizeKHR` takes it.
fn stack_bytes(bytes: u64) -> Result<u32> {
    u32::try_from(bytes)
        .map_err(|_| Error::StackSize { reason: format!("{bytes} bytes do not fit the 32 bits Vulkan takes") })
}

/// How a group counts in the stack formulas; callables by their OptiX prefix.
fn group_role(programs: &GroupPrograms) -> GroupRole {
    match programs {
        GroupPrograms::Raygen(_) => GroupRole::Raygen,
        GroupPrograms::Miss(_) => GroupRole::Miss,
        GroupPrograms::Hit { .. } => GroupRole::Hit,
        GroupPrograms::Exception(_) => GroupRole::DirectCallable,
        GroupPrograms::Callable(p) => {
            let name = p.name.to_bytes();
            if name.starts_with(b"__direct_callable__") {
                GroupRole::DirectCallable
            } else if name.starts_with(b"__continuation_callable__") {
                GroupRole::ContinuationCallable
            } else {
                GroupRole::Callable
            }
        }
    }
}

/// The driver's stack sizes of group `index` of `pipeline`, for the shaders it has.
fn query_group_stack_sizes(
    ctx: &ContextInner,
    pipeline: vk::Pipeline,
    index: u32,
    programs: &GroupPrograms,
) -> GroupStackSizes {
    let query = |shader: vk::ShaderGroupShaderKHR| -> u64 {
        // SAFETY: `index` is a group of the live `pipeline`, which has a shader of
        // kind `shader` (only those are asked for).
        unsafe { ctx.rt.get_ray_tracing_shader_group_stack_size(pipeline, index, shader) }
    };
    match programs {
        GroupPrograms::Raygen(_)
        | GroupPrograms::Miss(_)
        | GroupPrograms::Callable(_)
        | GroupPrograms::Exception(_) => {
            GroupStackSizes { general: query(vk::ShaderGroupShaderKHR::GENERAL), ..Default::default() }
        }
        GroupPrograms::Hit { closest_hit, any_hit, intersection } => GroupStackSizes {
            general: 0,
            closest_hit: if closest_hit.is_some() { query(vk::ShaderGroupShaderKHR::CLOSEST_HIT) } else { 0 },
            any_hit: if any_hit.is_some() { query(vk::ShaderGroupShaderKHR::ANY_HIT) } else { 0 },
            intersection: if intersection.is_some() { query(vk::ShaderGroupShaderKHR::INTERSECTION) } else { 0 },
        },
    }
}

fn stage_flag(kind: raykit_device::ProgramKind) -> vk::ShaderStageFlags {
    use raykit_device::ProgramKind as K;
    match kind {
        K::Raygen => vk::ShaderStageFlags::RAYGEN_KHR,
        K::Miss => vk::ShaderStageFlags::MISS_KHR,
        K::ClosestHit => vk::ShaderStageFlags::CLOSEST_HIT_KHR,
        K::AnyHit => vk::ShaderStageFlags::ANY_HIT_KHR,
        K::Intersection => vk::ShaderStageFlags::INTERSECTION_KHR,
        K::Callable | K::Exception => vk::ShaderStageFlags::CALLABLE_KHR,
    }
}

impl Drop for PipelineInner {
    fn drop(&mut self) {
        // SAFETY: SBTs and launches in flight hold an `Arc` to this, and a launch
        // waits for its work before it is dropped, so the pipeline is idle.
        unsafe {
            if self.pipeline != vk::Pipeline::null() {
                self.ctx.device.destroy_pipeline(self.pipeline, None);
            }
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
