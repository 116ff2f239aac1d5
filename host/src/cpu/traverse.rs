//! Traversal on the CPU backend: one trace through one IAS, the any-hit and
//! intersection programs it runs, and the built-ins of hit stages.
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

use std::any::Any;
use std::cell::Cell;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};

use glam::{Affine3A, UVec3, Vec3A};
use obvhs::ray::Ray as BvhRay;
use raykit_device::cpu::{Erased, TraceCall, TypeInfo};
use raykit_device::stage::HitBuiltins;
use raykit_device::{Ray, HIT_KIND_BACK_FACING_TRIANGLE, HIT_KIND_FRONT_FACING_TRIANGLE};

use super::accel::{SceneData, SceneInstance};
use super::geometry::{Geometry, Leaf};
use super::intersect::{intersect_node, intersect_triangle, without_negative_zeros};
use super::job::{fault, AnyHitEnd, InvocationState, LaunchJob};
use super::packet::Ran;
use crate::types::accel::InstanceFlags;
use crate::validate::link::ATTRIBUTE_BYTES;

/// `SpvRayFlags…KHR` bits.
pub(super) mod ray_flags {
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

/// A program running, as its runtime: the invocation it belongs to, the depth
/// of the ray it runs for, and, in intersection and any-hit programs, the
/// traversal it runs inside.
pub(super) struct Frame<'s, 'j> {
    pub(super) state: &'s InvocationState<'j>,
    pub(super) depth: u32,
    pub(super) traversal: Option<&'s Traversal<'s>>,
}

/// Hit attributes: `ATTRIBUTE_BYTES`, aligned to 16.
pub(super) type Attributes = [u128; ATTRIBUTE_BYTES / 16];

/// A hit accepted so far.
#[derive(Copy, Clone, Debug)]
pub(super) struct Committed {
    pub(super) t: f32,
    pub(super) hit_kind: u32,
    pub(super) instance: u32,
    pub(super) geometry: u32,
    pub(super) primitive: u32,
    pub(super) record: u64,
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

/// What is known of a primitive before [`Traversal::primitive`] tests it.
#[derive(Copy, Clone)]
enum Known<'r> {
    /// Nothing: a triangle is intersected, a box tested with this ray.
    Nothing(&'r BvhRay),
    /// A triangle's intersection `(t, u, v, determinant)`, found already.
    TriangleHit((f32, f32, f32, f32)),
    /// The ray enters the box: a packet walk tested it as this ray's would.
    BoxEntered,
}

/// One trace through one IAS.
pub(super) struct Traversal<'f> {
    frame: &'f Frame<'f, 'f>,
    scene: &'f SceneData,
    ray: Ray,
    call: TraceCall,
    depth: u32,
    t_max: Cell<f32>,
    pub(super) committed: Cell<Option<Committed>>,
    pub(super) committed_attributes: Cell<Attributes>,
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
    pub(super) fn new(
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
    pub(super) fn run(&self) {
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
        let direction = without_negative_zeros(direction);
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
        let mut ray = BvhRay::new(o, without_negative_zeros(d), self.ray.t_min, self.t_max.get());
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
                    self.primitive(index, instance, leaf, o, d, Known::TriangleHit(found));
                    if self.terminated.get() {
                        return;
                    }
                }
            }
            return;
        }
        let mut state = bvh.new_traversal(ray.direction);
        let mut node;
        use glam::UVec2;
        obvhs::traverse!(bvh, node, state, intersect_node::<AVX2>(node, &ray, state.oct_inv4), {
            let leaf = &gas.leaves[state.primitive_id as usize];
            self.primitive(index, instance, leaf, o, d, Known::Nothing(&ray));
            if self.terminated.get() {
                break;
            }
            ray.tmax = self.t_max.get();
        });
    }

    /// Runs the programs of `candidate`, a primitive whose box a packet walk
    /// found this ray enters, on the walk's stack: the traces they make go
    /// alone meanwhile (the packet is the walk's). A failure is kept in
    /// `failure`, for the lane waiting for this trace to carry out of it, and
    /// ends the ray's traversal. Returns the ray's closest distance after it.
    pub(super) fn run_candidate(
        &self,
        candidate: super::packet::Candidate,
        failure: &Cell<Option<Box<dyn Any + Send>>>,
    ) -> Ran {
        let state = self.frame.state;
        let seat = state.lane.replace(None);
        let ran = catch_unwind(AssertUnwindSafe(|| self.candidate(candidate)));
        state.lane.set(seat);
        let ended = match ran {
            Ok(()) => self.terminated(),
            Err(payload) => {
                // The unwinding skipped the programs' notes of what runs: the
                // walk itself runs none.
                super::overflow::leave(super::overflow::Running::NONE);
                failure.set(Some(payload));
                true
            }
        };
        Ran { t_max: self.t_max.get(), ended }
    }

    /// Tests `candidate` as the walk alone would (the instance's object-space
    /// ray, the same flags and programs), with the ray's closest distance so far.
    fn candidate(&self, candidate: super::packet::Candidate) {
        self.t_max.set(candidate.t_max);
        let index = candidate.instance;
        let instance: &SceneInstance = &self.scene.instances[index as usize];
        // As `instance` computes it; the identity's arithmetic is skipped (the
        // hit built-ins skip it too).
        let (origin, direction) = match instance.identity {
            true => (self.ray.origin, self.ray.direction),
            false => {
                let w2o: Affine3A = instance.world_to_object;
                (w2o.transform_point3(self.ray.origin), w2o.transform_vector3(self.ray.direction))
            }
        };
        let (o, d) = (Vec3A::from(origin), Vec3A::from(direction));
        let leaf = &instance.gas.leaves[candidate.leaf as usize];
        self.primitive(index, instance, leaf, o, d, Known::BoxEntered);
    }

    /// Whether the traversal ended (an accepted hit of a ray ending at its
    /// first, or an any-hit program's `terminate_ray`).
    fn terminated(&self) -> bool {
        self.terminated.get()
    }

    /// Tests one primitive of instance `index` with the object-space ray
    /// `origin + t direction`, knowing `known` of it.
    #[inline(always)]
    fn primitive(
        &self,
        index: u32,
        instance: &SceneInstance,
        leaf: &Leaf,
        origin: Vec3A,
        direction: Vec3A,
        known: Known<'_>,
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
        let record = crate::types::sbt::selected_hit_record(
            instance.sbt_offset,
            geometry,
            self.call.sbt_stride,
            self.call.sbt_offset,
        );
        let candidate = Candidate { instance: index, geometry, primitive, record, opaque };
        match geo {
            Geometry::Triangles { .. } => {
                if flags & ray_flags::SKIP_TRIANGLES != 0 {
                    return;
                }
                let found = match known {
                    Known::TriangleHit(found) => Some(found),
                    Known::Nothing(_) | Known::BoxEntered => {
                        intersect_triangle(&leaf.triangle, origin, direction, self.ray.t_min, self.t_max.get())
                    }
                };
                let Some((t, u, v, det)) = found else { return };
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
                let enters = match known {
                    Known::Nothing(ray) => boxes[primitive as usize].intersect_ray(ray) != f32::INFINITY,
                    Known::BoxEntered => true,
                    // No triangle's hit is a box's.
                    Known::TriangleHit(_) => false,
                };
                if !enters {
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
    pub(super) fn report(&self, t: f32, hit_kind: u32) -> bool {
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
pub(super) fn hit_builtins(
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
