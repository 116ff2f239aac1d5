//! Records fit their programs: what each group of a pipeline needs of the SBT
//! records that carry it, and the check an SBT is built under.
//!
//! **Record sizes.** A program reads its record data with a fixed layout: on
//! Vulkan its `ShaderRecordBufferKHR` block (Rust `#[record] data: &T`, GLSL
//! `layout(shaderRecordEXT) buffer`, WGSL `@group(3) @binding(0)`), whose size
//! raykit reads from the SPIR-V; on the CPU backend the `#[record]` type the
//! macros recorded. A record whose data is smaller would hand the program the
//! next record's bytes, or zeros, as its data: [`SbtBuilder::build`](crate::SbtBuilder::build) refuses it with
//! [`SbtError::RecordTooSmall`], naming the region, the index, the program and
//! both sizes. Larger data is accepted (a program may read a prefix of it).
//!
//! **Hit group kinds.** A hit group with an intersection program is a procedural
//! hit group, for AABB geometry; one without is a triangles hit group. Vulkan
//! leaves a hit group of the other kind undefined, so launches check the
//! records each instance of the scenes in the params can select (see
//! [`crate::validate::scene`]).

use crate::error::SbtError;
use crate::error::{Error, Result};
use crate::types::group::{Group, GroupPrograms, SpirvCode};
use crate::types::sbt::SbtRegion;

/// What a group of a pipeline needs of the records that carry it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct GroupNeeds {
    /// The most bytes of record data one of its programs reads, and that program.
    pub(crate) record: Option<(usize, String)>,
    /// Whether it is a procedural hit group (it has an intersection program).
    pub(crate) procedural: bool,
}

impl GroupNeeds {
    /// What `group`'s programs read: from the SPIR-V of its modules, or from the
    /// record types of programs compiled for the host.
    pub(crate) fn of<S: SpirvCode>(group: &Group<S>) -> GroupNeeds {
        let mut record: Option<(usize, String)> = None;
        for program in group.programs() {
            let bytes = match &program.code {
                crate::types::group::ProgramCode::Spirv(_) => program.entry_info().map_or(0, |e| e.record as usize),
                crate::types::group::ProgramCode::Cpu { program, .. } => program.record.map_or(0, |t| t.size),
            };
            if bytes > 0 && record.as_ref().is_none_or(|(most, _)| bytes > *most) {
                record = Some((bytes, program.name.to_string_lossy().into_owned()));
            }
        }
        let procedural = matches!(&group.programs, GroupPrograms::Hit { intersection: Some(_), .. });
        GroupNeeds { record, procedural }
    }
}

/// One record of an SBT being built: the pipeline index of its group and the
/// bytes of its data.
pub(crate) struct RecordData {
    pub(crate) group: usize,
    pub(crate) bytes: usize,
}

/// Refuses a record of `region` whose data is smaller than what its group's
/// programs read (`needs`, by pipeline group index).
pub(crate) fn check_record_sizes(
    needs: &[GroupNeeds],
    region: SbtRegion,
    records: impl IntoIterator<Item = RecordData>,
) -> Result<()> {
    for (index, record) in records.into_iter().enumerate() {
        let Some((reads, program)) = needs.get(record.group).and_then(|n| n.record.as_ref()) else { continue };
        if record.bytes < *reads {
            return Err(Error::Sbt(SbtError::RecordTooSmall {
                region,
                index,
                program: program.clone(),
                reads: *reads,
                given: record.bytes,
            }));
        }
    }
    Ok(())
}

/// The kinds of an SBT's hit groups, record by record, as launches check them
/// against the geometry of the scene.
#[derive(Clone, Debug, Default)]
pub(crate) struct HitKinds {
    /// Per hit record: whether its group is procedural.
    procedural: Vec<bool>,
    /// How many of them are.
    procedural_count: usize,
}

impl HitKinds {
    /// The kinds of the hit records, in order.
    pub(crate) fn new(procedural: Vec<bool>) -> HitKinds {
        let procedural_count = procedural.iter().filter(|p| **p).count();
        HitKinds { procedural, procedural_count }
    }

    /// Whether every hit record is procedural (`Some(true)`), none is
    /// (`Some(false)`), or they are mixed (`None`).
    pub(crate) fn uniform(&self) -> Option<bool> {
        match self.procedural_count {
            0 => Some(false),
            n if n == self.procedural.len() => Some(true),
            _ => None,
        }
    }

    /// Whether hit record `index` is procedural (`None` past the end).
    pub(crate) fn is_procedural(&self, index: u64) -> Option<bool> {
        usize::try_from(index).ok().and_then(|i| self.procedural.get(i)).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_smaller_than_its_program_reads_is_refused_and_larger_data_is_not() {
        let needs =
            [GroupNeeds::default(), GroupNeeds { record: Some((12, "__miss__ms".to_owned())), procedural: false }];
        let records = |sizes: &[(usize, usize)]| {
            sizes.iter().map(|&(group, bytes)| RecordData { group, bytes }).collect::<Vec<_>>()
        };
        assert!(check_record_sizes(&needs, SbtRegion::Miss, records(&[(0, 0), (1, 12), (1, 16)])).is_ok());
        let err = check_record_sizes(&needs, SbtRegion::Miss, records(&[(1, 12), (1, 0)]));
        let fields = match &err {
            Err(Error::Sbt(SbtError::RecordTooSmall { region, index, program, reads, given })) => {
                Some((*region, *index, program.as_str(), *reads, *given))
            }
            _ => None,
        };
        assert_eq!(fields, Some((SbtRegion::Miss, 1, "__miss__ms", 12, 0)), "expected RecordTooSmall, got {err:?}");
    }

    #[test]
    fn hit_kinds_say_whether_the_region_is_uniform() {
        assert_eq!(HitKinds::new(vec![]).uniform(), Some(false));
        assert_eq!(HitKinds::new(vec![true, true]).uniform(), Some(true));
        let mixed = HitKinds::new(vec![false, true]);
        assert_eq!(mixed.uniform(), None);
        assert_eq!((mixed.is_procedural(1), mixed.is_procedural(2)), (Some(true), None));
    }
}
