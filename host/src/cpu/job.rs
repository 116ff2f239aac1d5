//! One CPU launch as its invocations see it: what the launch reads, fixed when
//! it starts, each invocation's state, and how a program's fault ends it.

use std::any::Any;
use std::cell::{Cell, RefCell, UnsafeCell};
use std::panic::resume_unwind;
use std::sync::Arc;

use glam::{UVec3, Vec3};

use super::accel::SceneData;
use super::buffers::Words;
use super::lanes::LaneYielder;
use super::overflow::Overflow;
use super::packet::Packet;
use super::program::{Aligned, PipelineData, SbtData};
use super::traverse::Traversal;
use super::CpuContext;
use crate::error::UserException;

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
    /// Whether traversals run [`Traversal::run_avx2`](super::traverse::Traversal::run_avx2)
    /// (the CPU has its features).
    pub(super) avx2: bool,
    /// Whether invocations run in blocks of lanes whose camera rays are traced
    /// in packets (the context allows it and the CPU has AVX2).
    pub(super) packets: bool,
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

/// Whether the CPU has every feature
/// [`Traversal::run_avx2`](super::traverse::Traversal::run_avx2) is compiled for.
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

/// The state of one invocation, shared by its nested program calls.
pub(super) struct InvocationState<'j> {
    pub(super) job: &'j LaunchJob,
    pub(super) launch_index: UVec3,
    /// The innermost program a failure is unwinding (or unwound) through:
    /// what the failure is reported from.
    pub(super) failed_in: Cell<Option<&'static str>>,
    pub(super) exceptions: RefCell<Vec<UserException>>,
    /// Pairs of types (declared, given) found equal by name, by identity: a
    /// program receiving what it received before is not compared by name again.
    pub(super) same_types: Cell<[TypePair; 4]>,
    /// While the invocation runs in a lane of a block: where its packet
    /// traces go.
    pub(super) lane: Cell<Option<LaneSeat>>,
    /// Where the invocation's first trace a packet could take started: its
    /// traces from there (a camera's rays) go in packets.
    pub(super) camera: Cell<Option<Vec3>>,
    /// Whether the last trace a packet could take (of this invocation or, in
    /// a lane, of the lane's invocation before) missed: only then is the next
    /// tested for a sure miss (misses come in runs, as a camera's rays past
    /// the scene's edge do).
    pub(super) missed_last: Cell<bool>,
    /// Traces a packet could have taken, found outside the scene instead.
    pub(super) outside_rays: Cell<u64>,
}

impl<'j> InvocationState<'j> {
    pub(super) fn new(job: &'j LaunchJob) -> Self {
        InvocationState {
            job,
            launch_index: UVec3::ZERO,
            failed_in: Cell::new(None),
            exceptions: RefCell::new(Vec::new()),
            // No name function is at address 0: nothing matches these.
            same_types: Cell::new([(0, 0); 4]),
            lane: Cell::new(None),
            camera: Cell::new(None),
            missed_last: Cell::new(true),
            outside_rays: Cell::new(0),
        }
    }
}

/// Where an invocation running in a lane of a block sends its packet traces.
#[derive(Copy, Clone)]
pub(super) struct LaneSeat {
    /// What the lane suspends through.
    pub(super) yielder: *const LaneYielder,
    /// The block's packet.
    pub(super) packet: *const UnsafeCell<Packet>,
    /// Where the lane's waiting trace meets the packet's walk.
    pub(super) desk: *const LaneDesk,
    /// The lane's index in the block and its packet.
    pub(super) index: usize,
}

/// Where a lane's trace waiting in its packet meets the walk: the traversal
/// in which the walk runs the programs of the boxes the lane's ray enters, and
/// what failed in them.
pub(super) struct LaneDesk {
    /// The traversal of the lane's waiting trace; null when its ray tests no
    /// boxes.
    pub(super) traversal: Cell<*const Traversal<'static>>,
    /// A failure of a candidate's programs (a panic's payload, or
    /// [`Overflowed`]), carried out of the lane's trace once the walk is over.
    pub(super) failure: Cell<Option<Box<dyn Any + Send>>>,
}

impl Default for LaneDesk {
    fn default() -> Self {
        LaneDesk { traversal: Cell::new(std::ptr::null()), failure: Cell::new(None) }
    }
}

/// The identities of two types found equal (see
/// [`TypeInfo::identity`](raykit_device::cpu::TypeInfo::identity)).
type TypePair = (usize, usize);

/// A fault: a program asked for something the device would not define (an
/// unknown traversable, a record past the SBT, a payload of another type).
/// Unwinds the invocation; the launch returns it as an error.
pub(super) struct Fault(pub(super) String);

/// An overflow of the stack a packet's walk ran a candidate's programs on:
/// unwinds the invocation the candidate was for, which ends with it.
pub(super) struct Overflowed(pub(super) Overflow);

/// What an any-hit program decided by not returning.
pub(super) enum AnyHitEnd {
    Ignore,
    Terminate,
}

/// Ends the invocation with a fault.
pub(super) fn fault(problem: String) -> ! {
    resume_unwind(Box::new(Fault(problem)))
}
