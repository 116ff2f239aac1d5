//! Pipelines: program groups linked into a Vulkan ray-tracing pipeline, OptiX's
//! `optixPipelineCreate`.
//!
//! A [`Pipeline<P>`] is typed by its launch params `P`: the pipeline layout's
//! push-constant range is `size_of::<P>()`, and [`Pipeline::launch`] takes a `&P`.
//! Every program sees the context's bindless buffer table at set 0, binding 0.
//! See [`vkCreateRayTracingPipelinesKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateRayTracingPipelinesKHR.html).

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;

use crate::buffer_table::RT_STAGES;
use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use crate::program_group::{GroupPrograms, Program, ProgramGroup};

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
pub struct Pipeline<P: bytemuck::Pod> {
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
}

impl<P: bytemuck::Pod> Pipeline<P> {
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
        if params_size > limits.max_push_constants_size as usize {
            return Err(Error::ParamsTooLarge { size: params_size, limit: limits.max_push_constants_size });
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
                GroupPrograms::Raygen(p) | GroupPrograms::Miss(p) => vk::RayTracingShaderGroupCreateInfoKHR::default()
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
        let stages: Vec<vk::PipelineShaderStageCreateInfo<'_>> = programs
            .iter()
            .map(|p| {
                vk::PipelineShaderStageCreateInfo::default().stage(stage_flag(p.kind)).module(p.module.shader).name(&p.name)
            })
            .collect();

        let set_layouts = [inner.buffer_table.layout];
        let push_ranges = [vk::PushConstantRange { stage_flags: RT_STAGES, offset: 0, size: params_size as u32 }];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if params_size > 0 {
            layout_info = layout_info.push_constant_ranges(&push_ranges);
        }
        // SAFETY: valid create info; the set layout lives as long as the context.
        let layout = unsafe { inner.device.create_pipeline_layout(&layout_info, None) }
            .map_err(Error::vk("vkCreatePipelineLayout"))?;
        let mut pipeline_inner = PipelineInner {
            ctx: inner.clone(),
            pipeline: vk::Pipeline::null(),
            layout,
            groups: groups.iter().map(|g| (g.id, g.kind_name())).collect(),
            handles: Vec::new(),
            push_constant_size: params_size as u32,
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
