//! Launches on the CPU backend: the launch grid in tiles over the context's
//! thread pool, each invocation's raygen program called as a Rust function
//! (alone, or in a lane of a block whose camera rays are traced in packets),
//! and the launch's failures and user exceptions gathered in launch order.

use std::cell::{Cell, RefCell, UnsafeCell};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use glam::UVec3;
use raykit_device::exception::EXCEPTION_CAPACITY;
use raykit_device::stage::HitBuiltins;

use super::job::{Fault, InvocationState, LaneDesk, LaneSeat, LaunchJob, Overflowed};
use super::lanes::{self, LaneYielder};
use super::packet::{self, Candidate, Packet};
use super::program::{PipelineData, SbtData};
use super::traverse::Frame;
use super::CpuLiveness;
use super::{CpuContext, TILE};
use crate::error::LaunchError;
use crate::error::{Error, Result, UserException};
use crate::validate::launch::LaunchChecks;

/// Why an invocation stopped early.
enum Failure {
    Panicked { program: &'static str, message: String },
    Fault { program: &'static str, problem: String },
    StackOverflow { program: &'static str },
}

/// The failure of an invocation that overflowed its stack.
fn overflowed(job: &LaunchJob, overflow: super::overflow::Overflow) -> LaunchFailure {
    let index = overflow.launch_index;
    (linear_index(job.dims, index), index, Failure::StackOverflow { program: overflow.program })
}

/// What one invocation (or tile) left.
#[derive(Default)]
struct Outcome {
    exceptions: Vec<UserException>,
    failure: Option<LaunchFailure>,
}

/// A failed invocation: its position in launch order, its index and why.
type LaunchFailure = (u64, [u32; 3], Failure);

/// Runs the launch; returns its error, if any, after every invocation ran.
pub(crate) fn run(job: &LaunchJob) -> Result<()> {
    let [w, h, d] = job.dims;
    // A tile of about `size × size` invocations: as many rows as the launch
    // has, up to `size`, and wide enough for the rest (a launch of one row
    // gets tiles of one row, `size²` wide), so that a tile's set-up is shared
    // by as many invocations whatever the launch's shape.
    let shape = |size: u32| {
        let rows = size.min(h.max(1));
        (size * (size / rows), rows)
    };
    let count = |(tw, th): (u32, u32)| u64::from(w.div_ceil(tw)) * u64::from(h.div_ceil(th)) * u64::from(d);
    // Lanes' tiles are larger, so that more invocations share what a tile
    // sets up, but not so large that a thread gets fewer than 64 of them on
    // average: the load would not balance.
    let enough = 64 * job.ctx.pool.current_num_threads() as u64;
    let (tile_w, tile_h) = match job.packets {
        true if count(shape(4 * TILE)) >= enough => shape(4 * TILE),
        true => shape(2 * TILE),
        false => shape(TILE),
    };
    let (tiles_x, tiles_y) = (w.div_ceil(tile_w), h.div_ceil(tile_h));
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
                    run_tile_in_lanes(job, [tx * tile_w, ty * tile_h, z], [tile_w, tile_h], &mut outcome);
                    if outcome.failure.is_some() {
                        stop.store(true, Ordering::Relaxed);
                    }
                    return outcome;
                }
                // One state for the tile's invocations, its lists reused; on a
                // stack whose overflow ends the tile, not the process.
                let mut state = InvocationState::new(job);
                let guarded = super::overflow::run_guarded(|| {
                    for y in ty * tile_h..((ty + 1) * tile_h).min(h) {
                        for x in tx * tile_w..((tx + 1) * tile_w).min(w) {
                            state.launch_index = UVec3::new(x, y, z);
                            state.failed_in.set(None);
                            outcome.failure = invoke(&state, &mut outcome.exceptions);
                            if outcome.failure.is_some() {
                                return;
                            }
                        }
                    }
                });
                match guarded {
                    Ok(None) => {}
                    Ok(Some(overflow)) => outcome.failure = Some(overflowed(job, overflow)),
                    Err(e) => {
                        let index = [tx * tile_w, ty * tile_h, z];
                        let failure = Failure::Fault { program: "(launch)", problem: e.to_string() };
                        outcome.failure = Some((linear_index(job.dims, index), index, failure));
                    }
                }
                if outcome.failure.is_some() {
                    stop.store(true, Ordering::Relaxed);
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
                Error::Launch(LaunchError::ProgramPanicked { program: program.to_owned(), launch_index, message })
            }
            Failure::Fault { program, problem } => {
                Error::Launch(LaunchError::CpuLaunchFault { program: program.to_owned(), launch_index, problem })
            }
            Failure::StackOverflow { program } => Error::Launch(LaunchError::StackOverflow {
                program: program.to_owned(),
                launch_index,
                stack_bytes: super::THREAD_STACK,
            }),
        });
    }
    if exceptions.is_empty() {
        return Ok(());
    }
    exceptions.sort_by_key(|e| linear_index(job.dims, e.launch_index));
    let total = u32::try_from(exceptions.len()).unwrap_or(u32::MAX);
    exceptions.truncate(EXCEPTION_CAPACITY as usize);
    Err(crate::error::exceptions_error(total, exceptions, job.pipeline.max_trace_depth).into())
}

/// Runs the tile of `width × height` invocations from `[x0, y0, z]` in
/// [`packet::WIDTH`] lanes, their camera rays traced in packets. Lane `i` runs
/// the tile's invocations `i`, `i + WIDTH`, … in rows of blocks of
/// 4 × `WIDTH / 4` invocations, so that the lanes' rays stay close together.
/// Once an invocation failed, lanes run only the invocations before it in
/// launch order, so the tile reports its first failure in launch order.
///
/// A packet's walk runs on a guarded stack of its own (one per thread, reused,
/// so always in cache), and so do the programs of the boxes it finds: each in
/// the traversal its lane's waiting trace published ([`LaneDesk`]), without
/// switching to the lane. A failure there is the lane's: a panic is kept for
/// the lane to carry out of its trace once the walk is over; an overflow of the
/// walk's stack ends the walk, fails the lane whose candidate overflowed it,
/// and has the packet's other rays traced alone.
fn run_tile_in_lanes(job: &LaunchJob, [x0, y0, z]: [u32; 3], [width, height]: [u32; 2], outcome: &mut Outcome) {
    let [w, h, _] = job.dims;
    let (x_end, y_end) = (x0.saturating_add(width).min(w), y0.saturating_add(height).min(h));
    let (bw, bh) = if y_end - y0 == 1 { (packet::WIDTH as u32, 1) } else { (4, packet::WIDTH as u32 / 4) };
    // The launch-order position of the first failure so far.
    let first_failure = Cell::new(u64::MAX);
    let outcomes: [RefCell<Outcome>; packet::WIDTH] = std::array::from_fn(|_| RefCell::default());
    let packet = UnsafeCell::new(Packet::new());
    let outside_rays = Cell::new(0);
    let desks: [LaneDesk; packet::WIDTH] = Default::default();
    let body = |lane: usize, yielder: &LaneYielder| {
        let mut state = InvocationState::new(job);
        state.lane.set(Some(LaneSeat { yielder, packet: &packet, desk: &desks[lane], index: lane }));
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
        outside_rays.set(outside_rays.get() + state.outside_rays.get());
    };
    let mut packet_rays = 0;
    let traced = lanes::run_lanes(packet::WIDTH, &body, || {
        // The lane whose candidate the walk runs.
        let asking = Cell::new(None);
        let mut ask = |lane: usize, candidate: Candidate| {
            let traversal = desks[lane].traversal.get();
            if traversal.is_null() {
                return None;
            }
            asking.set(Some(lane));
            // SAFETY: the lane is suspended in the trace that published its
            // traversal, which lives until the lane is resumed after the walk.
            let ran = unsafe { &*traversal }.run_candidate(candidate, &desks[lane].failure);
            asking.set(None);
            Some(ran)
        };
        // SAFETY: every lane is suspended or finished: none holds a reference
        // into the packet (they do only while they make a trace's request).
        let walking = unsafe { &mut *packet.get() };
        // The walk runs the candidates' programs on its own stack, whose
        // overflow ends the invocation the candidate is for, not the block.
        let walked = super::overflow::run_guarded(|| packet_rays += u64::from(walking.trace_waiting(&mut ask)));
        if matches!(walked, Ok(None)) {
            return;
        }
        // The walk's frames were discarded, not unwound: no program runs now.
        super::overflow::leave(super::overflow::Running::NONE);
        if let (Ok(Some(overflow)), Some(lane)) = (walked, asking.get()) {
            desks[lane].failure.set(Some(Box::new(Overflowed(overflow))));
        }
        // SAFETY: the walk is over (it returned, overflowed or never began):
        // nothing else refers to the packet.
        let packet = unsafe { &mut *packet.get() };
        // The other rays are traced alone, in their own lanes: the programs of
        // candidates the walk ran for them run again (the launch fails anyway).
        packet.abandon();
    });
    job.ctx.packet_rays.fetch_add(packet_rays, Ordering::Relaxed);
    job.ctx.outside_rays.fetch_add(outside_rays.get(), Ordering::Relaxed);
    let overflows = match traced {
        Ok(overflows) => overflows,
        Err(e) => {
            let index = [x0, y0, z];
            let failure = Failure::Fault { program: "(launch)", problem: e.to_string() };
            outcome.failure = Some((linear_index(job.dims, index), index, failure));
            return;
        }
    };
    for overflow in overflows {
        let failure = overflowed(job, overflow);
        if outcome.failure.as_ref().is_none_or(|f| failure.0 < f.0) {
            outcome.failure = Some(failure);
        }
    }
    for lane in outcomes {
        // A lane that overflowed left its outcome borrowed: its frames were
        // discarded, not dropped; the outcome itself is whole.
        let mut lane = lane.into_inner();
        outcome.exceptions.append(&mut lane.exceptions);
        if let Some(failure) = lane.failure {
            if outcome.failure.as_ref().is_none_or(|f| failure.0 < f.0) {
                outcome.failure = Some(failure);
            }
        }
    }
}

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
    // A panic unwound past the programs' notes of what runs: none runs now.
    super::overflow::leave(super::overflow::Running::NONE);
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
        Err(payload) => match payload.downcast::<Overflowed>() {
            Ok(overflowed) => Failure::StackOverflow { program: overflowed.0.program },
            Err(payload) => Failure::Panicked { program, message: panic_message(payload.as_ref()) },
        },
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
/// A launch running on its own thread, which runs the tiles on the context's pool.
pub(crate) struct CpuLaunch {
    ctx: Arc<CpuContext>,
    thread: Option<std::thread::JoinHandle<Result<()>>>,
}

impl CpuLaunch {
    /// Runs the launch's `checks` while the context's scenes are locked (so no
    /// IAS drop slips in between), then starts the launch over `dims`.
    pub(crate) fn submit(
        pipeline: &Arc<PipelineData>,
        checks: LaunchChecks<'_>,
        records: &Arc<SbtData>,
        dims: [u32; 3],
    ) -> Result<CpuLaunch> {
        let ctx = &pipeline.ctx;
        let live = CpuLiveness { ctx, scenes: ctx.scenes() };
        checks.run(&live)?;
        drop(live);
        Ok(CpuLaunch::start(LaunchJob::new(pipeline.clone(), records.clone(), checks.params, dims)))
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
            Err(payload) => Err(Error::Launch(LaunchError::ProgramPanicked {
                program: "(the CPU backend)".to_owned(),
                launch_index: [0; 3],
                message: panic_message(payload.as_ref()),
            })),
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
