//! The runtime of programs on the CPU backend: what a program running as a
//! Rust function calls back into (buffers, traces, callables, exceptions,
//! intersection reports, textures), as the device's built-in functions.

use std::cell::Cell;
use std::panic::resume_unwind;
use std::sync::atomic::AtomicU32;

use glam::{UVec3, Vec3};
use raykit_device::cpu::{Erased, Invocation, Runtime, TraceCall, TypeInfo};
use raykit_device::exception::{ExceptionDetails, TRACE_DEPTH_EXCEEDED};
use raykit_device::stage::HitBuiltins;
use raykit_device::{Ray, Traversable, HIT_KIND_BACK_FACING_TRIANGLE, HIT_KIND_FRONT_FACING_TRIANGLE};

use super::accel::SceneData;
use super::job::{fault, AnyHitEnd, LaunchJob};
use super::packet::Traced;
use super::program::Program;
use super::traverse::{hit_builtins, ray_flags, Attributes, Committed, Frame, Traversal};
use crate::error::UserException;
use crate::validate::link::ATTRIBUTE_BYTES;

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

impl<'j> Frame<'_, 'j> {
    pub(super) fn job(&self) -> &'j LaunchJob {
        self.state.job
    }

    /// An invocation of this frame with `hit` as its hit built-ins and every
    /// pointer null.
    #[inline(always)]
    pub(super) fn invocation<'a>(&'a self, hit: &'a HitBuiltins) -> Invocation<'a> {
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
            specialization: &[],
        }
    }

    /// Calls `program` with `inv`; a failure unwinding out of it is noted as
    /// coming from it, unless a program it called was noted first.
    pub(super) fn run<'i>(&self, program: Program, inv: &mut Invocation<'i>)
    where
        'j: 'i,
    {
        inv.specialization = self.job().pipeline.constant_sets.get(program.constants).map_or(&[], Vec::as_slice);
        let unwinding = NoteUnwinding { failed_in: &self.state.failed_in, program: program.name };
        let running = super::overflow::enter(program.cpu, &self.state.launch_index);
        (program.cpu.run)(inv);
        super::overflow::leave(running);
        std::mem::forget(unwinding);
        // A failure the program caught itself is not the invocation's.
        self.state.failed_in.set(None);
    }

    /// Whether a trace of `ray` into `scene` goes in a packet: the invocation
    /// runs in a lane (and not in a program a packet walk asked it to run), no
    /// program runs for a triangle (all opaque, or made so by the ray; boxes
    /// run theirs in the walk), the ray has no flag a packet does not follow,
    /// and it starts where the invocation's first such trace did (a camera's
    /// rays).
    fn packet_ready(&self, scene: &SceneData, ray: &Ray, call: TraceCall) -> bool {
        const PACKET_FLAGS: u32 =
            ray_flags::OPAQUE | ray_flags::TERMINATE_ON_FIRST_HIT | ray_flags::SKIP_CLOSEST_HIT | ray_flags::SKIP_AABBS;
        if self.state.lane.get().is_none() || call.flags & !PACKET_FLAGS != 0 {
            return false;
        }
        if !(scene.triangles_opaque || call.flags & ray_flags::OPAQUE != 0) {
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
    /// the walk runs the programs of the boxes the ray enters meanwhile, in
    /// this trace's traversal. The committed hit and its attributes, if any
    /// (`Some(None)`: a miss), or `None` when the packet could not take the ray.
    #[allow(clippy::option_option)]
    fn trace_in_packet(
        &self,
        scene: &SceneData,
        ray: &Ray,
        call: TraceCall,
        depth: u32,
        payload: &Erased<'_>,
    ) -> Option<Option<(Committed, Attributes)>> {
        let seat = self.state.lane.get()?;
        let first_hit = call.flags & ray_flags::TERMINATE_ON_FIRST_HIT != 0;
        let boxes = scene.boxes && call.flags & ray_flags::SKIP_AABBS == 0;
        // SAFETY: the lanes of a block run one at a time on this thread, and
        // while one runs nothing else holds a reference into their packet (the
        // block's walk does only while every lane is suspended, and a lane
        // only within this call, not across its suspension).
        unsafe { &mut *(*seat.packet).get() }.request(
            seat.index,
            scene,
            ray.origin,
            ray.direction,
            ray.t_min,
            ray.t_max,
            call.cull_mask,
            first_hit,
            boxes,
        );
        // SAFETY: the block's desks outlive its lanes.
        let desk = unsafe { &*seat.desk };
        // The traversal the candidates' programs run in.
        let traversal = boxes.then(|| Traversal::new(self, scene, *ray, call, depth, payload));
        let published = traversal.as_ref().map_or(std::ptr::null(), |t| std::ptr::from_ref(t).cast());
        desk.traversal.set(published);
        // SAFETY: the lane's coroutine made the yielder and is running this call.
        unsafe { &*seat.yielder }.suspend(());
        desk.traversal.set(std::ptr::null());
        if let Some(failure) = desk.failure.take() {
            resume_unwind(failure);
        }
        let box_hit = traversal.and_then(|t| Some((t.committed.get()?, t.committed_attributes.get())));
        let (traced, hit) = {
            // SAFETY: as for the request above; the hit is copied out before
            // anything else runs.
            let packet = unsafe { &*(*seat.packet).get() };
            let (traced, hit) = packet.outcome(seat.index);
            (traced, *hit)
        };
        let triangle = match traced {
            Traced::Alone => return None,
            Traced::Miss => None,
            Traced::Hit => {
                let instance = &scene.instances[hit.instance as usize];
                let record = crate::types::sbt::selected_hit_record(
                    instance.sbt_offset,
                    hit.geometry,
                    call.sbt_stride,
                    call.sbt_offset,
                );
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
                Some((committed, attributes))
            }
        };
        // The closer of the two (each was accepted only up to the other's distance).
        Some(match (triangle, box_hit) {
            (Some(t), Some(b)) => Some(if t.0.t < b.0.t { t } else { b }),
            (t, b) => t.or(b),
        })
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
    pub(super) fn check_type(&self, program: Program, what: &str, declared: Option<TypeInfo>, given: TypeInfo) {
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
    pub(super) fn record(&self, region: usize, index: u64, what: &str) -> &'j super::program::Record {
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
        // A ray a packet could take that passes outside the scene misses
        // without waiting for the packet.
        let in_packet = self.packet_ready(scene, &ray, call);
        let traced = match in_packet {
            true if self.state.missed_last.get()
                && scene.surely_missed(ray.origin, ray.direction, ray.t_min, ray.t_max) =>
            {
                self.state.outside_rays.set(self.state.outside_rays.get() + 1);
                Some(None)
            }
            true => self.trace_in_packet(scene, &ray, call, depth, &payload),
            false => None,
        };
        let committed = match traced {
            Some(committed) => committed,
            None => self.trace_alone(scene, ray, call, depth, &payload),
        };
        if in_packet {
            self.state.missed_last.set(committed.is_none());
        }
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
                let record = frame.record(1, crate::types::sbt::selected_miss_record(call.miss_index), "miss index");
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
