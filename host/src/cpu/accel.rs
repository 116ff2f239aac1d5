//! Acceleration structures of the CPU backend: a GAS is its geometries with one
//! BVH over all their primitives, an IAS its instances with one BVH over their
//! world-space bounds. Both BVHs are obvhs's compressed-wide (CWBVH) trees
//! (see [`crate::cpu`] for the choice).
//!
//! Vulkan's refit maps to a rebuild of the tree (a GAS keeps its topology, as
//! `Gas::update` requires); compaction to nothing (the tree is already as small
//! as it gets, and the compacted size reported is its size).

use std::sync::Arc;
use std::time::Duration;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb as BvhAabb;
use obvhs::cwbvh::CwBvh;
use obvhs::BvhBuildParams;
use raykit_device::Matrix4x3;

use super::geometry::{Geometry, Leaf, Triangle};
use crate::types::accel::{BuildInput, InstanceFlags};
use crate::types::accel::{GeometryFlags, IndexKind};

/// The bounds of a triangle.
fn triangle_bounds(t: &Triangle) -> BvhAabb {
    let (a, b, c) = (t.v0, t.v0 + t.e1, t.v0 + t.e2);
    BvhAabb::new(a.min(b).min(c), a.max(b).max(c))
}

/// A built GAS: its geometries and the tree over their primitives.
pub(crate) struct GasData {
    pub(crate) geometries: Vec<Geometry>,
    /// The primitives in leaf order: entry `i` is what the tree's
    /// `primitive_indices[i]` names.
    pub(crate) leaves: Vec<Leaf>,
    pub(crate) bvh: CwBvh,
    /// Bounds of everything, in object space.
    pub(crate) bounds: BvhAabb,
    /// The leaves' triangles eight at a time, for a GAS small enough to test
    /// without its tree (see [`super::flat`]).
    pub(crate) flat: Option<Box<[super::flat::TriangleBlock]>>,
    /// Whether it has boxes (an AABB geometry).
    pub(crate) boxes: bool,
}

impl std::fmt::Debug for GasData {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GasData")
            .field("geometries", &self.geometries.len())
            .field("primitives", &self.leaves.len())
            .field("nodes", &self.bvh.nodes.len())
            .finish()
    }
}

/// The build parameters for a tree of `primitives`: obvhs's medium preset (PLOC
/// with reinsertion), which builds in about a second per million triangles on
/// one core and traces within a few percent of its slowest, best preset; small
/// trees, which build in milliseconds whatever the preset, get the best one
/// (4% fewer instructions in the path tracer's Cornell box traversal).
fn build_params(primitives: usize) -> BvhBuildParams {
    if primitives <= 4096 {
        BvhBuildParams::very_slow_build()
    } else {
        BvhBuildParams::medium_build()
    }
}

impl GasData {
    /// Builds the geometries of validated `inputs` and their tree.
    pub(crate) fn build(inputs: &[BuildInput<'_>]) -> GasData {
        let built: Vec<(Geometry, Vec<Triangle>)> = inputs.iter().map(geometry).collect();
        let mut primitives = Vec::new();
        let mut boxes = Vec::new();
        for (g, (geometry, triangles)) in built.iter().enumerate() {
            let count = match geometry {
                Geometry::Triangles { count, .. } => *count,
                Geometry::Aabbs { boxes, .. } => boxes.len(),
            };
            for p in 0..count {
                let b = match geometry {
                    Geometry::Triangles { .. } => triangle_bounds(&triangles[p]),
                    Geometry::Aabbs { boxes, .. } => boxes[p],
                };
                // Degenerate (and inactive, NaN) primitives are never hit: leave them out.
                if b.min.is_finite() && b.max.is_finite() && b.min.cmple(b.max).all() {
                    primitives.push((g as u32, p as u32));
                    boxes.push(b);
                }
            }
        }
        let bounds = boxes.iter().fold(BvhAabb::empty(), |all, b| all.union(b));
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&boxes, build_params(boxes.len()), &mut Duration::default());
        let leaves: Vec<Leaf> = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let (geometry, primitive) = primitives[i as usize];
                let triangle = match &built[geometry as usize] {
                    (Geometry::Triangles { .. }, triangles) => triangles[primitive as usize],
                    (Geometry::Aabbs { .. }, _) => Triangle { v0: Vec3A::ZERO, e1: Vec3A::ZERO, e2: Vec3A::ZERO },
                };
                Leaf { triangle, geometry, primitive }
            })
            .collect();
        let geometries: Vec<Geometry> = built.into_iter().map(|(g, _)| g).collect();
        let flat = super::flat::blocks(&geometries, &leaves);
        let boxes = geometries.iter().any(|g| matches!(g, Geometry::Aabbs { .. }));
        GasData { geometries, leaves, bvh, bounds, flat, boxes }
    }

    /// Bytes the structure takes on the host.
    pub(crate) fn size(&self) -> u64 {
        let nodes = std::mem::size_of_val(&self.bvh.nodes[..]) + std::mem::size_of_val(&self.bvh.primitive_indices[..]);
        let geometry: usize = self
            .geometries
            .iter()
            .map(|g| match g {
                Geometry::Triangles { .. } => 0,
                Geometry::Aabbs { boxes, .. } => std::mem::size_of_val(&boxes[..]),
            })
            .sum();
        (nodes + geometry + std::mem::size_of_val(&self.leaves[..])) as u64
    }
}

/// One geometry from its build input, and its triangles with the geometry
/// transform applied (none for AABBs).
fn geometry(input: &BuildInput<'_>) -> (Geometry, Vec<Triangle>) {
    match input {
        BuildInput::Triangles(t) => {
            let transform = t.transform.unwrap_or(Affine3A::IDENTITY);
            let vertex = |i: u32| -> Vec3A {
                let at = i as usize * t.stride as usize;
                let v: [f32; 3] = bytemuck::pod_read_unaligned(&t.vertex_bytes[at..at + 12]);
                transform.transform_point3a(Vec3A::from(v))
            };
            let count = t.triangle_count();
            let index = |i: usize| -> u32 {
                match t.indices.kind() {
                    IndexKind::None => i as u32,
                    _ => t.indices.get(i),
                }
            };
            let triangles = (0..count)
                .map(|i| {
                    let (a, b, c) = (vertex(index(3 * i)), vertex(index(3 * i + 1)), vertex(index(3 * i + 2)));
                    Triangle { v0: a, e1: b - a, e2: c - a }
                })
                .collect();
            (Geometry::Triangles { count, flags: t.flags }, triangles)
        }
        BuildInput::Aabbs(a) => {
            let boxes = (0..a.count)
                .map(|i| {
                    let b = a.aabb(i);
                    BvhAabb::new(Vec3A::from(b.min), Vec3A::from(b.max))
                })
                .collect();
            (Geometry::Aabbs { boxes, flags: a.flags }, Vec::new())
        }
    }
}

/// One instance of a built IAS.
#[derive(Debug)]
pub(crate) struct SceneInstance {
    pub(crate) gas: Arc<GasData>,
    pub(crate) object_to_world: Affine3A,
    pub(crate) world_to_object: Affine3A,
    pub(crate) custom_index: u32,
    pub(crate) mask: u8,
    pub(crate) sbt_offset: u32,
    pub(crate) flags: InstanceFlags,
    /// The instance has no transform: object space is world space.
    pub(crate) identity: bool,
    /// `object_to_world` and `world_to_object` as hit programs receive them.
    pub(crate) builtin_matrices: [Matrix4x3; 2],
}

impl SceneInstance {
    /// An instance of `gas` placed by `object_to_world`.
    pub(crate) fn new(
        gas: Arc<GasData>,
        object_to_world: Affine3A,
        custom_index: u32,
        mask: u8,
        sbt_offset: u32,
        flags: InstanceFlags,
    ) -> SceneInstance {
        let world_to_object = object_to_world.inverse();
        SceneInstance {
            gas,
            object_to_world,
            world_to_object,
            custom_index,
            mask,
            sbt_offset,
            flags,
            identity: object_to_world == Affine3A::IDENTITY,
            builtin_matrices: [builtin_matrix(object_to_world), builtin_matrix(world_to_object)],
        }
    }
}

/// An affine transform as the 4×3 matrix built-ins.
fn builtin_matrix(a: Affine3A) -> Matrix4x3 {
    Matrix4x3 {
        x_axis: a.matrix3.x_axis.into(),
        y_axis: a.matrix3.y_axis.into(),
        z_axis: a.matrix3.z_axis.into(),
        w_axis: a.translation.into(),
    }
}

/// A built IAS: what a trace of its `Traversable` runs through.
pub(crate) struct SceneData {
    pub(crate) instances: Vec<SceneInstance>,
    pub(crate) bvh: CwBvh,
    /// Every triangle is opaque (see [`triangles_opaque`]).
    pub(crate) triangles_opaque: bool,
    /// Some instance's GAS has boxes (an AABB geometry).
    pub(crate) boxes: bool,
    /// Which rays [`SceneData::surely_missed`] finds missing everything.
    sure_misses: SureMisses,
}

/// Which rays surely miss everything in a scene.
#[derive(Copy, Clone, Debug)]
enum SureMisses {
    /// Every ray: the scene has nothing to hit.
    All,
    /// Those that pass outside the world bounds of every instance.
    Outside(SceneBounds),
    /// None is told apart: the scene's lone instance has a transform, and its
    /// rays are walked through its GAS without a test of its world bounds
    /// (see `Packet::trace_scene`), whose rounding of the transform's inverse
    /// the bounds' margin does not cover.
    Unknown,
}

impl std::fmt::Debug for SceneData {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneData").field("instances", &self.instances.len()).finish_non_exhaustive()
    }
}

impl SceneData {
    /// Builds the tree over `instances`' world bounds.
    pub(crate) fn build(instances: Vec<SceneInstance>) -> SceneData {
        let boxes: Vec<BvhAabb> = instances.iter().map(world_bounds).collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&boxes, build_params(boxes.len()), &mut Duration::default());
        let all = boxes.iter().fold(BvhAabb::empty(), |all, b| all.union(b));
        let lone_transformed = matches!(&instances[..], [only] if !only.identity);
        let sure_misses = match all.min.cmple(all.max).all() {
            true if lone_transformed => SureMisses::Unknown,
            true => SureMisses::Outside(SceneBounds::new(all.min, all.max)),
            false => SureMisses::All,
        };
        let triangles_opaque = triangles_opaque(&instances);
        let boxes = instances.iter().any(|instance| instance.gas.boxes);
        SceneData { instances, bvh, triangles_opaque, boxes, sure_misses }
    }

    /// Whether a ray surely misses everything in the scene (see
    /// [`SceneBounds::surely_outside`]).
    #[inline(never)]
    pub(crate) fn surely_missed(&self, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> bool {
        match &self.sure_misses {
            SureMisses::All => true,
            SureMisses::Outside(bounds) => bounds.surely_outside(origin, direction, t_min, t_max),
            SureMisses::Unknown => false,
        }
    }

    /// Bytes the structure takes on the host.
    pub(crate) fn size(&self) -> u64 {
        (std::mem::size_of_val(&self.bvh.nodes[..])
            + std::mem::size_of_val(&self.bvh.primitive_indices[..])
            + std::mem::size_of_val(&self.instances[..])) as u64
    }
}

/// The relative margin of [`SceneBounds::surely_outside`]: 2^-16, 256 times
/// `f32`'s unit roundoff, where the box and triangle tests it stands in for
/// round by a few units.
const SURE_MISS_MARGIN: f32 = 1.0 / 65536.0;

/// A box rays are tested against for sure misses.
#[derive(Copy, Clone, Debug)]
pub(crate) struct SceneBounds {
    lo: Vec3A,
    hi: Vec3A,
    /// The largest magnitude of their coordinates.
    reach: f32,
}

impl SceneBounds {
    /// The box from `lo` to `hi`.
    pub(crate) fn new(lo: Vec3A, hi: Vec3A) -> SceneBounds {
        SceneBounds { lo, hi, reach: lo.abs().max(hi.abs()).max_element() }
    }

    /// Whether the ray from `origin` along `direction`, over
    /// `[t_min, t_max]`, surely passes outside the box: outside it even
    /// widened by a margin far larger than the rounding of any test inside (a
    /// relative [`SURE_MISS_MARGIN`] of the largest coordinate of the box and
    /// the ray's origin, and of the distances along the ray). `false` for any
    /// ray it cannot tell about (a NaN or infinite origin or direction,
    /// infinite bounds).
    pub(crate) fn surely_outside(&self, origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> bool {
        let (o, d) = (Vec3A::from(origin), Vec3A::from(direction));
        let reach = self.reach.max(o.abs().max_element());
        let margin = Vec3A::splat(reach * SURE_MISS_MARGIN);
        let inverse = d.recip();
        let (near, far) = ((self.lo - margin - o) * inverse, (self.hi + margin - o) * inverse);
        // A zero direction component gives infinite distances, or NaN where
        // the origin lies on the slab's plane: NaN excludes nothing.
        let or = |t: Vec3A, nan: f32| Vec3A::select(t.cmpeq(t), t, Vec3A::splat(nan));
        let entry = or(near, f32::NEG_INFINITY).min(or(far, f32::NEG_INFINITY)).max_element();
        let exit = or(near, f32::INFINITY).max(or(far, f32::INFINITY)).min_element();
        // (Capped, so that an infinite distance stays what it is.)
        let slack = |t: f32| (t.abs() * SURE_MISS_MARGIN).min(f32::MAX);
        let (entry, exit) = (entry - slack(entry), exit + slack(exit));
        let outside = entry > exit || exit < t_min || entry > t_max;
        // Zero for a finite origin and direction, NaN for any infinite or NaN
        // coordinate.
        let finite = ((o + d) * 0.0).cmpeq(Vec3A::ZERO).all() && reach.is_finite();
        outside && finite
    }
}

/// An instance's bounds in world space (empty for an empty GAS).
fn world_bounds(instance: &SceneInstance) -> BvhAabb {
    let b = instance.gas.bounds;
    if !(b.min.cmple(b.max).all()) {
        return BvhAabb::empty();
    }
    let mut out = BvhAabb::empty();
    for corner in 0..8 {
        let pick = |bit: u32, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi };
        let p = Vec3::new(pick(1, b.min.x, b.max.x), pick(2, b.min.y, b.max.y), pick(4, b.min.z, b.max.z));
        let w = Vec3A::from(instance.object_to_world.transform_point3(p));
        out = out.union(&BvhAabb::new(w, w));
    }
    out
}

/// A GAS of the CPU backend: its current tree (a refit replaces it) and the
/// version launches check IASes against.
pub(crate) struct CpuGas {
    pub(crate) ctx: Arc<super::CpuContext>,
    data: std::sync::Mutex<Arc<GasData>>,
    pub(crate) version: Arc<std::sync::atomic::AtomicU64>,
}

impl CpuGas {
    /// The tree as built last.
    pub(crate) fn data(&self) -> Arc<GasData> {
        self.data.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Rebuilds the tree from validated `inputs` of the same topology (Vulkan's
    /// refit); IASes built over the old tree keep it until they are updated.
    pub(crate) fn refit(&self, inputs: &[BuildInput<'_>]) {
        let data = Arc::new(GasData::build(inputs));
        *self.data.lock().unwrap_or_else(|p| p.into_inner()) = data;
        self.version.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
    }
}

/// Builds a GAS of the CPU backend from `inputs`: the tree, each geometry's
/// shape, and the tree's size in bytes.
pub(crate) fn build_gas(ctx: &Arc<super::CpuContext>, inputs: &[BuildInput<'_>]) -> (Arc<CpuGas>, u64) {
    let data = GasData::build(inputs);
    let size = data.size();
    let gas = CpuGas { ctx: ctx.clone(), data: std::sync::Mutex::new(Arc::new(data)), version: Default::default() };
    (Arc::new(gas), size)
}

/// An instance's row-major 3×4 transform as an affine map.
pub(crate) fn affine_from_rows(rows: &[f32; 12]) -> Affine3A {
    let r = |i: usize| Vec3::new(rows[4 * i], rows[4 * i + 1], rows[4 * i + 2]);
    let (r0, r1, r2) = (r(0), r(1), r(2));
    Affine3A::from_cols(
        Vec3A::new(r0.x, r1.x, r2.x),
        Vec3A::new(r0.y, r1.y, r2.y),
        Vec3A::new(r0.z, r1.z, r2.z),
        Vec3A::new(rows[3], rows[7], rows[11]),
    )
}

/// Whether every triangle of a scene of `instances` is opaque, by its
/// geometry's flag and its instance's `FORCE_*` flags (boxes may be either):
/// rays into such a scene, or with the ray's `OPAQUE` flag, run no program
/// for a triangle, so packets can take them.
pub(crate) fn triangles_opaque(instances: &[SceneInstance]) -> bool {
    let mut opaque = true;
    for instance in instances {
        for geometry in &instance.gas.geometries {
            let Geometry::Triangles { flags, .. } = geometry else { continue };
            let mut geometry_opaque = flags.contains(GeometryFlags::OPAQUE);
            if instance.flags.contains(InstanceFlags::FORCE_OPAQUE) {
                geometry_opaque = true;
            }
            if instance.flags.contains(InstanceFlags::FORCE_NON_OPAQUE) {
                geometry_opaque = false;
            }
            opaque &= geometry_opaque;
        }
    }
    opaque
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3, Vec3A};

    use super::SceneBounds;

    fn surely_outside(lo: Vec3A, hi: Vec3A, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        SceneBounds::new(lo, hi).surely_outside(o, d, t_min, t_max)
    }

    /// Whether the ray meets the box over `[t_min, t_max]`, in `f64` from the
    /// same `f32` inputs (exact enough: no `f32` rounding).
    fn meets(lo: Vec3A, hi: Vec3A, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> bool {
        let (lo, hi, o, d) = (DVec3::from(Vec3::from(lo)), DVec3::from(Vec3::from(hi)), DVec3::from(o), DVec3::from(d));
        let (mut entry, mut exit) = (f64::from(t_min), f64::from(t_max));
        for axis in 0..3 {
            if d[axis] == 0.0 {
                if o[axis] < lo[axis] || o[axis] > hi[axis] {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo[axis] - o[axis]) / d[axis], (hi[axis] - o[axis]) / d[axis]);
            entry = entry.max(a.min(b));
            exit = exit.min(a.max(b));
        }
        entry <= exit
    }

    /// A small deterministic generator: uniform in `[0, 1)`.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn vec(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * 2.0 * scale
        }
    }

    #[test]
    fn a_ray_that_meets_the_box_is_never_surely_outside_and_far_ones_are() {
        let mut rng = Lcg(7);
        let (mut met, mut far_outside) = (0, 0);
        for case in 0..200_000 {
            let scale = [1e-3, 1.0, 1e4][case % 3];
            let (a, b) = (rng.vec(scale), rng.vec(scale));
            let (mut lo, mut hi) = (a.min(b), a.max(b));
            // Flat boxes, as a planar mesh has.
            if case % 5 == 0 {
                hi.z = lo.z;
            }
            let origin = rng.vec(scale * [1.0, 4.0, 1000.0][case % 7 % 3]);
            // Aim at a point of the box: a corner, an edge, a face or inside.
            let pick = |t: f32, l: f32, h: f32| {
                if t < 0.3 {
                    l
                } else if t < 0.6 {
                    h
                } else {
                    l + (h - l) * t
                }
            };
            let target =
                Vec3::new(pick(rng.next(), lo.x, hi.x), pick(rng.next(), lo.y, hi.y), pick(rng.next(), lo.z, hi.z));
            let mut direction = match case % 4 {
                // Past the box by a little, so some rays miss it.
                0 => target - origin + rng.vec(scale * 0.05),
                _ => target - origin,
            };
            // Axis-aligned rays, some from the plane of a face.
            if case % 11 == 0 {
                direction.x = 0.0;
                if case % 2 == 0 {
                    lo.x = origin.x;
                    hi.x = hi.x.max(lo.x);
                }
            }
            let (t_min, t_max) = match case % 6 {
                0 => (0.0, 0.5),
                1 => (0.5, 2.0),
                _ => (0.0, f32::INFINITY),
            };
            let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
            if meets(lo, hi, origin, direction, t_min, t_max) {
                met += 1;
                assert!(
                    !surely_outside(lo, hi, origin, direction, t_min, t_max),
                    "case {case}: box {lo}..{hi}, ray {origin} + t {direction}, t in [{t_min}, {t_max}], meets the box"
                );
            }
            // The same ray moved far to its side: one that passes the box at a
            // tenth of its size or more is outside.
            let away = origin + direction.normalize_or_zero().any_orthonormal_vector() * 1e6 * scale;
            let size = (hi - lo).max_element().max(scale * 1e-3);
            if !meets(lo - size * 0.1, hi + size * 0.1, away, direction, 0.0, f32::INFINITY)
                && surely_outside(lo, hi, away, direction, 0.0, f32::INFINITY)
            {
                far_outside += 1;
            }
        }
        assert!(met > 100_000, "only {met} rays met their box");
        assert!(far_outside > 100_000, "only {far_outside} far rays were found outside");
    }

    #[test]
    fn rays_it_cannot_tell_about_are_not_outside() {
        let (lo, hi) = (Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let far = Vec3::new(0.0, 10.0, 0.0);
        // Passes above the box, so outside, unless a coordinate is not finite.
        assert!(surely_outside(lo, hi, far, Vec3::X, 0.0, f32::INFINITY));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(!surely_outside(lo, hi, Vec3::new(bad, 10.0, 0.0), Vec3::X, 0.0, f32::INFINITY));
            assert!(!surely_outside(lo, hi, far, Vec3::new(1.0, bad, 0.0), 0.0, f32::INFINITY));
        }
        let infinite = Vec3A::splat(f32::INFINITY);
        assert!(!surely_outside(-infinite, infinite, far, Vec3::X, 0.0, f32::INFINITY));
        // Behind the origin, or past `t_max`: outside; an empty interval is
        // left to the walk.
        assert!(surely_outside(lo, hi, Vec3::new(0.0, 0.0, 5.0), Vec3::Z, 0.0, f32::INFINITY));
        assert!(surely_outside(lo, hi, Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 0.0, 3.0));
        assert!(!surely_outside(lo, hi, Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 0.0, 4.0));
        // A zero direction: inside (or on a face of) the box is not outside.
        assert!(!surely_outside(lo, hi, Vec3::new(1.0, 0.0, 0.0), Vec3::ZERO, 0.0, 1.0));
        assert!(surely_outside(lo, hi, Vec3::new(2.0, 0.0, 0.0), Vec3::ZERO, 0.0, 1.0));
    }
}
