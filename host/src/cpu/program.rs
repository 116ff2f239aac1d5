//! Pipelines and shader binding tables of the CPU backend: the programs of each
//! group, as the macros compiled them for the host, and each record's data.

use std::sync::Arc;

use raykit_device::cpu::CpuProgram;

use super::CpuContext;
use crate::types;
use crate::types::group::{GroupKind, SpirvCode};

/// One program of a group: what runs and its name for errors.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Program {
    pub(crate) cpu: &'static CpuProgram,
    pub(crate) name: &'static str,
    /// Which of the pipeline's constant sets it was specialized with
    /// ([`PipelineData::constant_sets`]): each library's own, or the pipeline's.
    pub(crate) constants: usize,
}

/// One group of a CPU pipeline.
#[derive(Clone, Debug)]
pub(crate) struct Group {
    pub(crate) kind: GroupKind,
    /// The raygen, miss, callable or exception program.
    pub(crate) general: Option<Program>,
    pub(crate) closest_hit: Option<Program>,
    pub(crate) any_hit: Option<Program>,
    pub(crate) intersection: Option<Program>,
}

impl Group {
    /// Its programs.
    pub(crate) fn programs(&self) -> impl Iterator<Item = &Program> {
        [&self.general, &self.closest_hit, &self.any_hit, &self.intersection].into_iter().flatten()
    }

    /// The most bytes of record data its programs read.
    pub(crate) fn record_size(&self) -> usize {
        self.programs().filter_map(|p| p.cpu.record).map(|t| t.size).max().unwrap_or(0)
    }
}

/// A linked CPU pipeline.
#[derive(Debug)]
pub(crate) struct PipelineData {
    pub(crate) ctx: Arc<CpuContext>,
    pub(crate) groups: Vec<Group>,
    pub(crate) max_trace_depth: u32,
    /// The specialization constants, by id, of each part it was linked from:
    /// one set for a pipeline of groups, one per library for a pipeline of
    /// libraries.
    pub(crate) constant_sets: Vec<Vec<(u32, u32)>>,
    /// The index of the exception group, if there is one.
    pub(crate) exception_group: Option<usize>,
}

/// Bytes aligned to 16, as records, params and attributes are read.
#[derive(Clone, Debug, Default)]
pub(crate) struct Aligned(Vec<u128>);

impl Aligned {
    /// A copy of `bytes`, zero-padded to at least `len` bytes.
    pub(crate) fn new(bytes: &[u8], len: usize) -> Aligned {
        let mut words = vec![0u128; bytes.len().max(len).div_ceil(16).max(1)];
        bytemuck::cast_slice_mut::<u128, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        Aligned(words)
    }

    /// Overwrites the start with `bytes` (which fit).
    pub(crate) fn write(&mut self, bytes: &[u8]) {
        let all = bytemuck::cast_slice_mut::<u128, u8>(&mut self.0);
        let n = bytes.len().min(all.len());
        all[..n].copy_from_slice(&bytes[..n]);
    }

    /// The address of the first byte.
    pub(crate) fn ptr(&self) -> *const u8 {
        self.0.as_ptr().cast()
    }
}

/// One SBT record on the CPU backend: its group and data.
#[derive(Clone, Debug)]
pub(crate) struct Record {
    pub(crate) group: usize,
    pub(crate) data: Aligned,
}

/// The records of a CPU SBT, by region: raygen, miss, hit, callable (the
/// exception program's last).
#[derive(Clone, Debug, Default)]
pub(crate) struct SbtData {
    pub(crate) regions: [Vec<Record>; 4],
}

impl SbtData {
    /// The checked records of `regions` (raygen, miss, hit, callable) of
    /// `pipeline`, each padded to what its group's programs read.
    pub(crate) fn new(pipeline: &PipelineData, regions: &[Vec<types::sbt::PlainRecord<'_>>; 4]) -> SbtData {
        let records = |records: &Vec<types::sbt::PlainRecord<'_>>| {
            let record = |r: &types::sbt::PlainRecord<'_>| {
                let len = pipeline.groups.get(r.group).map_or(0, Group::record_size);
                Record { group: r.group, data: Aligned::new(r.data, len) }
            };
            records.iter().map(record).collect()
        };
        SbtData { regions: std::array::from_fn(|i| records(&regions[i])) }
    }
}

/// Links checked `groups` of a CPU context into a pipeline.
pub(crate) fn link<S: SpirvCode>(
    ctx: &Arc<CpuContext>,
    groups: &[&types::group::Group<S>],
    max_trace_depth: u32,
    constants: &types::specialization::Specialization,
) -> PipelineData {
    link_parts(ctx, &[(groups.to_vec(), constants)], max_trace_depth)
}

/// Links checked parts of a CPU context into a pipeline, in order: each part's
/// groups keep the specialization constants they came with (a pipeline
/// library's, on Vulkan compiled into it).
pub(crate) fn link_parts<S: SpirvCode>(
    ctx: &Arc<CpuContext>,
    parts: &[(Vec<&types::group::Group<S>>, &types::specialization::Specialization)],
    max_trace_depth: u32,
) -> PipelineData {
    let linked: Vec<Group> =
        parts.iter().enumerate().flat_map(|(set, (groups, _))| groups.iter().map(move |g| group(g, set))).collect();
    PipelineData {
        ctx: ctx.clone(),
        exception_group: linked.iter().position(|g| g.kind == GroupKind::Exception),
        groups: linked,
        max_trace_depth,
        constant_sets: parts.iter().map(|(_, constants)| constants.values().to_vec()).collect(),
    }
}

/// The CPU programs of `group` (a group of a CPU context holds only those).
fn group<S: Clone>(group: &types::group::Group<S>, constants: usize) -> Group {
    use types::group::{GroupPrograms, ProgramCode};
    let program = |p: &Option<types::group::Program<S>>| -> Option<Program> {
        let p = p.as_ref()?;
        match p.code {
            ProgramCode::Cpu { program: cpu, .. } => Some(Program { cpu, name: cpu.name, constants }),
            ProgramCode::Spirv(_) => None,
        }
    };
    let mut out = Group { kind: group.kind(), general: None, closest_hit: None, any_hit: None, intersection: None };
    match &group.programs {
        GroupPrograms::Raygen(p)
        | GroupPrograms::Miss(p)
        | GroupPrograms::Callable(p)
        | GroupPrograms::Exception(p) => {
            out.general = program(&Some(p.clone()));
        }
        GroupPrograms::Hit { closest_hit, any_hit, intersection } => {
            out.closest_hit = program(closest_hit);
            out.any_hit = program(any_hit);
            out.intersection = program(intersection);
        }
    }
    out
}
