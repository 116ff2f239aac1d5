//! Launches on the CPU backend: the launch grid in tiles over the context's
//! thread pool, each invocation's programs called as Rust functions, and the
//! runtime they call back into (buffers, traces, callables, exceptions).
//!
//! A trace follows Vulkan's traversal rules: instances whose mask shares no bit
//! with the ray's cull mask are skipped; a candidate's opacity comes from its
//! geometry's flag, overridden by the instance's `FORCE_*` flags, overridden by
//! the ray's `OPAQUE`/`NO_OPAQUE` flags; the `CULL_*` and `SKIP_*` ray flags
//! remove candidates; non-opaque candidates run the hit group's any-hit program,
//! which may ignore the hit or end the traversal; AABBs run the group's
//! intersection program, whose reports go through the same any-hit step; a hit
//! is accepted inside `[t_min, t_max]` with `t_max` shrinking to it;
//! `TERMINATE_ON_FIRST_HIT` ends at the first accepted hit. Then the committed
//! hit's closest-hit program runs (unless `SKIP_CLOSEST_HIT_SHADER`), or the
//! miss program. Hit records are found as on the device: `instance SBT offset +
//! geometry index × stride + ray offset`.

use std::cell::{Cell, RefCell, UnsafeCell};
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;

use glam::{Affine3A, UVec3, Vec3, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray as BvhRay;
use raykit_device::cpu::{Erased, Invocation, Runtime, TraceCall, TypeInfo};
use raykit_device::exception::{ExceptionDetails, EXCEPTION_CAPACITY, TRACE_DEPTH_EXCEEDED};
use raykit_device::stage::HitBuiltins;
use raykit_device::{Ray, Traversable, HIT_KIND_BACK_FACING_TRIANGLE, HIT_KIND_FRONT_FACING_TRIANGLE};

use super::accel::{Geometry, Leaf, SceneData, SceneInstance};
use super::buffers::Words;
use super::lanes::{self, LaneYielder};
use super::packet::{self, Packet, Traced};
use super::program::{Aligned, PipelineData, Program, SbtData, ATTRIBUTE_BYTES};
use super::{CpuContext, TILE};
use crate::accel::InstanceFlags;
use crate::error::{Error, Result, UserException};
use crate::handles::{check_handles, TraversableState};

/// `SpvRayFlags…KHR` bits.
mod ray_flags {
    pub const OPAQUE: u32 = 0x1;
    pub const NO_OPAQUE: u32 = 0x2;
    pub const TERMINATE_ON_FIRST_HIT: u32 = 0x4;
    pub const SKIP_CLOSEST_HIT: u32 = 0x8;
    pub const CULL_BACK_FACING: u32 = 0x10;
    pub const CULL_FRONT_FACING: u32 = 0x20;
    pub const CULL_OPAQUE: u32 = 0x40;
    pub const CULL_NO_OPAQUE: u32 = 0x80;
    pub const SKIP_TRIANGLES: u32 = 0x100;
    pub const SKIP_AABBS: u32 = 0x200;
}

/// Everything a launch reads, fixed when it starts.
pub(crate) struct LaunchJob {
    pub(crate) ctx: Arc<CpuContext>,
    pub(crate) pipeline: Arc<PipelineData>,
    pub(crate) sbt: Arc<SbtData>,
    pub(crate) params: Aligned,
    pub(crate) dims: [u32; 3],
    /// The buffer table when the launch started, by slot.
    pub(crate) buffers: super::slots::Snapshot<Words>,
    /// The texture table when the launch started, by slot.
    pub(crate) textures: super::textures::Snapshot,
    /// The live IASes when the launch started, with their addresses (a few:
    /// searched in order, faster than hashing on every trace).
    pub(crate) scenes: Vec<(u64, Arc<SceneData>)>,
    /// Whether traversals run [`Traversal::run_avx2`] (the CPU has its features).
    avx2: bool,
    /// Whether invocations run in blocks of lanes whose camera rays are traced
    /// in packets (the context allows it and the CPU has AVX2).
    packets: bool,
}

impl LaunchJob {
    /// A launch of `pipeline` with `sbt` and `params` over `dims`, seeing the
    /// context's buffers and IASes as they are now.
    pub(crate) fn new(pipeline: Arc<PipelineData>, sbt: Arc<SbtData>, params: &[u8], dims: [u32; 3]) -> LaunchJob {
        let ctx = pipeline.ctx.clone();
        let buffers = ctx.buffers.snapshot();
        let textures = ctx.textures.snapshot();
        let scenes = ctx.scenes().iter().map(|(a, s)| (*a, s.data.clone())).collect::<Vec<_>>();
        let avx2 = has_avx2();
        let packets = avx2 && ctx.packets;
        LaunchJob {
            ctx,
            pipeline,
            sbt,
            params: Aligned::new(params, 0),
            dims,
            buffers,
            textures,
            scenes,
            avx2,
            packets,
        }
    }
}

/// Whether the CPU has every feature [`Traversal::run_avx2`] is compiled for.
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("lzcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Why an invocation stopped early.
enum Failure {
    Panicked { program: &'static str, message: String },
    Fault { program: &'static str, problem: String },
}

/// What one invocation (or tile) left.
#[derive(Default)]
struct Outcome {
    exceptions: Vec<UserException>,
    failure: Option<LaunchFailure>,
}

/// A failed invocation: its position in launch order, its index and why.
type LaunchFailure = (u64, [u32; 3], Failure);

/// A fault: a program asked for something the device would not define (an
/// unknown traversable, a record past the SBT, a payload of another type).
/// Unwinds the invocation; the launch returns it as an error.
struct Fault(String);

/// What an any-hit program decided by not returning.
enum AnyHitEnd {
    Ignore,
    Terminate,
}

/// Runs the launch; returns its error, if any, after every invocation ran.
pub(crate) fn run(job: &LaunchJob) -> Result<()> {
    let [w, h, d] = job.dims;
    // Lanes' tiles are larger, so that more invocations share what a tile
    // sets up, but not so large that a thread gets fewer than 64 of them on
    // average: the load would not balance.
    let count = |size: u32| u64::from(w.div_ceil(size)) * u64::from(h.div_ceil(size)) * u64::from(d);
    let enough = 64 * job.ctx.pool.current_num_threads() as u64;
    let tile_size = match job.packets {
        true if count(4 * TILE) >= enough => 4 * TILE,
        true => 2 * TILE,
        false => TILE,
    };
    let (tiles_x, tiles_y) = (w.div_ceil(tile_size), h.div_ceil(tile_size));
    let tiles = u64::from(tiles_x) * u64::from(tiles_y) * u64::from(d);
    let stop = AtomicBool::new(false);
    let outcomes: Vec<Outcome> = job.ctx.pool.install(|| {
        use rayon::prelude::*;
        (0..tiles)
            .into_par_iter()
            .map(|tile| {
                let mut outcome = Outcome::default();
                if stop.load(Ordering::Relaxed) {
                    return outcome;
                }
                let z = (tile / (u64::from(tiles_x) * u64::from(tiles_y))) as u32;
                let rest = tile % (u64::from(tiles_x) * u64::from(tiles_y));
                let (ty, tx) = ((rest / u64::from(tiles_x)) as u32, (rest % u64::from(tiles_x)) as u32);
                if job.packets {
                    run_tile_in_lanes(job, [tx * tile_size, ty * tile_size, z], tile_size, &mut outcome);
                    if outcome.failure.is_some() {
                        stop.store(true, Ordering::Relaxed);
                    }
                    return outcome;
                }
                // One state for the tile's invocations, its lists reused.
                let mut state = InvocationState::new(job);
                for y in ty * tile_size..((ty + 1) * tile_size).min(h) {
                    for x in tx * tile_size..((tx + 1) * tile_size).min(w) {
                        state.launch_index = UVec3::new(x, y, z);
                        state.failed_in.set(None);
                        outcome.failure = invoke(&state, &mut outcome.exceptions);
                        if outcome.failure.is_some() {
                            stop.store(true, Ordering::Relaxed);
                            return outcome;
                        }
                    }
                }
                outcome
            })
            .collect()
    });
    let mut failures: Vec<(u64, [u32; 3], Failure)> = Vec::new();
    let mut exceptions = Vec::new();
    for outcome in outcomes {
        failures.extend(outcome.failure);
        exceptions.extend(outcome.exceptions);
    }
    failures.sort_by_key(|f| f.0);
    if let Some((_, launch_index, failure)) = failures.into_iter().next() {
        return Err(match failure {
            Failure::Panicked { program, message } => {
                Error::ProgramPanicked { program: program.to_owned(), launch_index, message }
            }
            Failure::Fault { program, problem } => {
                Error::CpuLaunchFault { program: program.to_owned(), launch_index, problem }
            }
        });
    }
    if exceptions.is_empty() {
        return Ok(());
    }
    exceptions.sort_by_key(|e| linear_index(job.dims, e.launch_index));
    let total = u32::try_from(exceptions.len()).unwrap_or(u32::MAX);
    exceptions.truncate(EXCEPTION_CAPACITY as usize);
    Err(crate::pipeline::exceptions_error(total, exceptions, job.pipeline.max_trace_depth))
}

/// The state of one invocation, shared by its nested program calls.
struct InvocationState<'j> {
    job: &'j LaunchJob,
    launch_index: UVec3,
    /// The innermost program a failure is unwinding (or unwound) through:
    /// what the failure is reported from.
    failed_in: Cell<Option<&'static str>>,
    exceptions: RefCell<Vec<UserException>>,
    /// Pairs of types (declared, given) found equal by name, by identity: a
    /// program receiving what it received before is not compared by name again.
    same_types: Cell<[TypePair; 4]>,
    /// While the invocation runs in a lane of a block: where its packet
    /// traces go.
    lane: Cell<Option<LaneSeat>>,
    /// Where the invocation's first trace a packet could take started: its
    /// traces from there (a camera's rays) go in packets.
    camera: Cell<Option<Vec3>>,
}

impl<'j> InvocationState<'j> {
    fn new(job: &'j LaunchJob) -> Self {
        InvocationState {
            job,
            launch_index: UVec3::ZERO,
            failed_in: Cell::new(None),
            exceptions: RefCell::new(Vec::new()),
            // No name function is at address 0: nothing matches these.
            same_types: Cell::new([(0, 0); 4]),
            lane: Cell::new(None),
            camera: Cell::new(None),
        }
    }
}

/// Where an invocation running in a lane of a block sends its packet traces.
#[derive(Copy, Clone)]
struct LaneSeat {
    /// What the lane suspends through.
    yielder: *const LaneYielder,
    /// The block's packet.
    packet: *const UnsafeCell<Packet>,
    /// The lane's index in the block and its packet.
    index: usize,
}

/// Runs the tile of `size × size` invocations from `[x0, y0, z]` in
/// [`packet::WIDTH`] lanes, their camera rays traced in packets. Lane `i` runs
/// the tile's invocations `i`, `i + WIDTH`, … in rows of blocks of
/// 4 × `WIDTH / 4` invocations, so that the lanes' rays stay close together.
/// Once an invocation failed, lanes run only the invocations before it in
/// launch order, so the tile reports its first failure in launch order.
fn run_tile_in_lanes(job: &LaunchJob, [x0, y0, z]: [u32; 3], size: u32, outcome: &mut Outcome) {
    let [w, h, _] = job.dims;
    let (x_end, y_end) = ((x0 + size).min(w), (y0 + size).min(h));
    let (bw, bh) = if y_end - y0 == 1 { (packet::WIDTH as u32, 1) } else { (4, packet::WIDTH as u32 / 4) };
    // The launch-order position of the first failure so far.
    let first_failure = Cell::new(u64::MAX);
    let outcomes: [RefCell<Outcome>; packet::WIDTH] = std::array::from_fn(|_| RefCell::default());
    let packet = UnsafeCell::new(Packet::new());
    let body = |lane: usize, yielder: &LaneYielder| {
        let mut state = InvocationState::new(job);
        state.lane.set(Some(LaneSeat { yielder, packet: &packet, index: lane }));
        let mut outcome = outcomes[lane].borrow_mut();
        // The lane's place in each block.
        let (dx, dy) = (lane as u32 % bw, lane as u32 / bw);
        for by in (y0..y_end).step_by(bh as usize) {
            for bx in (x0..x_end).step_by(bw as usize) {
                let (x, y) = (bx + dx, by + dy);
                if x >= x_end || y >= y_end {
                    continue;
                }
                let index = UVec3::new(x, y, z);
                if linear_index(job.dims, index.to_array()) > first_failure.get() {
                    continue;
                }
                state.launch_index = index;
                state.failed_in.set(None);
                state.camera.set(None);
                if let Some(failure) = invoke(&state, &mut outcome.exceptions) {
                    first_failure.set(first_failure.get().min(failure.0));
                    // Only invocations before the first failure run after it.
                    outcome.failure = Some(failure);
                }
            }
        }
    };
    let mut packet_rays = 0;
    let traced = lanes::run_lanes(packet::WIDTH, &body, || {
        // SAFETY: every lane is suspended or finished: none holds a reference
        // into the packet (they do only while they run).
        let packet = unsafe { &mut *packet.get() };
        packet_rays += u64::from(packet.trace_waiting());
    });
    job.ctx.packet_rays.fetch_add(packet_rays, Ordering::Relaxed);
    if let Err(e) = traced {
        let index = [x0, y0, z];
        let failure = Failure::Fault { program: "(launch)", problem: e.to_string() };
        outcome.failure = Some((linear_index(job.dims, index), index, failure));
        return;
    }
    for lane in outcomes {
        let mut lane = lane.into_inner();
        outcome.exceptions.append(&mut lane.exceptions);
        if let Some(failure) = lane.failure {
            if outcome.failure.as_ref().is_none_or(|f| failure.0 < f.0) {
                outcome.failure = Some(failure);
            }
        }
    }
}

/// Notes the program a failure unwinds through (dropped only while
/// unwinding: [`Frame::run`] forgets it when the program returns).
struct NoteUnwinding<'s> {
    failed_in: &'s Cell<Option<&'static str>>,
    program: &'static str,
}

impl Drop for NoteUnwinding<'_> {
    fn drop(&mut self) {
        if self.failed_in.get().is_none() {
            self.failed_in.set(Some(self.program));
        }
    }
}

/// The identities of two types found equal (see [`TypeInfo::identity`]).
type TypePair = (usize, usize);

/// Runs the raygen program at `state.launch_index`.
/// The user exceptions it threw go to `exceptions`; a failure is returned.
fn invoke(state: &InvocationState<'_>, exceptions: &mut Vec<UserException>) -> Option<LaunchFailure> {
    let (job, index) = (state.job, state.launch_index);
    let record = job.sbt.regions[0].first()?;
    let raygen = job.pipeline.groups[record.group].general?;
    let frame = Frame { state, depth: 0, traversal: None };
    let result = catch_unwind(AssertUnwindSafe(|| {
        let mut inv = frame.invocation(&HitBuiltins::ZERO);
        inv.record = record.data.ptr();
        frame.run(raygen, &mut inv);
    }));
    {
        let mut thrown = state.exceptions.borrow_mut();
        if !thrown.is_empty() {
            exceptions.append(&mut thrown);
        }
    }
    let payload = result.err()?;
    let program = state.failed_in.get().unwrap_or(raygen.name);
    let failure = match payload.downcast::<Fault>() {
        Ok(fault) => Failure::Fault { program, problem: fault.0 },
        Err(payload) => Failure::Panicked { program, message: panic_message(payload.as_ref()) },
    };
    Some((linear_index(job.dims, index.to_array()), index.to_array(), failure))
}

/// The position of `index` in launch order: `x + width × (y + height × z)`.
fn linear_index([w, h, _]: [u32; 3], [x, y, z]: [u32; 3]) -> u64 {
    u64::from(x) + u64::from(w) * (u64::from(y) + u64::from(h) * u64::from(z))
}

/// The message of a panic payload (`panic!`'s string, or a note that it had none).
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(a panic without a message)".to_owned()
    }
}

/// Ends the invocation with a fault.
fn fault(problem: String) -> ! {
    resume_unwind(Box::new(Fault(problem)))
}

/// A program running, as its runtime: the invocation it belongs to, the depth
/// of the ray it runs for, and, in intersection and any-hit programs, the
/// traversal it runs inside.
struct Frame<'s, 'j> {
    state: &'s InvocationState<'j>,
    depth: u32,
    traversal: Option<&'s Traversal<'s>>,
}

impl<'j> Frame<'_, 'j> {
    fn job(&self) -> &'j LaunchJob {
        self.state.job
    }

    /// An invocation of this frame with `hit` as its hit built-ins and every
    /// pointer null.
    #[inline(always)]
    fn invocation<'a>(&'a self, hit: &'a HitBuiltins) -> Invocation<'a> {
        let job = self.job();
        Invocation {
            runtime: self,
            launch_index: self.state.launch_index,
            launch_dimensions: UVec3::from_array(job.dims),
            world_ray_origin: Vec3::ZERO,
            world_ray_direction: Vec3::ZERO,
            hit,
            params: job.params.ptr(),
            record: std::ptr::null(),
            payload: std::ptr::null_mut(),
            attributes: std::ptr::null_mut(),
            callable_data: std::ptr::null_mut(),
            exception: ExceptionDetails::default(),
            depth: self.depth,
            max_trace_depth: job.pipeline.max_trace_depth,
            specialization: &job.pipeline.specialization,
        }
    }

    /// Calls `program` with `inv`; a failure unwinding out of it is noted as
    /// coming from it, unless a program it called was noted first.
    fn run(&self, program: Program, inv: &mut Invocation<'_>) {
        let unwinding = NoteUnwinding { failed_in: &self.state.failed_in, program: program.name };
        (program.cpu.run)(inv);
        std::mem::forget(unwinding);
        // A failure the program caught itself is not the invocation's.
        self.state.failed_in.set(None);
    }

    /// Whether a trace of `ray` into `scene` goes in a packet: the invocation
    /// runs in a lane, no program can run while the ray traverses (triangles
    /// only, all opaque or made so by the ray; no flag a packet does not
    /// follow), and the ray starts where the invocation's first such trace did
    /// (a camera's rays).
    fn packet_ready(&self, scene: &SceneData, ray: &Ray, call: TraceCall) -> bool {
        const PACKET_FLAGS: u32 =
            ray_flags::OPAQUE | ray_flags::TERMINATE_ON_FIRST_HIT | ray_flags::SKIP_CLOSEST_HIT | ray_flags::SKIP_AABBS;
        if self.state.lane.get().is_none() || call.flags & !PACKET_FLAGS != 0 {
            return false;
        }
        if !(scene.all_opaque_triangles || (scene.all_triangles && call.flags & ray_flags::OPAQUE != 0)) {
            return false;
        }
        match self.state.camera.get() {
            Some(camera) => camera == ray.origin,
            None => {
                self.state.camera.set(Some(ray.origin));
                true
            }
        }
    }

    /// Suspends the invocation until its block has traced `ray` in a packet;
    /// the committed hit and its attributes, if any (`Some(None)`: a miss), or
    /// `None` when the packet could not take the ray.
    #[allow(clippy::option_option)]
    fn trace_in_packet(
        &self,
        scene: &SceneData,
        ray: &Ray,
        call: TraceCall,
    ) -> Option<Option<(Committed, Attributes)>> {
        let seat = self.state.lane.get()?;
        let first_hit = call.flags & ray_flags::TERMINATE_ON_FIRST_HIT != 0;
        // SAFETY: the lanes of a block run one at a time on this thread, and
        // while one runs nothing else holds a reference into their packet (the
        // block's driver does only while every lane is suspended; a lane only
        // within this call, not across its suspension).
        unsafe { &mut *(*seat.packet).get() }.request(
            seat.index,
            scene,
            ray.origin,
            ray.direction,
            ray.t_min,
            ray.t_max,
            call.cull_mask,
            first_hit,
        );
        // SAFETY: the lane's coroutine made the yielder and is running this call.
        unsafe { &*seat.yielder }.suspend(());
        let (traced, hit) = {
            // SAFETY: as for the request above; the hit is copied out before
            // anything else runs.
            let packet = unsafe { &*(*seat.packet).get() };
            let (traced, hit) = packet.outcome(seat.index);
            (traced, *hit)
        };
        match traced {
            Traced::Hit => {
                let instance = &scene.instances[hit.instance as usize];
                let record = u64::from(instance.sbt_offset)
                    + u64::from(hit.geometry) * u64::from(call.sbt_stride)
                    + u64::from(call.sbt_offset);
                let hit_kind = if hit.front { HIT_KIND_FRONT_FACING_TRIANGLE } else { HIT_KIND_BACK_FACING_TRIANGLE };
                let committed = Committed {
                    t: hit.t,
                    hit_kind,
                    instance: hit.instance,
                    geometry: hit.geometry,
                    primitive: hit.primitive,
                    record,
                };
                let mut attributes: Attributes = [0; ATTRIBUTE_BYTES / 16];
                bytemuck::cast_slice_mut::<u128, f32>(&mut attributes)[..2].copy_from_slice(&[hit.u, hit.v]);
                Some(Some((committed, attributes)))
            }
            Traced::Miss => Some(None),
            Traced::Alone => None,
        }
    }

    /// Traces `ray` by itself; the committed hit and its attributes, if any.
    /// Not inlined into [`Runtime::trace`], whose frame stays small for the
    /// lanes' stacks.
    #[inline(never)]
    fn trace_alone(
        &self,
        scene: &SceneData,
        ray: Ray,
        call: TraceCall,
        depth: u32,
        payload: &Erased<'_>,
    ) -> Option<(Committed, Attributes)> {
        let traversal = Traversal::new(self, scene, ray, call, depth, payload);
        traversal.run();
        traversal.committed.get().map(|hit| (hit, traversal.committed_attributes.get()))
    }

    /// Checks that `program` receives `what` of type `given`: at once when the
    /// pair was found equal before in this tile.
    #[inline(always)]
    fn check_type(&self, program: Program, what: &str, declared: Option<TypeInfo>, given: TypeInfo) {
        let Some(declared) = declared else { return };
        let pair = (declared.identity(), given.identity());
        if !self.state.same_types.get().contains(&pair) {
            self.compare_types(program, what, declared, given);
        }
    }

    /// [`Frame::check_type`] for a pair not seen yet: compares the types by
    /// name and remembers them when equal.
    #[inline(never)]
    fn compare_types(&self, program: Program, what: &str, declared: TypeInfo, given: TypeInfo) {
        if declared != given {
            fault(format!(
                "`{}` takes a {what} of type {declared:?}, but was given one of type {given:?}",
                program.name
            ));
        }
        let mut seen = self.state.same_types.get();
        seen.rotate_right(1);
        seen[0] = (declared.identity(), given.identity());
        self.state.same_types.set(seen);
    }

    /// The record at `index` of `region` (1 miss, 2 hit, 3 callable).
    fn record(&self, region: usize, index: u64, what: &str) -> &'j super::program::Record {
        let records = &self.job().sbt.regions[region];
        usize::try_from(index).ok().and_then(|i| records.get(i)).unwrap_or_else(|| {
            fault(format!(
                "{what} {index} is past the SBT's {} record(s) of that region; build the SBT with a record there",
                records.len()
            ))
        })
    }
}

impl Runtime for Frame<'_, '_> {
    fn buffer(&self, buffer: u32) -> &[AtomicU32] {
        match self.job().buffers.get((buffer & (raykit_abi::BUFFER_TABLE_SLOTS - 1)) as usize) {
            Some(Some(b)) => b,
            _ => &[],
        }
    }

    fn trace(&self, scene: Traversable, ray: Ray, call: TraceCall, payload: Erased<'_>) {
        let job = self.job();
        let depth = self.depth + 1;
        if depth > job.pipeline.max_trace_depth {
            self.throw_exception(self.state.launch_index, TRACE_DEPTH_EXCEEDED, true);
            return;
        }
        let address = scene.device_address();
        let Some((_, scene)) = job.scenes.iter().find(|(a, _)| *a == address) else {
            fault(format!("a trace into traversable {address:#x}, which is no live IAS of this Context"));
        };
        let traced = if self.packet_ready(scene, &ray, call) { self.trace_in_packet(scene, &ray, call) } else { None };
        let committed = match traced {
            Some(committed) => committed,
            None => self.trace_alone(scene, ray, call, depth, &payload),
        };
        let frame = Frame { state: self.state, depth, traversal: None };
        match committed {
            Some((hit, mut attributes)) => {
                if call.flags & ray_flags::SKIP_CLOSEST_HIT != 0 {
                    return;
                }
                let record = frame.record(2, hit.record, "hit record");
                let Some(program) = job.pipeline.groups[record.group].closest_hit else { return };
                frame.check_type(program, "payload", program.cpu.payload, payload.ty);
                let builtins = hit_builtins(job, self.state.launch_index, scene, &ray, call, &hit, hit.t, hit.hit_kind);
                let mut inv = frame.invocation(&builtins);
                inv.record = record.data.ptr();
                inv.payload = payload.ptr;
                inv.attributes = attributes.as_mut_ptr().cast();
                frame.run(program, &mut inv);
            }
            None => {
                let record = frame.record(1, u64::from(call.miss_index), "miss index");
                let Some(program) = job.pipeline.groups[record.group].general else { return };
                frame.check_type(program, "payload", program.cpu.payload, payload.ty);
                let mut inv = frame.invocation(&HitBuiltins::ZERO);
                inv.world_ray_origin = ray.origin;
                inv.world_ray_direction = ray.direction;
                inv.record = record.data.ptr();
                inv.payload = payload.ptr;
                frame.run(program, &mut inv);
            }
        }
    }

    fn call(&self, sbt_index: u32, data: Erased<'_>) {
        let job = self.job();
        let record = self.record(3, u64::from(sbt_index), "callable index");
        let Some(program) = job.pipeline.groups[record.group].general else { return };
        self.check_type(program, "callable data", program.cpu.callable_data, data.ty);
        let frame = Frame { state: self.state, depth: self.depth, traversal: None };
        let mut inv = frame.invocation(&HitBuiltins::ZERO);
        inv.record = record.data.ptr();
        inv.callable_data = data.ptr;
        frame.run(program, &mut inv);
    }

    fn throw_exception(&self, launch_index: UVec3, code: u32, run_exception_program: bool) {
        self.state.exceptions.borrow_mut().push(UserException { code, launch_index: launch_index.to_array() });
        let job = self.job();
        let Some(group) = job.pipeline.exception_group.filter(|_| run_exception_program) else { return };
        let Some(program) = job.pipeline.groups[group].general else { return };
        let record = job.sbt.regions[3].iter().find(|r| r.group == group);
        let frame = Frame { state: self.state, depth: self.depth, traversal: None };
        let mut inv = frame.invocation(&HitBuiltins::ZERO);
        inv.exception = ExceptionDetails { code, launch_index };
        inv.record = record.map_or(std::ptr::null(), |r| r.data.ptr());
        frame.run(program, &mut inv);
    }

    fn report_intersection(&self, t: f32, hit_kind: u32) -> bool {
        match self.traversal {
            Some(traversal) => traversal.report(t, hit_kind),
            None => fault("report_intersection outside an intersection program".to_owned()),
        }
    }

    fn ignore_intersection(&self) -> ! {
        resume_unwind(Box::new(AnyHitEnd::Ignore))
    }

    fn terminate_ray(&self) -> ! {
        resume_unwind(Box::new(AnyHitEnd::Terminate))
    }

    fn sample_texture(&self, texture: u32, uv: glam::Vec2, lod: f32) -> glam::Vec4 {
        super::textures::sample(&self.job().textures, texture, uv, lod)
    }
}

/// Hit attributes: `ATTRIBUTE_BYTES`, aligned to 16.
type Attributes = [u128; ATTRIBUTE_BYTES / 16];

/// A hit accepted so far.
#[derive(Copy, Clone, Debug)]
struct Committed {
    t: f32,
    hit_kind: u32,
    instance: u32,
    geometry: u32,
    primitive: u32,
    record: u64,
}

/// The primitive being tested.
#[derive(Copy, Clone)]
struct Candidate {
    instance: u32,
    geometry: u32,
    primitive: u32,
    record: u64,
    opaque: bool,
}

/// One trace through one IAS.
struct Traversal<'f> {
    frame: &'f Frame<'f, 'f>,
    scene: &'f SceneData,
    ray: Ray,
    call: TraceCall,
    depth: u32,
    t_max: Cell<f32>,
    committed: Cell<Option<Committed>>,
    committed_attributes: Cell<Attributes>,
    /// Where the running intersection program writes its attributes.
    attribute_target: Cell<*mut u128>,
    /// The payload of the trace, for any-hit programs.
    payload: Cell<*mut u8>,
    payload_type: TypeInfo,
    /// The candidate an intersection program runs for.
    candidate: Cell<Option<Candidate>>,
    terminated: Cell<bool>,
}

impl<'f> Traversal<'f> {
    fn new(
        frame: &'f Frame<'f, 'f>,
        scene: &'f SceneData,
        ray: Ray,
        call: TraceCall,
        depth: u32,
        payload: &Erased<'_>,
    ) -> Self {
        Traversal {
            frame,
            scene,
            ray,
            call,
            depth,
            t_max: Cell::new(ray.t_max),
            committed: Cell::new(None),
            committed_attributes: Cell::new([0; ATTRIBUTE_BYTES / 16]),
            attribute_target: Cell::new(std::ptr::null_mut()),
            payload: Cell::new(payload.ptr),
            payload_type: payload.ty,
            candidate: Cell::new(None),
            terminated: Cell::new(false),
        }
    }

    fn flags(&self) -> u32 {
        self.call.flags
    }

    /// Walks the IAS's tree, then each instance's GAS tree: compiled for AVX2
    /// (with FMA, POPCNT, LZCNT and BMI) where the CPU has it, else for the
    /// target's baseline. Rust never fuses a multiply and an add by itself, so
    /// both compute the same values.
    fn run(&self) {
        #[cfg(target_arch = "x86_64")]
        if self.frame.job().avx2 {
            // SAFETY: the CPU has every feature `run_avx2` is compiled for
            // (`has_avx2` checked them when the launch started).
            unsafe { self.run_avx2() };
            return;
        }
        self.walk::<false>();
    }

    /// [`Traversal::walk`] compiled for AVX2 and its companions.
    ///
    /// # Safety
    /// The CPU must have the features named below.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    unsafe fn run_avx2(&self) {
        self.walk::<true>();
    }

    /// Walks the IAS's tree, then each instance's GAS tree; `AVX2` only
    /// inside [`Traversal::run_avx2`].
    #[inline(always)]
    fn walk<const AVX2: bool>(&self) {
        let origin = Vec3A::from(self.ray.origin);
        let direction = Vec3A::from(self.ray.direction);
        // An empty or NaN interval hits nothing.
        if self.ray.t_min.partial_cmp(&self.ray.t_max).is_none_or(|o| o == std::cmp::Ordering::Greater) {
            return;
        }
        // One instance (`Ias::single`, the common case): its GAS's tree does
        // every box test the IAS's would, so the IAS's is skipped.
        if let [only] = &self.scene.instances[..] {
            if !only.gas.leaves.is_empty() {
                self.instance::<AVX2>(0);
            }
            return;
        }
        let bvh = &self.scene.bvh;
        let mut world_ray = BvhRay::new(origin, direction, self.ray.t_min, self.t_max.get());
        let mut state = bvh.new_traversal(direction);
        let mut node;
        {
            use glam::UVec2;
            obvhs::traverse!(bvh, node, state, intersect_node::<AVX2>(node, &world_ray, state.oct_inv4), {
                let index = bvh.primitive_indices[state.primitive_id as usize];
                self.instance::<AVX2>(index);
                if self.terminated.get() {
                    break;
                }
                world_ray.tmax = self.t_max.get();
            });
        }
    }

    /// Traverses instance `index`.
    #[inline(always)]
    fn instance<const AVX2: bool>(&self, index: u32) {
        let instance: &SceneInstance = &self.scene.instances[index as usize];
        if u32::from(instance.mask) & self.call.cull_mask & 0xff == 0 {
            return;
        }
        let w2o: Affine3A = instance.world_to_object;
        let origin = w2o.transform_point3(self.ray.origin);
        let direction = w2o.transform_vector3(self.ray.direction);
        let gas = &instance.gas;
        let bvh = &gas.bvh;
        let (o, d) = (Vec3A::from(origin), Vec3A::from(direction));
        let mut ray = BvhRay::new(o, d, self.ray.t_min, self.t_max.get());
        #[cfg(target_arch = "x86_64")]
        if let (true, Some(blocks)) = (AVX2, &gas.flat) {
            // A small GAS: every triangle, eight at a time, in leaf order.
            for (b, block) in blocks.iter().enumerate() {
                // SAFETY: `AVX2` is true only inside `run_avx2`, run where the CPU has its features.
                let hits = unsafe { super::flat::intersect(block, o, d, self.ray.t_min, self.t_max.get()) };
                let mut lanes = hits.lanes;
                while lanes != 0 {
                    let lane = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    // An earlier candidate may have moved `t_max` closer.
                    if hits.t.0[lane] > self.t_max.get() {
                        continue;
                    }
                    let leaf = &gas.leaves[8 * b + lane];
                    let found = (hits.t.0[lane], hits.u.0[lane], hits.v.0[lane], hits.det.0[lane]);
                    self.primitive(index, instance, leaf, o, d, &ray, Some(found));
                    if self.terminated.get() {
                        return;
                    }
                }
            }
            return;
        }
        let mut state = bvh.new_traversal(d);
        let mut node;
        use glam::UVec2;
        obvhs::traverse!(bvh, node, state, intersect_node::<AVX2>(node, &ray, state.oct_inv4), {
            let leaf = &gas.leaves[state.primitive_id as usize];
            self.primitive(index, instance, leaf, o, d, &ray, None);
            if self.terminated.get() {
                break;
            }
            ray.tmax = self.t_max.get();
        });
    }

    /// Tests one primitive of instance `index`; a triangle's intersection
    /// `(t, u, v, determinant)` may come `found` already.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn primitive(
        &self,
        index: u32,
        instance: &SceneInstance,
        leaf: &Leaf,
        origin: Vec3A,
        direction: Vec3A,
        ray: &BvhRay,
        found: Option<(f32, f32, f32, f32)>,
    ) {
        let (geometry, primitive) = (leaf.geometry, leaf.primitive);
        let geo = &instance.gas.geometries[geometry as usize];
        let flags = self.flags();
        let mut opaque = geo.opaque();
        if instance.flags.contains(InstanceFlags::FORCE_OPAQUE) {
            opaque = true;
        }
        if instance.flags.contains(InstanceFlags::FORCE_NON_OPAQUE) {
            opaque = false;
        }
        if flags & ray_flags::OPAQUE != 0 {
            opaque = true;
        }
        if flags & ray_flags::NO_OPAQUE != 0 {
            opaque = false;
        }
        if (opaque && flags & ray_flags::CULL_OPAQUE != 0) || (!opaque && flags & ray_flags::CULL_NO_OPAQUE != 0) {
            return;
        }
        let record = u64::from(instance.sbt_offset)
            + u64::from(geometry) * u64::from(self.call.sbt_stride)
            + u64::from(self.call.sbt_offset);
        let candidate = Candidate { instance: index, geometry, primitive, record, opaque };
        match geo {
            Geometry::Triangles { .. } => {
                if flags & ray_flags::SKIP_TRIANGLES != 0 {
                    return;
                }
                let Some((t, u, v, det)) =
                    found.or_else(|| intersect_triangle(&leaf.triangle, origin, direction, ray.tmin, self.t_max.get()))
                else {
                    return;
                };
                // Facing is decided in object space, where the instance's flip
                // applies: a triangle whose vertices run counter-clockwise as seen
                // from the ray's origin is front-facing (a positive determinant
                // here), as Vulkan drivers decide.
                let mut front = det > 0.0;
                if instance.flags.contains(InstanceFlags::FLIP_TRIANGLE_FACING) {
                    front = !front;
                }
                if !instance.flags.contains(InstanceFlags::DISABLE_TRIANGLE_CULLING)
                    && ((front && flags & ray_flags::CULL_FRONT_FACING != 0)
                        || (!front && flags & ray_flags::CULL_BACK_FACING != 0))
                {
                    return;
                }
                let hit_kind = if front { HIT_KIND_FRONT_FACING_TRIANGLE } else { HIT_KIND_BACK_FACING_TRIANGLE };
                let mut attributes: Attributes = [0; ATTRIBUTE_BYTES / 16];
                bytemuck::cast_slice_mut::<u128, f32>(&mut attributes)[..2].copy_from_slice(&[u, v]);
                self.consider(candidate, t, hit_kind, attributes);
            }
            Geometry::Aabbs { boxes, .. } => {
                if flags & ray_flags::SKIP_AABBS != 0 {
                    return;
                }
                if boxes[primitive as usize].intersect_ray(ray) == f32::INFINITY {
                    return;
                }
                self.intersect(candidate);
            }
        }
    }

    /// Runs the candidate's intersection program.
    fn intersect(&self, candidate: Candidate) {
        let frame = self.frame;
        let job = frame.job();
        let record = frame.record(2, candidate.record, "hit record");
        let Some(program) = job.pipeline.groups[record.group].intersection else { return };
        self.candidate.set(Some(candidate));
        let inner = Frame { state: frame.state, depth: self.depth, traversal: Some(self) };
        let mut attributes: Attributes = [0; ATTRIBUTE_BYTES / 16];
        let probe = Committed {
            t: self.t_max.get(),
            hit_kind: 0,
            instance: candidate.instance,
            geometry: candidate.geometry,
            primitive: candidate.primitive,
            record: candidate.record,
        };
        let builtins = self.builtins(&probe, self.t_max.get(), 0);
        let mut inv = inner.invocation(&builtins);
        inv.record = record.data.ptr();
        inv.attributes = attributes.as_mut_ptr().cast();
        // The program writes its attributes here; `report` reads them from the cell.
        self.attribute_target.set(attributes.as_mut_ptr());
        let result = catch_unwind(AssertUnwindSafe(|| inner.run(program, &mut inv)));
        self.attribute_target.set(std::ptr::null_mut());
        if let Err(payload) = result {
            match payload.downcast::<AnyHitEnd>() {
                // An any-hit program ended the ray from inside a report.
                Ok(end) if matches!(*end, AnyHitEnd::Terminate) => {
                    frame.state.failed_in.set(None);
                    self.terminated.set(true);
                }
                Ok(_) => fault("ignore_intersection outside an any-hit program".to_owned()),
                Err(payload) => resume_unwind(payload),
            }
        }
        self.candidate.set(None);
    }

    /// A hit reported by the running intersection program.
    fn report(&self, t: f32, hit_kind: u32) -> bool {
        let Some(candidate) = self.candidate.get() else {
            fault("report_intersection outside an intersection program".to_owned());
        };
        if !(self.ray.t_min..=self.t_max.get()).contains(&t) {
            return false;
        }
        let target = self.attribute_target.get();
        let mut attributes: Attributes = [0; ATTRIBUTE_BYTES / 16];
        if !target.is_null() {
            // SAFETY: `target` is the intersection program's attribute storage,
            // alive while it runs (this call comes from it).
            attributes = unsafe { *(target as *const Attributes) };
        }
        self.consider(candidate, t, hit_kind, attributes)
    }

    /// Runs the any-hit step for a hit at `t` and commits it if accepted;
    /// whether it was.
    fn consider(&self, candidate: Candidate, t: f32, hit_kind: u32, attributes: Attributes) -> bool {
        let hit = Committed {
            t,
            hit_kind,
            instance: candidate.instance,
            geometry: candidate.geometry,
            primitive: candidate.primitive,
            record: candidate.record,
        };
        let mut terminate = self.flags() & ray_flags::TERMINATE_ON_FIRST_HIT != 0;
        if !candidate.opaque {
            let frame = self.frame;
            let record = frame.record(2, candidate.record, "hit record");
            if let Some(program) = frame.job().pipeline.groups[record.group].any_hit {
                frame.check_type(program, "payload", program.cpu.payload, self.payload_type);
                let inner = Frame { state: frame.state, depth: self.depth, traversal: Some(self) };
                let mut attrs = attributes;
                let builtins = self.builtins(&hit, t, hit_kind);
                let mut inv = inner.invocation(&builtins);
                inv.record = record.data.ptr();
                inv.payload = self.payload.get();
                inv.attributes = attrs.as_mut_ptr().cast();
                match catch_unwind(AssertUnwindSafe(|| inner.run(program, &mut inv))) {
                    Ok(()) => {}
                    Err(payload) => match payload.downcast::<AnyHitEnd>() {
                        Ok(end) => {
                            // Not a failure: the any-hit program ended as it may.
                            frame.state.failed_in.set(None);
                            match *end {
                                AnyHitEnd::Ignore => return false,
                                AnyHitEnd::Terminate => terminate = true,
                            }
                        }
                        Err(payload) => resume_unwind(payload),
                    },
                }
            }
        }
        self.t_max.set(t);
        self.committed.set(Some(hit));
        self.committed_attributes.set(attributes);
        if terminate {
            self.terminated.set(true);
            if self.candidate.get().is_some() {
                // Inside an intersection program: end it too.
                resume_unwind(Box::new(AnyHitEnd::Terminate));
            }
        }
        true
    }

    /// The built-ins of hit stages for `hit`, with `t_max` as `ray_tmax`.
    fn builtins(&self, hit: &Committed, t_max: f32, hit_kind: u32) -> HitBuiltins {
        let frame = self.frame;
        hit_builtins(frame.job(), frame.state.launch_index, self.scene, &self.ray, self.call, hit, t_max, hit_kind)
    }
}

/// The built-ins of hit stages for `hit` of a trace of `ray` into `scene` by
/// invocation `launch_index`, with `t_max` as `ray_tmax`. An instance without
/// a transform (the identity) makes the object-space ray the world-space one.
#[allow(clippy::too_many_arguments)]
fn hit_builtins(
    job: &LaunchJob,
    launch_index: UVec3,
    scene: &SceneData,
    ray: &Ray,
    call: TraceCall,
    hit: &Committed,
    t_max: f32,
    hit_kind: u32,
) -> HitBuiltins {
    let instance = &scene.instances[hit.instance as usize];
    let (object_ray_origin, object_ray_direction) = if instance.identity {
        (ray.origin, ray.direction)
    } else {
        let w2o = instance.world_to_object;
        (w2o.transform_point3(ray.origin), w2o.transform_vector3(ray.direction))
    };
    let [object_to_world, world_to_object] = instance.builtin_matrices;
    HitBuiltins {
        launch_index,
        launch_dimensions: UVec3::from_array(job.dims),
        world_ray_origin: ray.origin,
        world_ray_direction: ray.direction,
        object_ray_origin,
        object_ray_direction,
        ray_tmin: ray.t_min,
        ray_tmax: t_max,
        ray_flags: call.flags,
        hit_kind,
        primitive_index: hit.primitive,
        instance_id: hit.instance,
        instance_custom_index: instance.custom_index,
        geometry_index: hit.geometry,
        object_to_world,
        world_to_object,
    }
}

/// The hit mask of `node`'s children for `ray` (see [`CwBvhNode::intersect_ray`]);
/// `AVX2` only where the CPU has the features of [`Traversal::run_avx2`].
#[inline(always)]
fn intersect_node<const AVX2: bool>(node: &CwBvhNode, ray: &BvhRay, oct_inv4: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: `AVX2` is true only inside `run_avx2`, run where the CPU has its features.
        return unsafe { intersect_node_avx2(node, ray, oct_inv4) };
    }
    node.intersect_ray(ray, oct_inv4)
}

/// [`CwBvhNode::intersect_ray`] with the eight children at once: the same
/// operations on each child (its quantized bounds widened exactly to `f32`, one
/// multiply and one add per slab plane, the same min/max order), so the same
/// mask, without the four-wide version's 48 scalar conversions.
///
/// # Safety
/// The CPU must have the features named below.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
unsafe fn intersect_node_avx2(node: &CwBvhNode, ray: &BvhRay, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    /// obvhs's lower bound on a child's entry distance.
    const EPSILON: f32 = 0.0001;
    let dir_inv = node.compute_extent() * ray.inv_direction;
    let origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // Eight quantized coordinates as `f32`s.
    let slab = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, dir_inv: f32, origin: f32| {
        let (lo, hi) = (super::simd::quantized(lo), super::simd::quantized(hi));
        let (near, far) = if negative { (hi, lo) } else { (lo, hi) };
        let (scale, offset) = (_mm256_set1_ps(dir_inv), _mm256_set1_ps(origin));
        (_mm256_add_ps(_mm256_mul_ps(near, scale), offset), _mm256_add_ps(_mm256_mul_ps(far, scale), offset))
    };
    let (tmin_x, tmax_x) = slab(&node.child_min_x, &node.child_max_x, ray.direction.x < 0.0, dir_inv.x, origin.x);
    let (tmin_y, tmax_y) = slab(&node.child_min_y, &node.child_max_y, ray.direction.y < 0.0, dir_inv.y, origin.y);
    let (tmin_z, tmax_z) = slab(&node.child_min_z, &node.child_max_z, ray.direction.z < 0.0, dir_inv.z, origin.z);
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(EPSILON));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(ray.tmax));
    let hits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tmin, tmax)) as u32;
    super::simd::child_mask(node, hits, oct_inv4)
}

/// Möller–Trumbore: `(t, u, v, determinant)` of a hit inside `[t_min, t_max]`.
#[inline(always)]
fn intersect_triangle(
    tri: &super::accel::Triangle,
    origin: Vec3A,
    direction: Vec3A,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32, f32)> {
    let p = direction.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri.v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = direction.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t >= t_min && t <= t_max).then_some((t, u, v, det))
}

/// A launch running on its own thread, which runs the tiles on the context's pool.
pub(crate) struct CpuLaunch {
    ctx: Arc<CpuContext>,
    thread: Option<std::thread::JoinHandle<Result<()>>>,
}

impl CpuLaunch {
    /// Checks the handles of `params` and of the SBT's checked records against
    /// the context's live objects, and the scenes of `params` against the SBT's
    /// hit records, as Vulkan launches do (see [`crate::handles`] and
    /// [`crate::validate::scene`]), then starts the launch.
    pub(crate) fn submit<P: raykit_device::LaunchParams>(
        pipeline: &Arc<PipelineData>,
        sbt: &crate::Sbt,
        records: &Arc<SbtData>,
        params: &P,
        dims: [u32; 3],
    ) -> Result<CpuLaunch> {
        let ctx = &pipeline.ctx;
        let params = bytemuck::bytes_of(params);
        let live = |handle| ctx.buffers.is_live(handle);
        let texture = |handle| ctx.textures.is_live(handle);
        let scenes = ctx.scenes();
        let traversable = |address| scenes.get(&address).map_or(TraversableState::Unknown, |s| s.check.state());
        check_handles(&pipeline.handle_fields, params, None, live, texture, traversable)?;
        for record in &sbt.checked {
            let region = Some((record.region, record.index));
            check_handles(&record.fields, &record.data, region, live, texture, traversable)?;
        }
        let hit_reach = |address| scenes.get(&address).map(|s| s.check.reach.clone());
        crate::validate::scene::check_scene(hit_reach, &pipeline.handle_fields, params, sbt, &pipeline.reach)?;
        drop(scenes);
        Ok(CpuLaunch::start(LaunchJob::new(pipeline.clone(), records.clone(), params, dims)))
    }

    /// Starts `job`; the context counts it as running until it ends.
    pub(crate) fn start(job: LaunchJob) -> CpuLaunch {
        let ctx = job.ctx.clone();
        let running = job.ctx.start_launch();
        let thread = std::thread::spawn(move || {
            job.ctx.gate.pass();
            let result = run(&job);
            drop(job);
            drop(running);
            result
        });
        CpuLaunch { ctx, thread: Some(thread) }
    }

    /// Whether it has ended.
    pub(crate) fn is_done(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Waits for its end and returns its result.
    pub(crate) fn wait(mut self) -> Result<()> {
        self.join()
    }

    fn join(&mut self) -> Result<()> {
        let Some(thread) = self.thread.take() else { return Ok(()) };
        self.ctx.gate.open();
        match thread.join() {
            Ok(result) => result,
            // A panic outside any program (in the backend itself) ends the launch too.
            Err(payload) => Err(Error::ProgramPanicked {
                program: "(the CPU backend)".to_owned(),
                launch_index: [0; 3],
                message: panic_message(payload.as_ref()),
            }),
        }
    }
}

impl Drop for CpuLaunch {
    fn drop(&mut self) {
        // Dropping a launch waits for it, as on Vulkan; its errors are discarded.
        let _ = self.join();
    }
}

impl std::fmt::Debug for CpuLaunch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Launch").field("backend", &"cpu").field("done", &self.is_done()).finish()
    }
}
