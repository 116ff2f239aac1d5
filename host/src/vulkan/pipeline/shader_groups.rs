//! Program groups as Vulkan takes them: shader stages, shader groups and the
//! specialization every stage gets
//! ([`VkRayTracingShaderGroupCreateInfoKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkRayTracingShaderGroupCreateInfoKHR.html)),
//! the rules a set of groups compiled together must follow, and what the driver
//! reports for each group once it is linked (handle and stack sizes).

use ash::vk;

use crate::stack::{GroupRole, GroupStackSizes, StackSizes};
use crate::types::group::GroupKind;
use crate::types::specialization::Specialization;
use crate::vulkan::context::ContextInner;
use crate::vulkan::conv;
use crate::vulkan::module::{SpirvGroup, SpirvGroupPrograms, SpirvProgram};

/// The shader stages and groups of a set of program groups compiled together,
/// with the specialization every stage gets: the exception buffer's slot, the
/// pipeline's `max_trace_depth` and the user's constants.
pub(crate) struct ShaderGroups {
    programs: Vec<SpirvProgram>,
    pub(crate) group_infos: Vec<vk::RayTracingShaderGroupCreateInfoKHR<'static>>,
    spec_data: Vec<u8>,
    spec_entries: Vec<vk::SpecializationMapEntry>,
}

impl ShaderGroups {
    pub(crate) fn new(
        groups: &[&SpirvGroup],
        exception_slot: u32,
        max_trace_depth: u32,
        constants: &Specialization,
    ) -> ShaderGroups {
        // One shader stage per program; groups refer to stages by index.
        let mut programs: Vec<SpirvProgram> = Vec::new();
        let mut stage_index = |p: Option<&SpirvProgram>| -> u32 {
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
                SpirvGroupPrograms::Raygen(p)
                | SpirvGroupPrograms::Miss(p)
                | SpirvGroupPrograms::Callable(p)
                | SpirvGroupPrograms::Exception(p) => vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
                    .general_shader(stage_index(Some(p)))
                    .closest_hit_shader(vk::SHADER_UNUSED_KHR)
                    .any_hit_shader(vk::SHADER_UNUSED_KHR)
                    .intersection_shader(vk::SHADER_UNUSED_KHR),
                SpirvGroupPrograms::Hit { closest_hit, any_hit, intersection } => {
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
        // The user-exception buffer's slot and the pipeline's max_trace_depth (which
        // miss and closest-hit programs check their traces against), for every
        // program as specialization constants (modules without them ignore them).
        let mut values = vec![
            (raykit_device::exception::EXCEPTION_SLOT_SPEC_ID, exception_slot),
            (raykit_device::exception::MAX_TRACE_DEPTH_SPEC_ID, max_trace_depth),
        ];
        values.extend(constants.values().iter().copied());
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

    /// The values of the specialization constants every stage gets, by constant ID.
    pub(crate) fn spec_values(&self) -> Vec<(u32, u32)> {
        self.spec_entries
            .iter()
            .filter_map(|e| {
                let at = e.offset as usize;
                let bytes = self.spec_data.get(at..at + 4)?;
                Some((e.constant_id, u32::from_ne_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])))
            })
            .collect()
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
                    .stage(conv::stage(p.kind))
                    .module(p.module().map_or(vk::ShaderModule::null(), |m| m.shader))
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

/// A group of a pipeline being created, and where it was compiled: its index in
/// the pipeline (or library) that compiled it.
pub(crate) struct CompiledGroup<'g> {
    pub(crate) group: &'g SpirvGroup,
    /// The library that compiled it; `None` when the pipeline itself does.
    pub(crate) library: Option<vk::Pipeline>,
    /// Its index in the pipeline or library that compiled it.
    pub(crate) index: u32,
}

/// A group of a created pipeline, in pipeline order.
#[derive(Copy, Clone, Debug)]
pub(crate) struct LinkedGroup {
    pub(crate) kind: GroupKind,
    /// How it counts in the stack formulas.
    pub(crate) role: GroupRole,
    /// Its stack sizes, as the driver reports them.
    pub(crate) stack_sizes: GroupStackSizes,
}

impl LinkedGroup {
    /// Reads `compiled`'s stack sizes from the pipeline that compiled it (`pipeline`,
    /// or its library) at its index there, as `vkGetRayTracingShaderGroupStackSizeKHR`
    /// requires.
    pub(crate) fn read(ctx: &ContextInner, pipeline: vk::Pipeline, compiled: &CompiledGroup<'_>) -> LinkedGroup {
        let group = compiled.group;
        let compiled_in = compiled.library.unwrap_or(pipeline);
        LinkedGroup {
            kind: group.kind(),
            role: group_role(&group.programs),
            stack_sizes: query_group_stack_sizes(ctx, compiled_in, compiled.index, &group.programs),
        }
    }
}

/// How a group counts in the stack formulas; callables by their OptiX prefix.
fn group_role(programs: &SpirvGroupPrograms) -> GroupRole {
    match programs {
        SpirvGroupPrograms::Raygen(_) => GroupRole::Raygen,
        SpirvGroupPrograms::Miss(_) => GroupRole::Miss,
        SpirvGroupPrograms::Hit { .. } => GroupRole::Hit,
        SpirvGroupPrograms::Exception(_) => GroupRole::DirectCallable,
        SpirvGroupPrograms::Callable(p) => match raykit_abi::ProgramPrefix::of_bytes(p.name.to_bytes()) {
            Some(raykit_abi::ProgramPrefix::DirectCallable) => GroupRole::DirectCallable,
            Some(raykit_abi::ProgramPrefix::ContinuationCallable) => GroupRole::ContinuationCallable,
            _ => GroupRole::Callable,
        },
    }
}

/// The driver's stack sizes of group `index` of `pipeline`, for the shaders it has.
fn query_group_stack_sizes(
    ctx: &ContextInner,
    pipeline: vk::Pipeline,
    index: u32,
    programs: &SpirvGroupPrograms,
) -> GroupStackSizes {
    let query = |shader: vk::ShaderGroupShaderKHR| -> u64 {
        // SAFETY: `index` is a group of the live `pipeline`, which has a shader of
        // kind `shader` (only those are asked for).
        unsafe { ctx.rt.get_ray_tracing_shader_group_stack_size(pipeline, index, shader) }
    };
    match programs {
        SpirvGroupPrograms::Raygen(_)
        | SpirvGroupPrograms::Miss(_)
        | SpirvGroupPrograms::Callable(_)
        | SpirvGroupPrograms::Exception(_) => {
            GroupStackSizes { general: query(vk::ShaderGroupShaderKHR::GENERAL), ..Default::default() }
        }
        SpirvGroupPrograms::Hit { closest_hit, any_hit, intersection } => GroupStackSizes {
            general: 0,
            closest_hit: if closest_hit.is_some() { query(vk::ShaderGroupShaderKHR::CLOSEST_HIT) } else { 0 },
            any_hit: if any_hit.is_some() { query(vk::ShaderGroupShaderKHR::ANY_HIT) } else { 0 },
            intersection: if intersection.is_some() { query(vk::ShaderGroupShaderKHR::INTERSECTION) } else { 0 },
        },
    }
}

/// The maxima of `groups`' stack sizes by program kind.
pub(crate) fn stack_sizes(groups: &[LinkedGroup]) -> StackSizes {
    StackSizes::from_groups(groups.iter().map(|g| (g.role, g.stack_sizes)))
}
