//! What linking checks, once and for both backends, before a backend sees the
//! groups: the trace depth against the device's limit and against what the
//! programs trace, the params against every program that reads them, the
//! descriptor bindings the programs declare, and the groups a launchable
//! pipeline needs. What a pipeline was checked with stays with it as its
//! [`PipelineInfo`], which the SBT builder and every launch read.

use raykit_device::cpu::TypeInfo;
use raykit_device::LaunchParams;
use raykit_spirv::ParamsDelivery;

use super::handles::HandleField;
use super::records::GroupNeeds;
use super::TraceReach;
use crate::error::{Error, LinkError, Result};
use crate::types::context::DeviceLimits;
use crate::types::group::{Group, GroupKind, ProgramCode, SpirvCode};
use crate::types::program::params_delivery;

/// The most bytes of hit attributes a program may declare: Vulkan's
/// `maxRayHitAttributeSize` on every device raykit knows, and the CPU backend's.
pub(crate) const ATTRIBUTE_BYTES: usize = 32;

/// The backend-neutral facts of a linked pipeline, read from its groups when it
/// was checked: what the SBT and launches are checked against.
#[derive(Debug)]
pub(crate) struct PipelineInfo {
    /// The limits of the device it was linked for.
    pub(crate) limits: DeviceLimits,
    /// The most each launch dimension may be (`maxComputeWorkGroupCount[i] ×
    /// maxComputeWorkGroupSize[i]`).
    pub(crate) launch_dimensions: [u64; 3],
    /// Each group's identity and kind, in pipeline order.
    pub(crate) groups: Vec<(u64, GroupKind)>,
    pub(crate) max_trace_depth: u32,
    /// The SBT records its programs' traces and calls select.
    pub(crate) reach: TraceReach,
    /// What each group needs of its records, in pipeline order.
    pub(crate) needs: Vec<GroupNeeds>,
    /// Where the params' `Buffer` and `Traversable` fields are, checked by every launch.
    pub(crate) handle_fields: Vec<HandleField>,
}

impl PipelineInfo {
    /// The facts of a pipeline for params `P` of `groups` (in pipeline order).
    pub(crate) fn of<P: LaunchParams, S: SpirvCode>(
        limits: DeviceLimits,
        launch_dimensions: [u64; 3],
        groups: &[&Group<S>],
        max_trace_depth: u32,
    ) -> PipelineInfo {
        PipelineInfo {
            limits,
            launch_dimensions,
            groups: groups.iter().map(|g| (g.id, g.kind())).collect(),
            max_trace_depth,
            reach: TraceReach::of(groups.iter().copied()),
            needs: groups.iter().map(|g| GroupNeeds::of(g)).collect(),
            handle_fields: super::handles::handle_fields(&P::LAYOUT),
        }
    }

    /// The position of the group `id` in the pipeline.
    pub(crate) fn group_index(&self, id: u64) -> Option<usize> {
        self.groups.iter().position(|(g, _)| *g == id)
    }

    /// Whether the pipeline has a group of `kind`.
    pub(crate) fn has_group(&self, kind: GroupKind) -> bool {
        self.groups.iter().any(|(_, k)| *k == kind)
    }

    /// The position of its exception group, if it has one.
    pub(crate) fn exception_group(&self) -> Option<usize> {
        self.groups.iter().position(|(_, k)| *k == GroupKind::Exception)
    }
}

/// What every set of program groups compiled together (a pipeline or a
/// library) must satisfy, on either backend: a trace depth within the device's
/// limit and enough for what the programs trace, params that fit where they
/// travel and match every program that reads them (by the SPIR-V's layout where
/// it was read, by the Rust type for programs compiled for the host), records,
/// attributes and callable data the backends can hold, and descriptor bindings
/// raykit's pipeline layout has.
pub(crate) fn check_groups<P: LaunchParams, S: SpirvCode>(
    limits: &DeviceLimits,
    groups: &[&Group<S>],
    max_trace_depth: u32,
) -> Result<()> {
    if max_trace_depth > limits.max_ray_recursion_depth {
        return Err(Error::Link(LinkError::TraceDepthTooLarge {
            requested: max_trace_depth,
            limit: limits.max_ray_recursion_depth,
        }));
    }
    let params_size = std::mem::size_of::<P>();
    let delivery = params_delivery::<P>();
    // Launches write uniform params with `vkCmdUpdateBuffer`, which takes at most 65536 bytes.
    let uniform_limit = limits.max_uniform_buffer_range.min(65536);
    if delivery != ParamsDelivery::PushConstants && params_size > uniform_limit as usize {
        return Err(Error::Link(LinkError::ParamsTooLarge { size: params_size, limit: uniform_limit }));
    }
    for program in groups.iter().flat_map(|g| g.programs()) {
        if let Some(info) = program.entry_info() {
            if !info.params.is_empty() {
                raykit_spirv::check(&P::LAYOUT, &info.name, &info.params, delivery)?;
            }
            for binding in &info.bindings {
                super::check_binding(&info.name, binding, delivery)?;
            }
        }
        if let ProgramCode::Cpu { program: cpu, .. } = &program.code {
            check_host_types(cpu, TypeInfo::of::<P>())?;
        }
    }
    TraceReach::of(groups.iter().copied()).check_depth(max_trace_depth)
}

/// Refuses a program compiled for the host that declares params other than
/// `params`, or records or hit attributes the backends cannot hold.
fn check_host_types(program: &raykit_device::cpu::CpuProgram, params: TypeInfo) -> Result<()> {
    let mismatch = |what: &'static str, declared: &'static str, given: String| {
        Err(Error::Link(LinkError::CpuTypeMismatch { program: program.name.to_owned(), what, declared, given }))
    };
    if let Some(theirs) = program.params {
        if theirs != params {
            return mismatch("launch params", theirs.name(), params.name().to_owned());
        }
    }
    for (what, ty) in [("record data", program.record), ("hit attributes", program.attributes)] {
        if let Some(ty) = ty.filter(|t| t.align > 16) {
            return mismatch(what, ty.name(), format!("an alignment of {} (at most 16 is supported)", ty.align));
        }
    }
    if let Some(ty) = program.attributes.filter(|t| t.size > ATTRIBUTE_BYTES) {
        return mismatch(
            "hit attributes",
            ty.name(),
            format!("{} bytes (maxRayHitAttributeSize is {ATTRIBUTE_BYTES})", ty.size),
        );
    }
    Ok(())
}
