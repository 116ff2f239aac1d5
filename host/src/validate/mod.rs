//! Checks that keep what raykit accepts valid for the driver: SPIR-V validation
//! before `vkCreateShaderModule` (see [`spirv`]), the trace depth a pipeline's
//! programs can reach, and the SBT records their traces and scenes can select.
//!
//! **Trace depth.** raykit reads every program's `OpTraceRayKHR` calls through its
//! call graph. A pipeline whose raygen (or a callable) traces needs
//! `max_trace_depth ≥ 1`; one whose miss or closest-hit programs trace can recurse,
//! and needs `max_trace_depth ≥ 2`. How deep such recursion goes depends on run-time
//! values the SPIR-V cannot bound: a `max_trace_depth` of 2 or more declares how
//! deep the programs trace (OptiX asks the same). Vulkan leaves tracing past
//! `maxPipelineRayRecursionDepth` undefined; raykit's device-side `trace` refuses
//! to go there for ray types that carry their depth
//! (`raykit_device::RayType::CHECK_DEPTH`): such a pipeline is accepted with any
//! depth of 2 or more, and a trace past it ends in
//! [`LaunchError::RecursionTooDeep`](crate::LaunchError::RecursionTooDeep) from the launch.
//!
//! **The SBT fits the scene.** Every launch checks that the instances of its
//! scenes select no hit record past the SBT's end: for each `(sbtRecordStride,
//! sbtRecordOffset)` pair the traces use, the furthest instance's SBT offset +
//! (geometries − 1) × stride + offset must be below the hit record count
//! ([`LaunchError::SbtTooSmallForScene`](crate::LaunchError::SbtTooSmallForScene)).
//!
//! **Callables.** The SBT index of every `OpExecuteCallableKHR` a program
//! reaches is read too: an SBT with fewer callables than the highest constant
//! index is [`SbtError::CallableMissing`].
//! A computed index cannot be bounded; it needs one callable at least when the
//! pipeline has callable groups (raykit's own call of the exception program is
//! such a call, and needs none).
//!
//! **Records and hit group kinds**: see `records` (record sizes against the
//! programs that read them; the kind of each hit group against the geometry
//! that selects it).

pub(crate) mod accel;
pub mod handles;
pub(crate) mod hit_reach;
pub(crate) mod launch;
pub(crate) mod link;
pub(crate) mod records;
pub(crate) mod scene;
pub mod spirv;
pub(crate) mod texture;

use raykit_device::ProgramKind;
use raykit_spirv::{DescriptorBinding, DescriptorKind, ParamsDelivery};

use crate::error::{Error, Result};
use crate::error::{LinkError, ResourceError, SbtError};
use crate::types::group::GroupKind;
use crate::types::group::{Group, SpirvCode};
use crate::types::sbt::SbtRegion;

/// Vulkan uses the low 16 bits of a trace's `missIndex`: the miss region holds at
/// most this many records a trace can select.
pub const MAX_MISS_RECORDS: usize = 1 << 16;
/// Vulkan uses 24 bits of an instance's SBT offset: raykit's hit region holds at
/// most this many records.
pub const MAX_HIT_RECORDS: usize = 1 << 24;
/// Callables are placed one after another; at most this many.
pub const MAX_CALLABLE_RECORDS: usize = 1 << 16;

/// The most records `region` may hold.
pub(crate) const fn max_records(region: SbtRegion) -> usize {
    match region {
        SbtRegion::Raygen => 1,
        SbtRegion::Miss => MAX_MISS_RECORDS,
        SbtRegion::Hit => MAX_HIT_RECORDS,
        SbtRegion::Callable => MAX_CALLABLE_RECORDS,
    }
}

/// What a pipeline's programs can reach when they trace, read from their SPIR-V.
#[derive(Clone, Debug, Default)]
pub(crate) struct TraceReach {
    /// The highest constant miss index a trace uses, and the program using it.
    pub(crate) miss_index: Option<(u32, String)>,
    /// The highest constant SBT offset a trace uses, and the program using it.
    pub(crate) sbt_offset: Option<(u32, String)>,
    /// A raygen (or callable) program that traces: depth 1 at least.
    pub(crate) first_level: Option<String>,
    /// A miss or closest-hit program that traces: recursion, depth 2 at least.
    pub(crate) recursive: Option<String>,
    /// The `(sbtRecordStride, sbtRecordOffset)` pairs the traces use (low 4
    /// bits), each with a program using it: what a launch's scene is checked
    /// against (see [`scene`]).
    pub(crate) hit_selectors: Vec<(u32, u32, String)>,
    /// The highest constant callable index a program calls, and the program.
    pub(crate) callable_index: Option<(u32, String)>,
    /// A program that calls a callable at an index computed at run time.
    pub(crate) dynamic_callable: Option<String>,
}

impl TraceReach {
    /// Reads what the programs of `groups` trace.
    pub(crate) fn of<'g, S: SpirvCode + 'g>(groups: impl IntoIterator<Item = &'g Group<S>>) -> TraceReach {
        let mut reach = TraceReach::default();
        let higher = |slot: &mut Option<(u32, String)>, value: Option<u32>, name: &str| {
            if let Some(v) = value {
                if slot.as_ref().is_none_or(|(old, _)| v > *old) {
                    *slot = Some((v, name.to_owned()));
                }
            }
        };
        let groups: Vec<&Group<S>> = groups.into_iter().collect();
        // The SBT placement of the ray types the pipeline's miss and hit programs
        // were declared for: what a trace whose stride or offset is computed at
        // run time is assumed to use.
        let mut declared: Vec<(u32, u32)> = Vec::new();
        for program in groups.iter().flat_map(|g| g.programs()) {
            if let Some(ray) = program.ray {
                let pair = (ray.sbt_stride & 0xf, ray.sbt_offset & 0xf);
                if !declared.contains(&pair) {
                    declared.push(pair);
                }
            }
        }
        let select = |reach: &mut TraceReach, pair: (u32, u32), name: &str| {
            if !reach.hit_selectors.iter().any(|(s, o, _)| (*s, *o) == pair) {
                reach.hit_selectors.push((pair.0, pair.1, name.to_owned()));
            }
        };
        for group in &groups {
            for program in group.programs() {
                let Some(info) = program.entry_info() else {
                    // A program compiled for the host (the CPU backend) has no
                    // SPIR-V to read its traces from: one of a stage that may
                    // trace is assumed to trace the declared ray types.
                    let may_trace = matches!(
                        program.kind,
                        ProgramKind::Raygen | ProgramKind::Miss | ProgramKind::ClosestHit | ProgramKind::Callable
                    );
                    if may_trace {
                        for pair in &declared {
                            select(&mut reach, *pair, &program.name.to_string_lossy());
                        }
                    }
                    continue;
                };
                for index in &info.traces.callables {
                    match index {
                        Some(_) => higher(&mut reach.callable_index, *index, &info.name),
                        None => {
                            reach.dynamic_callable.get_or_insert_with(|| info.name.clone());
                        }
                    }
                }
                if !info.traces.traces() {
                    continue;
                }
                for call in &info.traces.calls {
                    // Vulkan reads the low 16 bits of the miss index and 4 of the offset.
                    higher(&mut reach.miss_index, call.miss_index.map(|m| m & 0xffff), &info.name);
                    higher(&mut reach.sbt_offset, call.sbt_offset.map(|o| o & 0xf), &info.name);
                    match (call.sbt_stride, call.sbt_offset) {
                        (Some(stride), Some(offset)) => select(&mut reach, (stride & 0xf, offset & 0xf), &info.name),
                        _ => {
                            for pair in &declared {
                                select(&mut reach, *pair, &info.name);
                            }
                        }
                    }
                }
                match program.kind {
                    ProgramKind::Raygen | ProgramKind::Callable => {
                        reach.first_level.get_or_insert_with(|| info.name.clone());
                    }
                    ProgramKind::Miss | ProgramKind::ClosestHit => {
                        reach.recursive.get_or_insert_with(|| info.name.clone());
                    }
                    // The SPIR-V environment forbids tracing in the other stages.
                    _ => {}
                }
            }
        }
        reach
    }

    /// Refuses a `max_trace_depth` below what the programs need (see the module docs).
    pub(crate) fn check_depth(&self, max_trace_depth: u32) -> Result<()> {
        let refuse = |program: &String, needed: u32, why: &'static str| {
            Err(Error::Link(LinkError::TraceDepthExceeded { program: program.clone(), needed, max_trace_depth, why }))
        };
        if let Some(program) = &self.recursive {
            if max_trace_depth < 2 {
                return refuse(program, 2, "a miss or closest-hit program that traces recurses");
            }
        }
        if let Some(program) = &self.first_level {
            if max_trace_depth < 1 {
                return refuse(program, 1, "it traces rays");
            }
        }
        Ok(())
    }

    /// Refuses an SBT whose `miss` and `hit` record counts leave a record that a
    /// trace of the pipeline selects out of range. `has_miss`/`has_hit`: whether the
    /// pipeline has groups of that kind.
    pub(crate) fn check_sbt(&self, has_miss: bool, miss: usize, has_hit: bool, hit: usize) -> Result<()> {
        let tracer = self.first_level.as_ref().or(self.recursive.as_ref());
        let Some(tracer) = tracer else { return Ok(()) };
        for (region, has, count, reach) in
            [(SbtRegion::Miss, has_miss, miss, &self.miss_index), (SbtRegion::Hit, has_hit, hit, &self.sbt_offset)]
        {
            if !has {
                continue;
            }
            let (needed, program) = match reach {
                Some((index, program)) => (*index as usize + 1, program),
                None => (1, tracer),
            };
            if count < needed {
                return Err(Error::Sbt(SbtError::Incomplete { region, needed, have: count, program: program.clone() }));
            }
        }
        Ok(())
    }
}

impl TraceReach {
    /// Refuses an SBT with `callables` callable records of the user's (the
    /// exception program's not counted) when a program calls a callable index
    /// past them. A call at an index computed at run time cannot be bounded:
    /// it needs one record at least when the pipeline has callable groups
    /// (`has_callables`); without them it is the exception program's call,
    /// which raykit places itself.
    pub(crate) fn check_callables(&self, has_callables: bool, callables: usize) -> Result<()> {
        let missing = |what: String, program: &String| {
            Err(Error::Sbt(SbtError::CallableMissing { what, have: callables, program: program.clone() }))
        };
        if let Some((index, program)) = &self.callable_index {
            if *index as usize >= callables {
                return missing(format!("callable {index}"), program);
            }
        }
        if let Some(program) = &self.dynamic_callable {
            if has_callables && callables == 0 {
                return missing("callables at an index computed at run time".to_owned(), program);
            }
        }
        Ok(())
    }
}

/// Refuses a descriptor binding that raykit's pipeline layout does not have:
/// the buffer table (storage buffers) at set 0, binding 0, the texture table
/// (combined image samplers) at set 0, binding 1, and the params uniform
/// buffer at set 1, binding 0 when `delivery` says the params go there.
pub(crate) fn check_binding(program: &str, binding: &DescriptorBinding, delivery: ParamsDelivery) -> Result<()> {
    let (table_set, table_binding) = (raykit_abi::BUFFER_TABLE_SET, raykit_abi::BUFFER_TABLE_BINDING);
    let reason = match (binding.set, binding.binding) {
        (s, b) if (s, b) == (table_set, table_binding) => {
            if binding.kind == DescriptorKind::StorageBuffer {
                return Ok(());
            }
            "where raykit binds its buffer table (storage buffers)".to_owned()
        }
        (s, b) if (s, b) == (table_set, raykit_abi::TEXTURE_TABLE_BINDING) => {
            if binding.kind == DescriptorKind::CombinedImageSampler {
                return Ok(());
            }
            "where raykit binds its texture table (combined image samplers)".to_owned()
        }
        (s, b) if s == raykit_abi::PARAMS_SET && b == raykit_abi::PARAMS_BINDING => match delivery {
            ParamsDelivery::UniformBuffer { .. } if binding.kind == DescriptorKind::UniformBuffer => return Ok(()),
            ParamsDelivery::UniformBuffer { .. } => "where raykit binds the params uniform buffer".to_owned(),
            ParamsDelivery::PushConstants => {
                "but this pipeline's params travel as push constants, so set 1 is not bound".to_owned()
            }
        },
        (s, _) if s == table_set => format!("but set {s} has only bindings 0 (buffers) and 1 (textures)"),
        (s, _) if s == raykit_abi::PARAMS_SET => format!("but set {s} has only binding 0"),
        (s, _) => format!("but raykit's pipeline layout has no set {s}"),
    };
    Err(Error::Link(LinkError::DescriptorBinding {
        program: program.to_owned(),
        set: binding.set,
        binding: binding.binding,
        found: match &binding.name {
            Some(name) => format!("{} `{name}`", binding.kind),
            None => binding.kind.to_string(),
        },
        reason,
    }))
}

/// Validates each SPIR-V module of `groups` once, with the specialization
/// constants `spec_values` frozen in, before `vkCreateShaderModule` sees it
/// (see [`spirv`]). Only Vulkan consumes SPIR-V, so only its linking calls this;
/// every other link check is [`link::check_groups`].
pub(crate) fn check_spirv_modules<S: SpirvCode>(groups: &[&Group<S>], spec_values: &[(u32, u32)]) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for group in groups {
        for program in group.programs() {
            let Some(module) = program.module() else { continue };
            if seen.insert(module.identity()) {
                spirv::validate(&spirv::freeze_spec_constants(module.words(), spec_values)?)?;
            }
        }
    }
    Ok(())
}

/// Refuses an explicit stack size smaller than the largest stack one program of
/// the pipeline needs by itself (`sizes`, from the driver), or zero.
pub(crate) fn check_explicit_stack(bytes: u32, sizes: &crate::stack::StackSizes) -> Result<()> {
    let largest = [sizes.css_rg, sizes.css_ms, sizes.css_ch, sizes.css_ah, sizes.css_is, sizes.css_cc, sizes.dss_dc]
        .into_iter()
        .max()
        .unwrap_or(0);
    if bytes == 0 || u64::from(bytes) < largest {
        return Err(Error::Link(LinkError::StackSize {
            reason: format!(
                "StackSize::Explicit({bytes}) is below {}, the largest stack one of the pipeline's programs needs by itself (Pipeline::stack_sizes); use StackSize::Refined or StackSize::CallGraph, or give at least that many bytes",
                largest.max(1)
            ),
        }));
    }
    Ok(())
}

/// Refuses a buffer of `bytes` over the device's `maxStorageBufferRange`
/// (`limit`): device programs reach every buffer through a storage-buffer
/// descriptor, which cannot cover more.
pub(crate) fn check_storage_buffer(bytes: u64, limit: u32) -> Result<()> {
    if bytes > u64::from(limit) {
        return Err(Error::Resource(ResourceError::BufferTooLarge { bytes, limit }));
    }
    Ok(())
}
/// What the groups of a launchable pipeline must have: a raygen group, and at
/// most one exception group.
pub(crate) fn check_linkable(kinds: impl Iterator<Item = GroupKind> + Clone) -> Result<()> {
    if kinds.clone().filter(|&k| k == GroupKind::Exception).count() > 1 {
        return Err(Error::Link(LinkError::SeveralExceptionPrograms));
    }
    if !kinds.clone().any(|k| k == GroupKind::Raygen) {
        return Err(Error::Link(LinkError::NoRaygen));
    }
    Ok(())
}
