//! Packet traces: up to sixteen rays of a block of invocations traced together
//! through a scene whose triangles are opaque.
//!
//! Each group of rays with one direction octant walks the tree once. A node's
//! children are tested against the group's interval: the boxes of origins and
//! inverse directions that hold every ray of the group, widened a little, so a
//! child any ray would enter is always entered. Triangles are tested against
//! every ray at once, eight lanes at a time, with the same operations in the same
//! order as the one-ray test ([`super::intersect::intersect_triangle`]), so each ray gets the same hit as
//! alone; only which of two hits at exactly the same distance wins may differ.
//! Rays far apart in direction or origin would make the interval loose, so such
//! groups are walked one ray at a time by the same code.
//!
//! Boxes (AABB geometries) are tested against each ray as a trace alone tests
//! them; for each ray that enters one, the walk runs the candidate's programs
//! (its intersection program, and any-hit for what it reports) in the ray's own
//! traversal, as its trace alone would, on the walk's stack (see
//! [`super::launch`]), and goes on with the ray's new closest distance.

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray as BvhRay;

use super::accel::{GasData, SceneData};
use super::geometry::{Geometry, Leaf};
use super::intersect::without_negative_zeros;
use super::simd::{child_mask, quantized};
use crate::types::accel::InstanceFlags;

/// Rays in a packet: one AVX2 register of `f32` lanes per eight.
pub(crate) const WIDTH: usize = 16;
const _: () = assert!(WIDTH.is_multiple_of(8) && WIDTH <= LaneMask::BITS as usize);

/// A set of lanes, lane `i` at bit `i`.
type LaneMask = u16;

/// Rays whose directions are closer than this (the cosine of about 6°) share
/// a walk.
const COHERENT_COSINE: f32 = 0.995;

/// Rays whose origins differ by more than this fraction of their distance from
/// the world origin (or more than this, near it) are walked alone.
const COHERENT_ORIGIN: f32 = 1e-3;

/// How far node intervals are widened, relative to their ends: many ulps, so
/// that rounding never loses a child a ray enters.
const WIDEN: f32 = 1.0 / (1 << 16) as f32;

/// What became of a lane's request.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) enum Traced {
    /// The packet could not take it (a NaN or infinite origin or direction):
    /// the invocation traces it alone.
    Alone,
    Miss,
    /// It hit something.
    Hit,
}

/// A primitive whose box a lane's ray enters: leaf `leaf` of instance
/// `instance`, for a ray whose closest accepted hit so far is at `t_max`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Candidate {
    pub(crate) instance: u32,
    pub(crate) leaf: u32,
    pub(crate) t_max: f32,
}

/// What became of a [`Candidate`]: its ray's closest distance after it, and
/// whether its traversal ended (the ray terminated, or a program failed).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct Ran {
    pub(crate) t_max: f32,
    pub(crate) ended: bool,
}

/// How a walk runs a candidate for a lane's ray: `None` when it could not
/// (the lane's ray ends its walk there).
pub(crate) type AskLane<'a> = dyn FnMut(usize, Candidate) -> Option<Ran> + 'a;

/// The closest accepted triangle of a ray.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct PacketHit {
    pub(crate) t: f32,
    pub(crate) u: f32,
    pub(crate) v: f32,
    /// Front-facing, after the instance's facing flip.
    pub(crate) front: bool,
    pub(crate) instance: u32,
    pub(crate) geometry: u32,
    pub(crate) primitive: u32,
}

/// Rays lane by lane, coordinate by coordinate: `o[axis][lane]`,
/// `d[axis][lane]`; rows on 32-byte boundaries, so AVX2 loads of them never
/// split a cache line.
#[derive(Copy, Clone)]
#[repr(C, align(32))]
struct Rays {
    o: [[f32; WIDTH]; 3],
    d: [[f32; WIDTH]; 3],
}

impl Rays {
    const ZERO: Rays = Rays { o: [[0.0; WIDTH]; 3], d: [[0.0; WIDTH]; 3] };

    fn set(&mut self, lane: usize, origin: Vec3, direction: Vec3) {
        for axis in 0..3 {
            self.o[axis][lane] = origin[axis];
            self.d[axis][lane] = direction[axis];
        }
    }

    fn origin(&self, lane: usize) -> Vec3 {
        Vec3::new(self.o[0][lane], self.o[1][lane], self.o[2][lane])
    }

    fn direction(&self, lane: usize) -> Vec3 {
        Vec3::new(self.d[0][lane], self.d[1][lane], self.d[2][lane])
    }
}

/// The rays of a block's lanes waiting to be traced together, lane by lane,
/// and what they hit (the rows first, on 32-byte boundaries). A lane writes its
/// request with [`Packet::request`] and suspends; once every lane has,
/// [`Packet::trace_waiting`] traces them; each lane then reads its
/// [`Packet::outcome`].
#[repr(C, align(32))]
pub(crate) struct Packet {
    /// The rays in world space.
    world: Rays,
    t_min: [f32; WIDTH],
    /// The closest accepted hit's distance, or the ray's `t_max`.
    t_max: [f32; WIDTH],
    cull_mask: [u32; WIDTH],
    /// The scene each waiting lane's ray goes into.
    scenes: [*const SceneData; WIDTH],
    /// Lanes with a request not traced yet.
    waiting: LaneMask,
    /// Lanes that end at their first accepted hit.
    first_hit: LaneMask,
    /// Lanes still traversing.
    active: LaneMask,
    /// Lanes whose ray the packet could not take (an infinite or NaN origin
    /// or direction, or no AVX2): their invocations trace them alone.
    alone: LaneMask,
    /// Lanes that hit a triangle: their closest one is in `hits`.
    hit_lanes: LaneMask,
    /// Lanes whose rays test boxes (into a scene that has some, without `SKIP_AABBS`).
    box_lanes: LaneMask,
    hits: [PacketHit; WIDTH],
}

/// The rays of one walk, in one octant: their lanes, and the interval holding
/// their rays in the walked tree's space.
struct Group {
    lanes: LaneMask,
    origin_lo: Vec3A,
    origin_hi: Vec3A,
    /// Every ray starts at one point (`origin_lo == origin_hi`).
    shared_origin: bool,
    /// The nearest `t_min` of the group's rays.
    near: f32,
    inverse_lo: Vec3A,
    inverse_hi: Vec3A,
    /// A direction in the octant, for the tree's child order.
    octant: Vec3A,
}

impl Packet {
    pub(crate) fn new() -> Self {
        Packet {
            world: Rays::ZERO,
            t_min: [0.0; WIDTH],
            t_max: [0.0; WIDTH],
            cull_mask: [0; WIDTH],
            scenes: [std::ptr::null(); WIDTH],
            waiting: 0,
            first_hit: 0,
            active: 0,
            alone: 0,
            hit_lanes: 0,
            box_lanes: 0,
            hits: [PacketHit::default(); WIDTH],
        }
    }

    /// Lane `lane`'s request: a ray into `scene` (which outlives the trace),
    /// with `cull_mask`, ending at its first accepted hit with `first_hit`,
    /// testing boxes with `boxes`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn request(
        &mut self,
        lane: usize,
        scene: &SceneData,
        origin: Vec3,
        direction: Vec3,
        t_min: f32,
        t_max: f32,
        cull_mask: u32,
        first_hit: bool,
        boxes: bool,
    ) {
        self.world.set(lane, origin, direction);
        self.t_min[lane] = t_min;
        self.t_max[lane] = t_max;
        self.cull_mask[lane] = cull_mask;
        self.scenes[lane] = scene;
        let bit: LaneMask = 1 << lane;
        self.first_hit = if first_hit { self.first_hit | bit } else { self.first_hit & !bit };
        self.box_lanes = if boxes { self.box_lanes | bit } else { self.box_lanes & !bit };
        self.waiting |= bit;
    }

    /// Gives up the walk of the waiting lanes: each traces its ray alone.
    /// For a walk that could not go on (its stack overflowed in a candidate's
    /// programs, or none could be made).
    pub(crate) fn abandon(&mut self) {
        self.alone |= self.waiting;
        self.waiting = 0;
    }

    /// What became of lane `lane`'s last request, and its closest triangle
    /// hit (`Traced::Hit`; a box's hit is the lane's own).
    #[inline(always)]
    pub(crate) fn outcome(&self, lane: usize) -> (Traced, &PacketHit) {
        let bit: LaneMask = 1 << lane;
        let traced = if self.alone & bit != 0 {
            Traced::Alone
        } else if self.hit_lanes & bit != 0 {
            Traced::Hit
        } else {
            Traced::Miss
        };
        (traced, &self.hits[lane])
    }

    /// Traces the waiting lanes' rays: those into one scene together, asking
    /// lanes to run the programs of boxes their rays enter. Returns how many
    /// rays the packet took (the others are traced alone).
    pub(crate) fn trace_waiting(&mut self, ask: &mut AskLane<'_>) -> u32 {
        let waiting = self.waiting;
        let mut left = self.waiting;
        while left != 0 {
            let scene = self.scenes[left.trailing_zeros() as usize];
            let mut lanes: LaneMask = 0;
            let mut rest = left;
            while rest != 0 {
                let lane = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if self.scenes[lane] == scene {
                    lanes |= 1 << lane;
                }
            }
            left &= !lanes;
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the scene is one of the launch's (`LaunchJob::scenes`
            // holds it while the launch runs, and requests come from its
            // traces), and packets run only where the CPU has AVX2 and its
            // companions (`LaunchJob::packets`).
            unsafe {
                self.trace_scene(&*scene, lanes, ask)
            };
            #[cfg(not(target_arch = "x86_64"))]
            {
                self.alone |= lanes;
            }
        }
        self.waiting = 0;
        (waiting & !self.alone).count_ones()
    }

    /// Traces the rays of `lanes`, all into `scene`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn trace_scene(&mut self, scene: &SceneData, lanes: LaneMask, ask: &mut AskLane<'_>) {
        // Rays with an infinite or NaN origin or direction are traced alone; an
        // empty or NaN interval hits nothing.
        let (finite, nonempty) = self.finite_and_nonempty();
        self.alone = (self.alone & !lanes) | (lanes & !finite);
        self.hit_lanes &= !lanes;
        self.active = lanes & finite & nonempty;
        if self.active == 0 {
            return;
        }
        match &scene.instances[..] {
            // One instance: its GAS's tree does every box test the IAS's would.
            [only] => {
                if !only.gas.leaves.is_empty() {
                    self.instance(scene, 0, self.active, ask);
                }
            }
            _ => {
                let mut left = self.active;
                let world = self.world;
                while left != 0 {
                    let group = Group::next(&mut left, &world, &self.t_min);
                    self.walk_scene(scene, &group, ask);
                }
            }
        }
    }

    /// The lanes whose origin and direction are finite, and those whose `t`
    /// interval is not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn finite_and_nonempty(&self) -> (LaneMask, LaneMask) {
        use std::arch::x86_64::*;
        let (mut finite, mut nonempty) = (0, 0);
        for half in 0..WIDTH / 8 {
            let at = 8 * half;
            // SAFETY: each row holds `WIDTH` `f32`s; eight are read from `at`,
            // which is at most `WIDTH - 8`.
            let load = |row: &[f32; WIDTH]| unsafe { _mm256_loadu_ps(row.as_ptr().add(at)) };
            let zero = _mm256_setzero_ps();
            // Zero times a finite number is zero, times an infinity or NaN is NaN.
            let mut zeros = zero;
            for axis in 0..3 {
                let (o, d) = (load(&self.world.o[axis]), load(&self.world.d[axis]));
                zeros = _mm256_add_ps(zeros, _mm256_add_ps(_mm256_mul_ps(o, zero), _mm256_mul_ps(d, zero)));
            }
            let lanes = |m: __m256| (_mm256_movemask_ps(m) as LaneMask) << at;
            finite |= lanes(_mm256_cmp_ps::<_CMP_EQ_OQ>(zeros, zero));
            nonempty |= lanes(_mm256_cmp_ps::<_CMP_LE_OQ>(load(&self.t_min), load(&self.t_max)));
        }
        (finite, nonempty)
    }

    /// Walks the IAS's tree with `group` (world space), visiting instances.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn walk_scene(&mut self, scene: &SceneData, group: &Group, ask: &mut AskLane<'_>) {
        let bvh: &CwBvh = &scene.bvh;
        let mut state = bvh.new_traversal(group.octant);
        let mut node: &CwBvhNode;
        use glam::UVec2;
        let mut far = self.far(group);
        obvhs::traverse!(bvh, node, state, self.node_mask(node, group, far, state.oct_inv4), {
            let index = bvh.primitive_indices[state.primitive_id as usize];
            self.instance(scene, index, group.lanes & self.active, ask);
            if group.lanes & self.active == 0 {
                break;
            }
            far = self.far(group);
        });
    }

    /// Traverses instance `index` with the rays of `lanes` its mask lets in.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn instance(&mut self, scene: &SceneData, index: u32, lanes: LaneMask, ask: &mut AskLane<'_>) {
        let instance = &scene.instances[index as usize];
        let mut lanes = lanes;
        let mut rest = lanes;
        while rest != 0 {
            let lane = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if u32::from(instance.mask) & self.cull_mask[lane] & 0xff == 0 {
                lanes &= !(1 << lane);
            }
        }
        if lanes == 0 {
            return;
        }
        // The object-space rays, as a trace alone computes them; the identity
        // changes no value, so its arithmetic is skipped.
        let mut object = self.world;
        if !instance.identity {
            let w2o: Affine3A = instance.world_to_object;
            let mut rest = lanes;
            while rest != 0 {
                let lane = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let origin = w2o.transform_point3(self.world.origin(lane));
                let direction = w2o.transform_vector3(self.world.direction(lane));
                object.set(lane, origin, direction);
            }
        }
        let gas = &instance.gas;
        // The rays boxes are tested with, as a trace alone makes them.
        let mut box_rays = BoxRays { o: [[0.0; WIDTH]; 3], inverse: [[0.0; WIDTH]; 3] };
        if gas.boxes {
            let mut rest = lanes & self.box_lanes;
            while rest != 0 {
                let lane = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let (o, d) = (Vec3A::from(object.origin(lane)), Vec3A::from(object.direction(lane)));
                let ray = BvhRay::new(o, without_negative_zeros(d), self.t_min[lane], self.t_max[lane]);
                for axis in 0..3 {
                    box_rays.o[axis][lane] = ray.origin[axis];
                    box_rays.inverse[axis][lane] = ray.inv_direction[axis];
                }
            }
        }
        let walk = Walk { instance: index, gas, flip: instance.flags.contains(InstanceFlags::FLIP_TRIANGLE_FACING) };
        let mut left = lanes;
        while left != 0 {
            let group = Group::next(&mut left, &object, &self.t_min);
            self.walk_gas(&walk, &object, &box_rays, &group, ask);
        }
    }

    /// Walks a GAS's tree with `group` (object space), testing triangles and
    /// having lanes run the programs of boxes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn walk_gas(&mut self, walk: &Walk<'_>, rays: &Rays, box_rays: &BoxRays, group: &Group, ask: &mut AskLane<'_>) {
        let gas = walk.gas;
        let bvh: &CwBvh = &gas.bvh;
        let mut state = bvh.new_traversal(group.octant);
        let mut node: &CwBvhNode;
        use glam::UVec2;
        let mut far = self.far(group);
        obvhs::traverse!(bvh, node, state, self.node_mask(node, group, far, state.oct_inv4), {
            let leaf = &gas.leaves[state.primitive_id as usize];
            let changed = match &gas.geometries[leaf.geometry as usize] {
                Geometry::Triangles { .. } => self.triangle(walk.instance, leaf, walk.flip, rays, group),
                Geometry::Aabbs { boxes, .. } => {
                    let candidate = Candidate { instance: walk.instance, leaf: state.primitive_id, t_max: 0.0 };
                    self.aabb(&boxes[leaf.primitive as usize], candidate, box_rays, group, ask)
                }
            };
            if changed {
                if group.lanes & self.active == 0 {
                    break;
                }
                far = self.far(group);
            }
        });
    }

    /// Has each lane of the group whose ray enters `aabb` run `candidate`'s
    /// programs; whether any ray's interval or activity changed.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn aabb(
        &mut self,
        aabb: &obvhs::aabb::Aabb,
        candidate: Candidate,
        box_rays: &BoxRays,
        group: &Group,
        ask: &mut AskLane<'_>,
    ) -> bool {
        let mut lanes = box_rays.entering(aabb, group.lanes & self.active & self.box_lanes);
        let mut changed = false;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let bit: LaneMask = 1 << lane;
            match ask(lane, Candidate { t_max: self.t_max[lane], ..candidate }) {
                Some(ran) => {
                    changed |= ran.t_max != self.t_max[lane] || ran.ended;
                    self.t_max[lane] = ran.t_max;
                    if ran.ended {
                        self.active &= !bit;
                    }
                }
                None => {
                    self.active &= !bit;
                    changed = true;
                }
            }
        }
        changed
    }

    /// The farthest `t_max` of the group's active rays.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn far(&self, group: &Group) -> f32 {
        use std::arch::x86_64::*;
        let lanes = group.lanes & self.active;
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let none = _mm256_set1_ps(f32::NEG_INFINITY);
        let mut t_max = none;
        for half in 0..WIDTH / 8 {
            let lanes = _mm256_set1_epi32(i32::from(lanes) >> (8 * half));
            let walking = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(lanes, bits), bits));
            // SAFETY: `t_max` holds `WIDTH` `f32`s, a multiple of eight: the
            // unaligned load reads eight of them.
            let eight = unsafe { _mm256_loadu_ps(self.t_max.as_ptr().add(8 * half)) };
            t_max = _mm256_max_ps(t_max, _mm256_blendv_ps(none, eight, walking));
        }
        let half = _mm_max_ps(_mm256_castps256_ps128(t_max), _mm256_extractf128_ps::<1>(t_max));
        let half = _mm_max_ps(half, _mm_movehl_ps(half, half));
        _mm_cvtss_f32(_mm_max_ss(half, _mm_shuffle_ps::<0b01>(half, half)))
    }

    /// The obvhs hit mask of `node`'s children for `group`, whose active rays
    /// end by `far`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn node_mask(&self, node: &CwBvhNode, group: &Group, far: f32, oct_inv4: u32) -> u32 {
        if group.lanes & self.active == 0 {
            return 0;
        }
        if group.shared_origin {
            node_mask_avx2::<true>(node, group, far, oct_inv4)
        } else {
            node_mask_avx2::<false>(node, group, far, oct_inv4)
        }
    }

    /// Tests `leaf`'s triangle against the group's active rays and keeps the
    /// closer hits; the same arithmetic as the one-ray test, lane by lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn triangle(&mut self, instance: u32, leaf: &Leaf, flip: bool, rays: &Rays, group: &Group) -> bool {
        let lanes = group.lanes & self.active;
        let mut accepted = false;
        for half in 0..WIDTH / 8 {
            let in_half = (lanes >> (8 * half)) as u8;
            if in_half != 0 {
                accepted |= self.triangle_half(instance, leaf, flip, rays, 8 * half, in_half);
            }
        }
        accepted
    }

    /// [`Packet::triangle`] for the eight lanes from `first`, of which `lanes`
    /// (bit `i` for lane `first + i`) take part.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn triangle_half(&mut self, instance: u32, leaf: &Leaf, flip: bool, rays: &Rays, first: usize, lanes: u8) -> bool {
        use std::arch::x86_64::*;
        let tri = &leaf.triangle;
        let set = |v: Vec3A| [_mm256_set1_ps(v.x), _mm256_set1_ps(v.y), _mm256_set1_ps(v.z)];
        // SAFETY: each row holds `WIDTH` `f32`s; the unaligned load reads eight
        // from `first`, which is at most `WIDTH - 8`.
        let load = |row: &[f32; WIDTH]| unsafe { _mm256_loadu_ps(row.as_ptr().add(first)) };
        let found = super::simd::intersect_triangles(
            rays.o.each_ref().map(load),
            rays.d.each_ref().map(load),
            set(tri.v0),
            set(tri.e1),
            set(tri.e2),
            load(&self.t_min),
            load(&self.t_max),
            lanes,
        );
        let mut accepted = found.lanes;
        if accepted == 0 {
            return false;
        }
        let (ts, us, vs, dets) = (found.t.0, found.u.0, found.v.0, found.det.0);
        while accepted != 0 {
            let i = accepted.trailing_zeros() as usize;
            accepted &= accepted - 1;
            let lane = first + i;
            self.t_max[lane] = ts[i];
            self.hit_lanes |= 1 << lane;
            self.hits[lane] = PacketHit {
                t: ts[i],
                u: us[i],
                v: vs[i],
                front: (dets[i] > 0.0) != flip,
                instance,
                geometry: leaf.geometry,
                primitive: leaf.primitive,
            };
            if self.first_hit & (1 << lane) != 0 {
                self.active &= !(1 << lane);
            }
        }
        true
    }
}

/// The rays boxes are tested with, lane by lane: the origins and inverse
/// directions of the object-space rays a trace alone would test them with
/// (obvhs's `Ray`); rows on 32-byte boundaries.
#[repr(C, align(32))]
struct BoxRays {
    o: [[f32; WIDTH]; 3],
    inverse: [[f32; WIDTH]; 3],
}

impl BoxRays {
    /// The lanes of `lanes` whose rays enter `aabb`: obvhs's `Aabb::intersect_ray`
    /// eight lanes at a time, with the same operations in the same order (its
    /// minima and maxima, and glam's reductions over the axes), so each lane
    /// decides as alone.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn entering(&self, aabb: &obvhs::aabb::Aabb, lanes: LaneMask) -> LaneMask {
        use std::arch::x86_64::*;
        let mut entering = 0;
        for half in 0..WIDTH / 8 {
            let at = 8 * half;
            if (lanes >> at) & 0xff == 0 {
                continue;
            }
            // SAFETY: each row holds `WIDTH` `f32`s; eight are read from `at`,
            // which is at most `WIDTH - 8`.
            let load = |row: &[f32; WIDTH]| unsafe { _mm256_loadu_ps(row.as_ptr().add(at)) };
            let slab = |axis: usize| {
                let (o, inverse) = (load(&self.o[axis]), load(&self.inverse[axis]));
                let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(aabb.min[axis]), o), inverse);
                let t2 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(aabb.max[axis]), o), inverse);
                (_mm256_min_ps(t1, t2), _mm256_max_ps(t1, t2))
            };
            let ((near_x, far_x), (near_y, far_y), (near_z, far_z)) = (slab(0), slab(1), slab(2));
            // glam's `max_element` and `min_element`: (x ∘ z) ∘ (y ∘ z).
            let near = _mm256_max_ps(_mm256_max_ps(near_x, near_z), _mm256_max_ps(near_y, near_z));
            let far = _mm256_min_ps(_mm256_min_ps(far_x, far_z), _mm256_min_ps(far_y, far_z));
            let hit = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(far, near),
                _mm256_cmp_ps::<_CMP_GE_OQ>(far, _mm256_setzero_ps()),
            );
            entering |= (_mm256_movemask_ps(hit) as LaneMask) << at;
        }
        entering & lanes
    }
}

/// The instance a GAS walk is for: its index, its GAS, and whether it flips
/// triangles' facing.
struct Walk<'g> {
    instance: u32,
    gas: &'g GasData,
    flip: bool,
}

impl Group {
    /// Takes from `left` the next group of `rays`: the first lane, and the
    /// lanes in its octant whose rays are close to its ray (others are left
    /// for later groups, in the end alone); with the interval holding them.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    fn next(left: &mut LaneMask, rays: &Rays, t_min: &[f32; WIDTH]) -> Group {
        use std::arch::x86_64::*;
        let first = left.trailing_zeros() as usize;
        let (axis, start) = (rays.direction(first), rays.origin(first));
        let axis_length2 = axis.length_squared() * (COHERENT_COSINE * COHERENT_COSINE);
        let reach = COHERENT_ORIGIN * start.abs().max_element().max(1.0);
        let set = |v: f32| _mm256_set1_ps(v);
        let zero = _mm256_setzero_ps();
        let abs = |v: __m256| _mm256_andnot_ps(set(-0.0), v);
        let mut together: LaneMask = 1 << first;
        for half in 0..WIDTH / 8 {
            let at = 8 * half;
            // SAFETY: each row holds `WIDTH` `f32`s; eight are read from `at`,
            // which is at most `WIDTH - 8`.
            let load = |row: &[f32; WIDTH]| unsafe { _mm256_loadu_ps(row.as_ptr().add(at)) };
            let (dx, dy, dz) = (load(&rays.d[0]), load(&rays.d[1]), load(&rays.d[2]));
            let (ox, oy, oz) = (load(&rays.o[0]), load(&rays.o[1]), load(&rays.o[2]));
            // The same octant: each component below zero where the first's is.
            let below = |v: __m256, first: f32| {
                let lanes = _mm256_cmp_ps::<_CMP_LT_OQ>(v, zero);
                if first < 0.0 {
                    lanes
                } else {
                    _mm256_xor_ps(lanes, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))
                }
            };
            let octant = _mm256_and_ps(below(dx, axis.x), _mm256_and_ps(below(dy, axis.y), below(dz, axis.z)));
            // cos(angle) ≥ COHERENT_COSINE, without roots.
            let cosine = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, set(axis.x)), _mm256_mul_ps(dy, set(axis.y))),
                _mm256_mul_ps(dz, set(axis.z)),
            );
            let length2 =
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
            let aligned = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(cosine, zero),
                _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_mul_ps(cosine, cosine), _mm256_mul_ps(set(axis_length2), length2)),
            );
            let spread = _mm256_max_ps(
                abs(_mm256_sub_ps(ox, set(start.x))),
                _mm256_max_ps(abs(_mm256_sub_ps(oy, set(start.y))), abs(_mm256_sub_ps(oz, set(start.z)))),
            );
            let near = _mm256_cmp_ps::<_CMP_LE_OQ>(spread, set(reach));
            let close = _mm256_and_ps(octant, _mm256_and_ps(aligned, near));
            together |= (_mm256_movemask_ps(close) as LaneMask) << at;
        }
        together &= *left;
        *left &= !together;
        let mut group = Group {
            lanes: together,
            origin_lo: Vec3A::splat(f32::INFINITY),
            origin_hi: Vec3A::splat(f32::NEG_INFINITY),
            shared_origin: false,
            near: f32::INFINITY,
            inverse_lo: Vec3A::splat(f32::INFINITY),
            inverse_hi: Vec3A::splat(f32::NEG_INFINITY),
            octant: Vec3A::from(axis),
        };
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        // Per axis, lane by lane over the halves: the lowest and highest origin
        // and inverse direction of the group's rays; and the lowest `t_min`.
        let (mut o_lo, mut o_hi) = ([set(f32::INFINITY); 3], [set(f32::NEG_INFINITY); 3]);
        let (mut i_lo, mut i_hi) = ([set(f32::INFINITY); 3], [set(f32::NEG_INFINITY); 3]);
        let mut near = set(f32::INFINITY);
        for half in 0..WIDTH / 8 {
            let at = 8 * half;
            let in_half = _mm256_set1_epi32(i32::from(together >> at) & 0xff);
            if together >> at & 0xff == 0 {
                continue;
            }
            let lanes = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(in_half, bits), bits));
            // SAFETY: as above.
            let load = |row: &[f32; WIDTH]| unsafe { _mm256_loadu_ps(row.as_ptr().add(at)) };
            let low = |acc: __m256, v: __m256| _mm256_min_ps(acc, _mm256_blendv_ps(set(f32::INFINITY), v, lanes));
            let high = |acc: __m256, v: __m256| _mm256_max_ps(acc, _mm256_blendv_ps(set(f32::NEG_INFINITY), v, lanes));
            for axis in 0..3 {
                let (o, d) = (load(&rays.o[axis]), load(&rays.d[axis]));
                // `1 / d`, finite, with the sign `octant_of` gives `d` (zero is positive).
                let inverse = _mm256_min_ps(_mm256_max_ps(_mm256_div_ps(set(1.0), d), set(-1e30)), set(1e30));
                let inverse = _mm256_blendv_ps(inverse, set(1e30), _mm256_cmp_ps::<_CMP_EQ_OQ>(d, zero));
                o_lo[axis] = low(o_lo[axis], o);
                o_hi[axis] = high(o_hi[axis], o);
                i_lo[axis] = low(i_lo[axis], inverse);
                i_hi[axis] = high(i_hi[axis], inverse);
            }
            near = low(near, load(t_min));
        }
        // The lowest and highest of the eight lanes.
        let min = |v: __m256| {
            let h = _mm_min_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
            let h = _mm_min_ps(h, _mm_movehl_ps(h, h));
            _mm_cvtss_f32(_mm_min_ss(h, _mm_shuffle_ps::<0b01>(h, h)))
        };
        let max = |v: __m256| {
            let h = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
            let h = _mm_max_ps(h, _mm_movehl_ps(h, h));
            _mm_cvtss_f32(_mm_max_ss(h, _mm_shuffle_ps::<0b01>(h, h)))
        };
        group.origin_lo = Vec3A::from_array(o_lo.map(min));
        group.origin_hi = Vec3A::from_array(o_hi.map(max));
        group.inverse_lo = Vec3A::from_array(i_lo.map(min));
        group.inverse_hi = Vec3A::from_array(i_hi.map(max));
        group.near = min(near);
        group.shared_origin = group.origin_lo == group.origin_hi;
        group
    }
}

/// Which of `node`'s children the interval of `group` may enter within
/// `[group.near, far]`, as obvhs's hit mask: each child's box decoded to `f32`
/// (exactly: the scale is a power of two), its slab distances bounded over the
/// corners of the origin and inverse-direction boxes, the interval widened by
/// [`WIDEN`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn node_mask_avx2<const SHARED_ORIGIN: bool>(node: &CwBvhNode, group: &Group, far: f32, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    let extent = node.compute_extent();
    // The distances to one plane per child, bounded over the group's corners.
    let bounds = |q: &[u8; 8], p: f32, e: f32, o_lo: f32, o_hi: f32, i_lo: f32, i_hi: f32| {
        let plane = _mm256_add_ps(_mm256_set1_ps(p), _mm256_mul_ps(quantized(q), _mm256_set1_ps(e)));
        let a = _mm256_sub_ps(plane, _mm256_set1_ps(o_lo));
        let (il, ih) = (_mm256_set1_ps(i_lo), _mm256_set1_ps(i_hi));
        if SHARED_ORIGIN {
            let (aa, ab) = (_mm256_mul_ps(a, il), _mm256_mul_ps(a, ih));
            return (_mm256_min_ps(aa, ab), _mm256_max_ps(aa, ab));
        }
        let b = _mm256_sub_ps(plane, _mm256_set1_ps(o_hi));
        let (aa, ab, ba, bb) = (_mm256_mul_ps(a, il), _mm256_mul_ps(a, ih), _mm256_mul_ps(b, il), _mm256_mul_ps(b, ih));
        (
            _mm256_min_ps(_mm256_min_ps(aa, ab), _mm256_min_ps(ba, bb)),
            _mm256_max_ps(_mm256_max_ps(aa, ab), _mm256_max_ps(ba, bb)),
        )
    };
    let axis = |lo: &[u8; 8], hi: &[u8; 8], p: f32, e: f32, o_lo: f32, o_hi: f32, i_lo: f32, i_hi: f32| {
        let (lo_min, lo_max) = bounds(lo, p, e, o_lo, o_hi, i_lo, i_hi);
        let (hi_min, hi_max) = bounds(hi, p, e, o_lo, o_hi, i_lo, i_hi);
        // Entering at the near plane, leaving at the far one: which is which
        // follows the octant (every inverse of the group has one sign).
        if i_lo < 0.0 {
            (hi_min, lo_max)
        } else {
            (lo_min, hi_max)
        }
    };
    let (olo, ohi, ilo, ihi) = (group.origin_lo, group.origin_hi, group.inverse_lo, group.inverse_hi);
    let p = Vec3A::from(node.p);
    let (in_x, out_x) = axis(&node.child_min_x, &node.child_max_x, p.x, extent.x, olo.x, ohi.x, ilo.x, ihi.x);
    let (in_y, out_y) = axis(&node.child_min_y, &node.child_max_y, p.y, extent.y, olo.y, ohi.y, ilo.y, ihi.y);
    let (in_z, out_z) = axis(&node.child_min_z, &node.child_max_z, p.z, extent.z, olo.z, ohi.z, ilo.z, ihi.z);
    let enter = _mm256_max_ps(in_x, _mm256_max_ps(in_y, in_z));
    let leave = _mm256_min_ps(out_x, _mm256_min_ps(out_y, out_z));
    let abs = |v: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), v);
    let widen_by = _mm256_set1_ps(WIDEN);
    let enter = _mm256_sub_ps(enter, _mm256_mul_ps(abs(enter), widen_by));
    let leave = _mm256_add_ps(leave, _mm256_mul_ps(abs(leave), widen_by));
    let enter = _mm256_max_ps(enter, _mm256_set1_ps(group.near));
    let leave = _mm256_min_ps(leave, _mm256_set1_ps(far));
    let hits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(enter, leave)) as u32;
    child_mask(node, hits, oct_inv4)
}
