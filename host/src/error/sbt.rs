//! Errors of shader binding tables: records, their slots, kinds and sizes.

use crate::types::group::GroupKind;
use crate::types::sbt::SbtRegion;

/// Errors of shader binding tables.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SbtError {
    /// An SBT record of the wrong kind of group was given.
    #[error("SBT {region} record needs a {expected} program group, got a {actual} group")]
    GroupKind {
        /// Region being filled.
        region: SbtRegion,
        /// Kind the region needs.
        expected: GroupKind,
        /// Kind given.
        actual: GroupKind,
    },

    /// A launch was given an SBT built for another pipeline.
    #[error(
        "the SBT was built for another pipeline; build one for the pipeline you launch with Sbt::builder(&pipeline)"
    )]
    OfAnotherPipeline,

    /// An SBT region that must be present is missing.
    #[error("the SBT has no {region} record; add one with Sbt::builder(..).{region}(..)")]
    Missing {
        /// The region.
        region: SbtRegion,
    },

    /// An SBT record could not be updated in place.
    #[error("cannot update SBT {region} record: {reason}")]
    Update {
        /// The region.
        region: SbtRegion,
        /// Why not.
        reason: String,
    },

    /// Two records were placed in one SBT slot.
    #[error("SBT {region} slot {index} already holds a record; each ray type × geometry slot takes one (check the ray types' SBT_OFFSET/SBT_STRIDE/MISS_INDEX)")]
    SlotTaken {
        /// The region.
        region: SbtRegion,
        /// The slot.
        index: usize,
    },

    /// A slot below the last filled one was left empty.
    #[error("SBT {region} slot {index} is empty, but a later slot is filled; every slot a trace can reach needs a record (add one with `{region}_at({index}, ..)` or the ray type's `{region}_for`)")]
    Hole {
        /// The region.
        region: SbtRegion,
        /// The empty slot.
        index: usize,
    },

    /// An SBT index is past what a trace can select, or its arithmetic overflows.
    #[error("SBT {region} index {index} is out of range: a {region} region holds at most {limit} records (Vulkan reads {bits} bits of it); use a smaller index")]
    IndexOutOfRange {
        /// The region.
        region: SbtRegion,
        /// The index, or how it was computed when that overflowed.
        index: String,
        /// The most records the region may hold.
        limit: usize,
        /// How many bits of the index Vulkan reads.
        bits: u32,
    },

    /// The SBT lacks a record that a trace of its pipeline selects.
    #[error("the SBT has {have} {region} record(s), but `{program}` traces rays that select {region} record {}; add it with Sbt::builder(..).{region}_at({}, ..) (or the ray type's `{region}_for`)", .needed - 1, .needed - 1)]
    Incomplete {
        /// The region.
        region: SbtRegion,
        /// How many records it needs.
        needed: usize,
        /// How many it has.
        have: usize,
        /// The program whose trace selects the missing record.
        program: String,
    },

    /// A group was placed for a ray type other than the one its programs were declared for.
    #[error("`{program}` was declared for ray type `{declared}` (`#[{kind}(ray = {declared})]`), but its group is placed with {region}_for::<{asked}>; place it with {region}_for::<{declared}>, or declare the program for `{asked}`")]
    RayTypeMismatch {
        /// The region.
        region: SbtRegion,
        /// The program.
        program: String,
        /// Its kind's attribute name (`miss`, `closest_hit`, `any_hit`).
        kind: &'static str,
        /// The ray type it was declared for.
        declared: &'static str,
        /// The ray type it was placed for.
        asked: &'static str,
    },

    /// The SBT's host copy could not be allocated.
    ///
    /// A fault, not a refusal: the host is out of memory.
    #[error("the SBT needs {bytes} bytes, which cannot be allocated; use fewer or smaller records")]
    TooLarge {
        /// Its size.
        bytes: u64,
    },

    /// A record's data is too large for the device.
    #[error("SBT record data of {size} bytes: record stride {stride} exceeds this device's maxShaderGroupStride {limit}; keep large data in a `Buffer<T>` and put its handle in the record")]
    RecordTooLarge {
        /// Data size.
        size: usize,
        /// Resulting stride.
        stride: u64,
        /// `maxShaderGroupStride`.
        limit: u32,
    },

    /// A record's data is smaller than what a program of its group reads.
    #[error("SBT {region} record {index} carries {given} bytes of data, but `{program}` reads {reads} bytes of record data; give the record data of the type the program declares for its record (`#[record]` in Rust, the shader record block in GLSL or WGSL), or make the program read less")]
    RecordTooSmall {
        /// The region.
        region: SbtRegion,
        /// The record's index in it.
        index: usize,
        /// The program that reads past the data.
        program: String,
        /// The bytes of record data it reads.
        reads: usize,
        /// The bytes of data the record carries.
        given: usize,
    },

    /// The SBT lacks a callable record that a program of its pipeline calls.
    #[error("the SBT has {have} callable record(s), but `{program}` calls {what}; add callables with Sbt::builder(..).callable(..) in index order (the n-th call of `callable` is index n)")]
    CallableMissing {
        /// What the program calls: `callable N`, or callables at a computed index.
        what: String,
        /// How many callable records the user gave.
        have: usize,
        /// The program whose call selects the missing record.
        program: String,
    },
}
