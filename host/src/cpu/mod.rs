//! The CPU backend (no OptiX counterpart): the same device programs, run natively on the host.
//!
//! A device crate compiles for the host as well as for SPIR-V (that is how host
//! and device share types); compiled for the host, every `#[raygen]`,
//! `#[miss]`, … function also becomes a [`CpuProgram`](raykit_device::cpu::CpuProgram)
//! that its [`EntryPoint`](raykit_device::EntryPoint) constant carries. A
//! [`Context`](crate::Context) made with [`Backend::Cpu`](crate::Backend::Cpu)
//! (or `RAYKIT_BACKEND=cpu`) runs those programs as Rust functions, behind the
//! same types and calls as on Vulkan: modules name the linked device crate
//! ([`Module::from_device_crate`](crate::Module::from_device_crate)), program
//! groups, pipelines, SBTs, GASes, IASes, buffers, launches (synchronous and
//! asynchronous), specialization constants, user exceptions, the exception
//! program, and textures. Device programs can then be debugged as ordinary
//! Rust: breakpoints, `println!`, `assert!`, sanitizers. A panic in a program
//! ends its launch with [`LaunchError::ProgramPanicked`](crate::LaunchError::ProgramPanicked), naming the program and the
//! launch index.
//!
//! What differs from Vulkan:
//! * SPIR-V modules (GLSL, WGSL, SPIR-V files) cannot run: they are refused with
//!   [`DeviceError::NotOnCpuBackend`] saying why.
//! * Traversal follows Vulkan's rules (ray flags, instance masks and flags,
//!   geometry flags, SBT offset, stride and miss-index arithmetic, the `t`
//!   interval, any-hit and intersection programs), on BVHs from
//!   [obvhs](https://crates.io/crates/obvhs): compressed-wide BVH8 trees built
//!   with PLOC, a pure-Rust library chosen over Embree 3 because it needs no
//!   system library to install or ship, and because any-hit and intersection
//!   programs, which may end a traversal by unwinding, run inside a Rust
//!   traversal rather than in callbacks from C. Embree traces single rays about
//!   1.7× faster and 16-ray packets about 3× faster on a million triangles; the
//!   traversal is compiled for AVX2 where the CPU has it. Refit rebuilds the
//!   tree; compaction keeps it.
//! * GASes of at most 64 triangles are tested without their tree, one ray
//!   against eight triangles at once (`cpu::flat`).
//! * Camera rays are traced in packets (`cpu::packet`, `cpu::lanes`): sixteen
//!   invocations of a tile run side by side as coroutines
//!   ([corosensei](https://crates.io/crates/corosensei)), each on a stack as
//!   deep as a pool thread's (their tops a quarter-kilobyte apart modulo a
//!   page, so that their hot frames share the first-level cache). A trace
//!   from where its invocation first traced, into a scene whose triangles run
//!   no program while rays traverse it, writes its ray into the block's packet
//!   and suspends the invocation until the other lanes have suspended or
//!   finished; then their rays walk the tree together, against interval
//!   bounds that hold them all, and their triangles and boxes are tested eight
//!   rays at a time; the programs of boxes a ray enters run on the walk's stack,
//!   in the ray's own traversal. Each ray gets the same hit as alone, bit for
//!   bit; only which of two hits at exactly the same distance is the closest
//!   may differ.
//!   [`ContextOptions::cpu_packets`](crate::ContextOptions::cpu_packets) (or
//!   `RAYKIT_CPU_PACKETS=0`) turns packets off;
//!   [`Context::packet_rays`](crate::Context::packet_rays) counts the rays they
//!   took. Such a trace whose ray passes outside the scene's bounds (widened
//!   by a margin that covers any rounding) misses at once, without waiting for
//!   the packet
//!   ([`Context::rays_outside_scene`](crate::Context::rays_outside_scene)
//!   counts them); one is tested so only after the lane's last such trace
//!   missed, as the camera's rays past a scene's edge do in runs.
//! * The trace depth is checked on every trace, for every ray type: a trace past
//!   the pipeline's `max_trace_depth` is not made and the launch returns
//!   [`LaunchError::RecursionTooDeep`](crate::LaunchError::RecursionTooDeep).
//! * A program that overflows its stack (recursion without end) ends its
//!   launch with [`LaunchError::StackOverflow`](crate::LaunchError::StackOverflow), naming the program and the
//!   launch index, instead of the process (see `cpu::overflow`).
//! * A launch runs in parallel over tiles of its grid (8 × 8 invocations, or
//!   32 × 32 in lanes, 16 × 16 where that would leave a thread fewer than 64
//!   tiles) on a thread pool of the context
//!   ([rayon](https://crates.io/crates/rayon)); each invocation computes the
//!   same values whatever the number of threads, user exceptions are reported
//!   in launch-index order, and a failed launch reports the first failure of
//!   its tile in launch order.
//! * Textures ([`Texture`](crate::Texture)) keep their texels in host memory,
//!   and `sample_lod` runs a sampler written to Vulkan's filtering rules
//!   (texel coordinates, address modes, bilinear weights, mip selection and
//!   blending, sRGB decoded before filtering) in `f32`: every format and filter
//!   is supported, up to 16384 texels a side
//!   (`raykit::texture::max_texture_size`).
//! * Stack sizes, pipeline libraries, compile caches, GPU timestamps and the raw
//!   Vulkan handles do not apply: those calls say so with a typed error or report
//!   nothing.

pub(crate) mod accel;
pub(crate) mod buffers;
pub(crate) mod flat;
pub(crate) mod geometry;
mod intersect;
pub(crate) mod job;
pub(crate) mod lanes;
pub(crate) mod launch;
pub(crate) mod overflow;
pub(crate) mod packet;
pub(crate) mod program;
mod runtime;
pub(crate) mod simd;
pub(crate) mod slots;
pub(crate) mod textures;
mod traverse;

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use crate::error::DeviceError;
use crate::error::{Error, Result};
use crate::log::MessageLog;
use crate::types::context::{ContextOptions, DeviceLimits};
use crate::validate::handles::{LiveIas, TraversableState};
use crate::validate::hit_reach::HitReach;
use crate::validate::launch::Liveness;

/// The invocations of one launch tile: 8 × 8.
pub(crate) const TILE: u32 = 8;

/// The device limits of the CPU backend: Vulkan's, where they bound what the
/// API accepts (record sizes, recursion), and the host's otherwise.
pub(crate) const LIMITS: DeviceLimits = DeviceLimits {
    shader_group_handle_size: 32,
    shader_group_handle_alignment: 32,
    shader_group_base_alignment: 64,
    max_shader_group_stride: 4096,
    max_ray_recursion_depth: 31,
    max_ray_dispatch_invocation_count: 1 << 30,
    max_ray_hit_attribute_size: 32,
    max_push_constants_size: 256,
    max_uniform_buffer_range: 65536,
    max_storage_buffer_range: u32::MAX,
    min_uniform_buffer_offset_alignment: 16,
    min_scratch_alignment: 128,
    max_geometry_count: 1 << 24,
    max_primitive_count: 1 << 29,
    max_instance_count: 1 << 24,
};

/// Each launch dimension's limit on the CPU backend.
pub(crate) const LAUNCH_DIMENSION_LIMITS: [u64; 3] = [1 << 30, 1 << 30, 1 << 30];

/// Stack of each of the pool's threads: deep enough for 31 levels of
/// recursion through user programs.
pub(crate) const THREAD_STACK: usize = 64 << 20;

/// A live IAS as traces reach it: its built structure and what launches check.
pub(crate) struct LiveScene {
    pub(crate) data: Arc<accel::SceneData>,
    pub(crate) check: LiveIas,
}

/// A context of the CPU backend.
pub(crate) struct CpuContext {
    pub(crate) id: u64,
    pub(crate) log: MessageLog,
    pub(crate) buffers: buffers::BufferTable,
    pub(crate) textures: textures::TextureTable,
    /// The live IASes, by the address their `Traversable` carries.
    pub(crate) scenes: Mutex<HashMap<u64, LiveScene>>,
    pub(crate) pool: rayon::ThreadPool,
    /// Whether launches trace in packets where they can (see [`packet`]).
    pub(crate) packets: bool,
    /// Rays traced in packets so far.
    pub(crate) packet_rays: AtomicU64,
    /// Rays a packet could have taken, found outside the scene instead.
    pub(crate) outside_rays: AtomicU64,
    /// The launches running, by the epoch each got when it started; reads and
    /// writes of buffers wait for them.
    running: Mutex<Running>,
    finished: Condvar,
    /// The test hook that holds launches before they start (see [`crate::gate`]).
    pub(crate) gate: Gate,
}

/// The launches of a context running now.
#[derive(Default)]
struct Running {
    /// The epoch the next launch gets.
    next: u64,
    /// The epochs of those running.
    epochs: std::collections::BTreeSet<u64>,
}

/// Holds launches before they start while closed; every host wait opens it
/// first, so a gate left closed never deadlocks (the CPU side of [`crate::gate`]).
#[derive(Default)]
pub(crate) struct Gate {
    closed: Mutex<bool>,
    opened: Condvar,
}

impl Gate {
    /// Closes the gate: launches started from now on wait.
    #[cfg(feature = "fault-injection")]
    pub(crate) fn close(&self) {
        *self.closed.lock().unwrap_or_else(|p| p.into_inner()) = true;
    }

    /// Opens the gate; held launches start.
    pub(crate) fn open(&self) {
        *self.closed.lock().unwrap_or_else(|p| p.into_inner()) = false;
        self.opened.notify_all();
    }

    /// Whether the gate is closed.
    #[cfg(feature = "fault-injection")]
    pub(crate) fn is_closed(&self) -> bool {
        *self.closed.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Blocks while the gate is closed.
    pub(crate) fn pass(&self) {
        let mut closed = self.closed.lock().unwrap_or_else(|p| p.into_inner());
        while *closed {
            closed = self.opened.wait(closed).unwrap_or_else(|p| p.into_inner());
        }
    }
}

impl std::fmt::Debug for CpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CpuContext").field("id", &self.id).field("threads", &self.pool.current_num_threads()).finish()
    }
}

impl CpuContext {
    /// A CPU context with `options.cpu_threads` threads (all the host's by default).
    pub(crate) fn new(id: u64, options: &ContextOptions) -> Result<CpuContext> {
        let threads = options
            .cpu_threads
            .or_else(|| std::env::var("RAYKIT_CPU_THREADS").ok().and_then(|v| v.parse().ok()))
            .unwrap_or(0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .stack_size(THREAD_STACK)
            .thread_name(move |i| format!("raykit-cpu-{id}-{i}"))
            .build()
            .map_err(|e| Error::Device(DeviceError::CpuThreads { reason: e.to_string() }))?;
        Ok(CpuContext {
            id,
            log: MessageLog::with_callback(options.log_callback.clone()),
            buffers: Default::default(),
            textures: Default::default(),
            scenes: Mutex::new(HashMap::new()),
            pool,
            packets: options
                .cpu_packets
                .unwrap_or_else(|| std::env::var("RAYKIT_CPU_PACKETS").map_or(true, |v| v.trim() != "0")),
            packet_rays: AtomicU64::new(0),
            outside_rays: AtomicU64::new(0),
            running: Mutex::new(Running::default()),
            finished: Condvar::new(),
            gate: Gate::default(),
        })
    }

    /// The backend's name for [`crate::Context::device_name`].
    pub(crate) fn name(&self) -> String {
        format!("raykit CPU backend ({} threads)", self.pool.current_num_threads())
    }

    pub(crate) fn scenes(&self) -> MutexGuard<'_, HashMap<u64, LiveScene>> {
        self.scenes.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn running(&self) -> MutexGuard<'_, Running> {
        self.running.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Counts a launch as running until the returned guard drops.
    pub(crate) fn start_launch(self: &Arc<Self>) -> RunningLaunch {
        let mut running = self.running();
        let epoch = running.next;
        running.next += 1;
        running.epochs.insert(epoch);
        RunningLaunch(self.clone(), epoch)
    }

    /// The epoch of the last launch started (all launches before it have
    /// smaller ones).
    pub(crate) fn last_epoch(&self) -> u64 {
        self.running().next
    }

    /// Blocks until every launch started before `epoch` has ended.
    pub(crate) fn wait_for(&self, epoch: u64) {
        self.gate.open();
        let mut running = self.running();
        while running.epochs.first().is_some_and(|first| *first < epoch) {
            running = self.finished.wait(running).unwrap_or_else(|p| p.into_inner());
        }
    }

    /// Whether a launch started before `epoch` is running.
    pub(crate) fn is_running_before(&self, epoch: u64) -> bool {
        self.running().epochs.first().is_some_and(|first| *first < epoch)
    }

    /// Blocks until no launch of this context runs.
    pub(crate) fn wait_idle(&self) {
        self.wait_for(u64::MAX);
    }
}

impl Drop for CpuContext {
    fn drop(&mut self) {
        // Every object of the context holds an `Arc` of it: none is alive now.
        self.log.mark_destroyed();
    }
}

/// A launch counted as running (see [`CpuContext::start_launch`]).
pub(crate) struct RunningLaunch(Arc<CpuContext>, u64);

impl Drop for RunningLaunch {
    fn drop(&mut self) {
        self.0.running().epochs.remove(&self.1);
        self.0.finished.notify_all();
    }
}

/// Hands out the addresses of CPU IASes: never 0, never reused in a process.
pub(crate) fn next_scene_address() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    (NEXT.fetch_add(1, Ordering::Relaxed) << 8) | 0x0c00_0000_0000_0000
}

/// What launch checks see of a CPU context: its buffer and texture tables, and
/// its scenes under their lock, held from the check until the launch has started.
pub(crate) struct CpuLiveness<'a> {
    pub(crate) ctx: &'a CpuContext,
    pub(crate) scenes: MutexGuard<'a, HashMap<u64, LiveScene>>,
}

impl Liveness for CpuLiveness<'_> {
    fn buffer(&self, handle: u32) -> bool {
        self.ctx.buffers.is_live(handle)
    }

    fn texture(&self, handle: u32) -> bool {
        self.ctx.textures.is_live(handle)
    }

    fn traversable(&self, address: u64) -> TraversableState {
        self.scenes.get(&address).map_or(TraversableState::Unknown, |s| s.check.state())
    }

    fn hit_reach(&self, address: u64) -> Option<Arc<HitReach>> {
        self.scenes.get(&address).map(|s| s.check.reach.clone())
    }
}
