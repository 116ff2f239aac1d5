//! Errors of launches: dimensions, handles, the scene against the SBT, and what device programs
//! did (user exceptions, refused recursion, panics and faults on the CPU backend).

use crate::types::sbt::SbtRegion;

/// One user exception thrown by a device program (`ctx.throw_exception`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct UserException {
    /// The code the program threw.
    pub code: u32,
    /// The launch index of the invocation that threw it.
    pub launch_index: [u32; 3],
}

fn list_exceptions(exceptions: &[UserException]) -> String {
    let shown: Vec<String> =
        exceptions.iter().take(8).map(|e| format!("code {:#x} at {:?}", e.code, e.launch_index)).collect();
    shown.join(", ")
}

fn list_indices(indices: &[[u32; 3]]) -> String {
    let shown: Vec<String> = indices.iter().take(8).map(|i| format!("{i:?}")).collect();
    let more = if indices.len() > 8 { format!(" and {} more", indices.len() - 8) } else { String::new() };
    format!("{}{more}", shown.join(", "))
}

/// Where an invalid handle sits, for [`LaunchError::InvalidHandle`](crate::LaunchError::InvalidHandle)'s message.
fn handle_place(record: &Option<(SbtRegion, usize)>, field: &str) -> String {
    match record {
        None => format!("launch params field `{field}`"),
        Some((region, index)) => format!("field `{field}` of {region} record {index} of the SBT"),
    }
}

/// The error of a launch whose programs threw `total` exceptions, `recorded` of
/// them recorded, in a pipeline linked with `max_trace_depth`: the traces refused
/// past the depth ([`LaunchError::RecursionTooDeep`](crate::LaunchError::RecursionTooDeep)) if any were recorded, otherwise
/// the user exceptions ([`LaunchError::UserExceptions`]).
pub(crate) fn exceptions_error(total: u32, recorded: Vec<UserException>, max_trace_depth: u32) -> LaunchError {
    use raykit_device::exception::TRACE_DEPTH_EXCEEDED;
    let (refused, user): (Vec<UserException>, Vec<UserException>) =
        recorded.into_iter().partition(|e| e.code == TRACE_DEPTH_EXCEEDED);
    if refused.is_empty() {
        return LaunchError::UserExceptions { total, exceptions: user };
    }
    LaunchError::RecursionTooDeep {
        max_trace_depth,
        depth: max_trace_depth.saturating_add(1),
        refused: refused.len(),
        launch_indices: refused.iter().map(|e| e.launch_index).collect(),
        user_exceptions: user,
        total,
    }
}

/// Errors of launches.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LaunchError {
    /// A device program panicked (a failed `assert!`, an index out of bounds, an
    /// explicit `panic!`) while the CPU backend ran it: the launch stopped.
    ///
    /// A fault, not a refusal: a device program failed while it ran; the launch was valid.
    #[error("device program `{program}` panicked at launch index {launch_index:?}: {message}")]
    ProgramPanicked {
        /// The program's entry-point name.
        program: String,
        /// The launch index of the invocation that panicked.
        launch_index: [u32; 3],
        /// The panic's message.
        message: String,
    },

    /// A device program asked the CPU backend for something the device leaves
    /// undefined: a trace into a traversable that is no live IAS, a record past
    /// the end of an SBT region, a payload or callable data of another type than
    /// the receiving program's. The launch stopped.
    ///
    /// A fault, not a refusal: a device program did what the device leaves undefined; the CPU backend catches it, a GPU cannot.
    #[error("device program `{program}` at launch index {launch_index:?}: {problem}")]
    CpuLaunchFault {
        /// The program running when it happened.
        program: String,
        /// The launch index of the invocation.
        launch_index: [u32; 3],
        /// What went wrong, and how to fix it.
        problem: String,
    },

    /// A device program ran out of stack on the CPU backend (recursion without
    /// end, or frames larger than the stack): the launch stopped, and the
    /// context goes on working.
    ///
    /// A fault, not a refusal: a device program recursed past its stack while it ran.
    #[error("device program `{program}` overflowed its stack of {stack_bytes} bytes at launch index {launch_index:?} (recursion without end, or too deep); bound the recursion, or keep large data in buffers rather than on the stack")]
    StackOverflow {
        /// The innermost program running when the stack ran out.
        program: String,
        /// The launch index of the invocation.
        launch_index: [u32; 3],
        /// The stack each invocation runs on.
        stack_bytes: usize,
    },

    /// A handle in the launch params, or in the data of an SBT record whose type
    /// derives `SbtRecordData`, does not name a live object of the launching
    /// context: a dropped or foreign buffer, a dropped or foreign IAS, or an IAS
    /// whose GASes changed since it was built.
    #[error("{}: {problem}; {fix}", handle_place(.record, .field))]
    InvalidHandle {
        /// The SBT record holding the handle (its region and index there), or
        /// `None` for a field of the launch params.
        record: Option<(SbtRegion, usize)>,
        /// The field, as a path (`scene`, `inner.buffers[2]`).
        field: String,
        /// What is wrong with it.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// Miss or closest-hit programs of a ray type with `RayType::CHECK_DEPTH`
    /// would have traced past the pipeline's `max_trace_depth` during a launch:
    /// the device did not make those traces (each threw
    /// `raykit_device::exception::TRACE_DEPTH_EXCEEDED` and went on without it).
    /// The launch ran to its end.
    #[error("{refused} trace(s) would have gone to depth {depth}, past the pipeline's max_trace_depth {max_trace_depth}, and were not made, at launch indices {}{} ({total} exception(s) thrown in all); raise LinkOptions::max_trace_depth to the depth the programs recurse to, or end the recursion in the program (ClosestHit::trace_depth / Miss::trace_depth give the depth)", list_indices(.launch_indices), if .user_exceptions.is_empty() { String::new() } else { format!(", and user exceptions {}", list_exceptions(.user_exceptions)) })]
    RecursionTooDeep {
        /// The pipeline's `max_trace_depth`.
        max_trace_depth: u32,
        /// The depth the refused traces would have reached (`max_trace_depth + 1`).
        depth: u32,
        /// How many refused traces were recorded.
        refused: usize,
        /// The launch index of each recorded refusal, in the order recorded.
        launch_indices: Vec<[u32; 3]>,
        /// The user exceptions recorded with them.
        user_exceptions: Vec<UserException>,
        /// How many exceptions were thrown in all (recorded or not: a launch
        /// records the first `EXCEPTION_CAPACITY`).
        total: u32,
    },

    /// A launch's scene can select a hit record past the end of the SBT's hit
    /// region: an instance's SBT offset plus its geometries (at the stride of the
    /// pipeline's traces) plus a ray type's offset reaches further than the
    /// records built (see [`crate::Instance::sbt_offset`]).
    #[error("instance {instance} of the IAS in params field `{field}` (SBT offset {sbt_offset}, {geometries} geometr{}) reaches hit record {slot} = {sbt_offset} + ({geometries} - 1) × stride {stride} + ray offset {ray_offset} (a trace in `{program}`), but the SBT has {hit_records} hit record(s); build the SBT with records up to index {slot} (SbtBuilder::hit_for::<R>(geometry slot, ..) for every ray type), or lower the instance's sbt_offset (raykit::sbt::instance_sbt_offset)", if *.geometries == 1 { "y" } else { "ies" })]
    SbtTooSmallForScene {
        /// The params field holding the IAS.
        field: String,
        /// The instance's index in the IAS.
        instance: usize,
        /// Its SBT offset (`Instance::sbt_offset`).
        sbt_offset: u32,
        /// Geometries of its GAS.
        geometries: u32,
        /// `sbtRecordStride` of the trace.
        stride: u32,
        /// `sbtRecordOffset` of the trace.
        ray_offset: u32,
        /// The hit record index reached.
        slot: u64,
        /// Hit records in the SBT.
        hit_records: usize,
        /// A program making such a trace.
        program: String,
    },

    /// An instance selects a hit record whose group is of the other kind than
    /// its geometry: a procedural hit group (one with an intersection program)
    /// for triangles, or a triangles hit group for AABBs.
    #[error("instance {instance} of the IAS in params field `{field}` has {} (geometry {geometry} of its GAS), but hit record {slot} it selects (stride {stride}, ray offset {ray_offset}, a trace in `{program}`) holds a {} hit group; {}", hit_kind_names(*.aabbs).0, hit_kind_names(*.aabbs).1, hit_kind_fix(*.aabbs))]
    HitGroupKind {
        /// The params field holding the IAS.
        field: String,
        /// The instance's index in the IAS.
        instance: usize,
        /// The geometry's index in the instance's GAS.
        geometry: u32,
        /// Whether the geometry is AABBs (the group then has no intersection
        /// program) rather than triangles (the group has one).
        aabbs: bool,
        /// The hit record it selects.
        slot: u64,
        /// `sbtRecordStride` of the trace.
        stride: u32,
        /// `sbtRecordOffset` of the trace.
        ray_offset: u32,
        /// A program making such a trace.
        program: String,
    },

    /// Launch dimensions are zero or too large.
    #[error("launch dimensions {dims:?}: {reason}")]
    Dimensions {
        /// What was asked for.
        dims: [u32; 3],
        /// Why they cannot be launched.
        reason: String,
    },

    /// Device programs threw user exceptions during a launch. The launch ran to
    /// its end: buffers hold what the programs wrote.
    #[error("the launch raised {total} user exception(s): {} (the first {} are recorded; each was thrown with ctx.throw_exception)", list_exceptions(.exceptions), .exceptions.len())]
    UserExceptions {
        /// How many were thrown.
        total: u32,
        /// The first `EXCEPTION_CAPACITY` of them, in the order they were recorded.
        exceptions: Vec<UserException>,
    },
}

/// The geometry's kind and the hit group's, for [`LaunchError::HitGroupKind`].
fn hit_kind_names(aabbs: bool) -> (&'static str, &'static str) {
    if aabbs {
        ("AABBs", "triangles")
    } else {
        ("triangles", "procedural")
    }
}

/// What to change, for [`LaunchError::HitGroupKind`].
fn hit_kind_fix(aabbs: bool) -> &'static str {
    if aabbs {
        "AABB geometry needs a hit group with an intersection program (ProgramGroup::hit_group(..).intersection(..)) at that record"
    } else {
        "triangle geometry needs a hit group without an intersection program at that record; place the procedural group where only AABB instances select it"
    }
}
