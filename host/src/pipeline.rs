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
//! See [`vkCreateRayTracingPipelinesKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateRayTracingPipelinesKHR.html).

use std::marker::PhantomData;
use std::sync::{Arc, Mutex};

use ash::vk;

use crate::buffer_table::RT_STAGES;
use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use raykit_device::layout::ParamsDelivery;
use crate::memory::RawBuffer;
use crate::program_group::{GroupPrograms, Program, ProgramGroup};
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
    /// Where programs record user exceptions; launches hold the lock.
    pub(crate) exceptions: Mutex<ExceptionBuffer>,
}

/// A pipeline's user-exception buffer (see `raykit_device::exception`): a
/// host-visible buffer in the bindless table.
pub(crate) struct ExceptionBuffer {
    ctx: Arc<ContextInner>,
    pub(crate) buffer: RawBuffer,
    pub(crate) slot: u32,
}

impl ExceptionBuffer {
    fn new(ctx: &Arc<ContextInner>) -> Result<ExceptionBuffer> {
        let size = raykit_device::exception::EXCEPTION_BUFFER_WORDS as u64 * 4;
        let buffer = RawBuffer::new(
            ctx,
            "user exception buffer",
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            gpu_allocator::MemoryLocation::GpuToCpu,
            16,
        )?;
        let slot = ctx.buffer_table.insert(&ctx.device, buffer.buffer)?;
        Ok(ExceptionBuffer { ctx: ctx.clone(), buffer, slot })
    }

    /// Zeroes the counter before a launch.
    pub(crate) fn reset(&mut self) -> Result<()> {
        self.buffer.write_bytes(&0u32.to_ne_bytes())
    }

    /// The exceptions recorded by the last launch: `(total thrown, records)`.
    pub(crate) fn read(&self) -> (u32, Vec<crate::error::UserException>) {
        use raykit_device::exception::{EXCEPTION_CAPACITY, EXCEPTION_RECORD_WORDS};
        let Some(bytes) = self.buffer.mapped() else { return (0, Vec::new()) };
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(bytes);
        let total = words.first().copied().unwrap_or(0);
        let stored = total.min(EXCEPTION_CAPACITY) as usize;
        let records = (0..stored)
            .filter_map(|i| {
                let at = 1 + i * EXCEPTION_RECORD_WORDS as usize;
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
    /// Host-visible; written before each launch, under the lock (launches of one
    /// pipeline from several threads take turns).
    pub(crate) buffer: Mutex<Option<RawBuffer>>,
}

impl ParamsUniform {
    fn new(ctx: &Arc<ContextInner>, size: u64) -> Result<ParamsUniform> {
        let device = &ctx.device;
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(raykit_device::PARAMS_BINDING)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .descriptor_count(1)
            .stage_flags(RT_STAGES)];
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device.
        let set_layout = unsafe { device.create_descriptor_set_layout(&info, None) }
            .map_err(Error::vk("vkCreateDescriptorSetLayout"))?;
        // Wrapped at once, so an early return frees what exists.
        let mut uniform = ParamsUniform {
            ctx: ctx.clone(),
            set_layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            buffer: Mutex::new(None),
        };
        let sizes = [vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 1 }];
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        // SAFETY: valid create info on a live device.
        uniform.pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .map_err(Error::vk("vkCreateDescriptorPool"))?;
        let layouts = [set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(uniform.pool).set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        uniform.set = unsafe { device.allocate_descriptor_sets(&alloc) }.map_err(Error::vk("vkAllocateDescriptorSets"))?[0];
        let buffer = RawBuffer::new(
            ctx,
            "launch params uniform buffer",
            size,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            gpu_allocator::MemoryLocation::CpuToGpu,
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
        uniform.buffer = Mutex::new(Some(buffer));
        Ok(uniform)
    }
}

impl Drop for ParamsUniform {
    fn drop(&mut self) {
        // SAFETY: launches are blocking, so the set is idle; freeing the pool frees it.
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
        let inner = &ctx.inner;
        let limits = inner.limits;
        if options.max_trace_depth > limits.max_ray_recursion_depth {
            return Err(Error::TraceDepthTooLarge {
                requested: options.max_trace_depth,
                limit: limits.max_ray_recursion_depth,
            });
        }
        if groups.iter().any(|g| !Arc::ptr_eq(&g.ctx, inner)) {
            return Err(Error::ContextMismatch);
        }
        if !groups.iter().any(|g| matches!(g.programs, GroupPrograms::Raygen(_))) {
            return Err(Error::NoRaygen);
        }
        let params_size = std::mem::size_of::<P>();
        let delivery = params_delivery::<P>();
        if delivery != ParamsDelivery::PushConstants && params_size > limits.max_uniform_buffer_range as usize {
            return Err(Error::ParamsTooLarge { size: params_size, limit: limits.max_uniform_buffer_range });
        }
        // OptiX's rule that all modules agree on the compile options: every
        // program's params block must be `P`, laid out as on the host.
        for group in groups {
            for program in group.programs() {
                let name = program.name.to_string_lossy();
                let Some(info) = program.module.entry_points.iter().find(|e| e.name == name) else { continue };
                if !info.params.is_empty() {
                    raykit_device::layout::check(&P::LAYOUT, &name, &info.params, delivery)?;
                }
            }
        }

        // One shader stage per program; groups refer to stages by index.
        let mut programs: Vec<Program> = Vec::new();
        let mut stage_index = |p: &Option<Program>| -> u32 {
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
                GroupPrograms::Raygen(p) | GroupPrograms::Miss(p) | GroupPrograms::Callable(p) => vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
                    .general_shader(stage_index(&Some(p.clone())))
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
                        .closest_hit_shader(stage_index(closest_hit))
                        .any_hit_shader(stage_index(any_hit))
                        .intersection_shader(stage_index(intersection))
                }
            };
            group_infos.push(info);
        }
        // The user-exception buffer, and its slot for every program as a
        // specialization constant (modules without that constant ignore it).
        let exceptions = ExceptionBuffer::new(inner)?;
        let slot_bytes = exceptions.slot.to_ne_bytes();
        let spec_entries = [vk::SpecializationMapEntry {
            constant_id: raykit_device::exception::EXCEPTION_SLOT_SPEC_ID,
            offset: 0,
            size: std::mem::size_of::<u32>(),
        }];
        let specialization = vk::SpecializationInfo::default().map_entries(&spec_entries).data(&slot_bytes);
        let stages: Vec<vk::PipelineShaderStageCreateInfo<'_>> = programs
            .iter()
            .map(|p| {
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(stage_flag(p.kind))
                    .module(p.module.shader)
                    .name(&p.name)
                    .specialization_info(&specialization)
            })
            .collect();

        let params_uniform = match delivery {
            ParamsDelivery::PushConstants => None,
            ParamsDelivery::UniformBuffer { .. } => Some(ParamsUniform::new(inner, params_size as u64)?),
        };
        let mut set_layouts = vec![inner.buffer_table.layout];
        if let Some(uniform) = &params_uniform {
            set_layouts.push(uniform.set_layout);
        }
        let push_constant_size = if params_uniform.is_some() { 0 } else { params_size as u32 };
        let push_ranges = [vk::PushConstantRange { stage_flags: RT_STAGES, offset: 0, size: push_constant_size }];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_constant_size > 0 {
            layout_info = layout_info.push_constant_ranges(&push_ranges);
        }
        // SAFETY: valid create info; the set layouts live as long as the pipeline.
        let layout = unsafe { inner.device.create_pipeline_layout(&layout_info, None) }
            .map_err(Error::vk("vkCreatePipelineLayout"))?;
        let mut pipeline_inner = PipelineInner {
            ctx: inner.clone(),
            pipeline: vk::Pipeline::null(),
            layout,
            groups: groups.iter().map(|g| (g.id, g.kind_name())).collect(),
            handles: Vec::new(),
            push_constant_size,
            params_uniform,
            exceptions: Mutex::new(exceptions),
        };

        let create_info = [vk::RayTracingPipelineCreateInfoKHR::default()
            .stages(&stages)
            .groups(&group_infos)
            .max_pipeline_ray_recursion_depth(options.max_trace_depth)
            .layout(layout)];
        // SAFETY: every stage's module is alive (held by `programs`); the create
        // info is valid; the recursion depth was checked against the device limit.
        let pipelines = unsafe {
            inner.rt.create_ray_tracing_pipelines(
                vk::DeferredOperationKHR::null(),
                vk::PipelineCache::null(),
                &create_info,
                None,
            )
        };
        let pipeline = match pipelines {
            Ok(p) => p[0],
            Err((p, e)) => {
                for pipeline in p.into_iter().filter(|p| *p != vk::Pipeline::null()) {
                    // SAFETY: never used.
                    unsafe { inner.device.destroy_pipeline(pipeline, None) };
                }
                return Err(Error::vk("vkCreateRayTracingPipelinesKHR")(e));
            }
        };
        pipeline_inner.pipeline = pipeline;
        let handle_size = inner.limits.shader_group_handle_size as usize;
        // SAFETY: `pipeline` has exactly `groups.len()` groups.
        pipeline_inner.handles = unsafe {
            inner.rt.get_ray_tracing_shader_group_handles(pipeline, 0, groups.len() as u32, groups.len() * handle_size)
        }
        .map_err(Error::vk("vkGetRayTracingShaderGroupHandlesKHR"))?;
        Ok(Pipeline { inner: Arc::new(pipeline_inner), _params: PhantomData })
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

fn stage_flag(kind: raykit_device::ProgramKind) -> vk::ShaderStageFlags {
    use raykit_device::ProgramKind as K;
    match kind {
        K::Raygen => vk::ShaderStageFlags::RAYGEN_KHR,
        K::Miss => vk::ShaderStageFlags::MISS_KHR,
        K::ClosestHit => vk::ShaderStageFlags::CLOSEST_HIT_KHR,
        K::AnyHit => vk::ShaderStageFlags::ANY_HIT_KHR,
        K::Intersection => vk::ShaderStageFlags::INTERSECTION_KHR,
        K::Callable => vk::ShaderStageFlags::CALLABLE_KHR,
    }
}

impl Drop for PipelineInner {
    fn drop(&mut self) {
        // SAFETY: launches are blocking, so the pipeline is idle; SBTs made for it
        // hold an `Arc` to it.
        unsafe {
            if self.pipeline != vk::Pipeline::null() {
                self.ctx.device.destroy_pipeline(self.pipeline, None);
            }
            self.ctx.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
