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
        let triangles_opaque = triangles_opaque(&instances);
        let boxes = instances.iter().any(|instance| instance.gas.boxes);
        SceneData { instances, bvh, triangles_opaque, boxes }
    }

    /// Bytes the structure takes on the host.
    pub(crate) fn size(&self) -> u64 {
        (std::mem::size_of_val(&self.bvh.nodes[..])
            + std::mem::size_of_val(&self.bvh.primitive_indices[..])
            + std::mem::size_of_val(&self.instances[..])) as u64
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
