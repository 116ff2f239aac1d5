//! Acceleration-structure descriptions both backends read: GAS build inputs, the
//! flags of geometries and instances, build options and sizes.
//!
//! A build input is one *geometry* (`VkAccelerationStructureGeometryKHR`):
//! [`Triangles`] (f32×3 vertices at any stride, u16, u32 or no indices, an
//! optional 3×4 transform) or [`Aabbs`] (boxes hit through an intersection
//! program). Each geometry has its [`GeometryFlags`], and its SBT index is its
//! position in the build: a ray hitting geometry `g` of an instance with SBT
//! offset `o` runs hit record `o + g × stride + ray type offset` (see
//! [the SBT indexing rules](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#shader-binding-table-indexing-rules)).
//! The flags hold raykit's own bits; `vulkan::conv` maps them to Vulkan's.

use std::hash::Hash;

use glam::{Affine3A, Vec3};

/// Size of one f32×3 vertex position.
pub(crate) const VERTEX_SIZE: u64 = 12;
/// Size of one `VkAabbPositionsKHR`.
pub(crate) const AABB_SIZE: u64 = 24;

/// Per-geometry flags (`VkGeometryFlagsKHR`, OptiX's `OPTIX_GEOMETRY_FLAG_*`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct GeometryFlags(pub(crate) u32);

impl GeometryFlags {
    /// No flags: any-hit programs run (OptiX's `OPTIX_GEOMETRY_FLAG_NONE`).
    #[doc(alias("OptixGeometryFlags", "OPTIX_GEOMETRY_FLAG_NONE"))]
    pub const NONE: GeometryFlags = GeometryFlags(0);
    /// The geometry is opaque: any-hit programs are skipped.
    #[doc(alias("OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT"))]
    pub const OPAQUE: GeometryFlags = GeometryFlags(1 << 0);
    /// Any-hit runs at most once per primitive along a ray.
    #[doc(alias("OPTIX_GEOMETRY_FLAG_REQUIRE_SINGLE_ANYHIT_CALL"))]
    pub const NO_DUPLICATE_ANY_HIT: GeometryFlags = GeometryFlags(1 << 1);

    /// Whether every flag of `other` is set.
    pub fn contains(self, other: GeometryFlags) -> bool {
        self.0 & other.0 == other.0
    }
}

impl std::ops::BitOr for GeometryFlags {
    type Output = GeometryFlags;
    fn bitor(self, rhs: GeometryFlags) -> GeometryFlags {
        GeometryFlags(self.0 | rhs.0)
    }
}

/// Index data of a triangle geometry.
#[derive(Copy, Clone, Debug, Default)]
pub enum Indices<'a> {
    /// Every three consecutive vertices make a triangle.
    #[default]
    None,
    /// Three 16-bit indices per triangle.
    U16(&'a [u16]),
    /// Three 32-bit indices per triangle.
    U32(&'a [u32]),
}

impl Indices<'_> {
    pub(crate) fn len(&self) -> usize {
        match self {
            Indices::None => 0,
            Indices::U16(i) => i.len(),
            Indices::U32(i) => i.len(),
        }
    }

    pub(crate) fn get(&self, i: usize) -> u32 {
        match self {
            Indices::None => i as u32,
            Indices::U16(x) => x[i] as u32,
            Indices::U32(x) => x[i],
        }
    }

    pub(crate) fn bytes(&self) -> &[u8] {
        match self {
            Indices::None => &[],
            Indices::U16(i) => bytemuck::cast_slice(i),
            Indices::U32(i) => bytemuck::cast_slice(i),
        }
    }

    pub(crate) fn kind(&self) -> IndexKind {
        match self {
            Indices::None => IndexKind::None,
            Indices::U16(_) => IndexKind::U16,
            Indices::U32(_) => IndexKind::U32,
        }
    }
}

/// The index format of a geometry, without its data.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) enum IndexKind {
    None,
    U16,
    U32,
}

/// A triangle geometry: f32×3 vertex positions, optional indices and transform.
#[derive(Copy, Clone, Debug)]
pub struct Triangles<'a> {
    pub(crate) vertex_bytes: &'a [u8],
    pub(crate) stride: u64,
    pub(crate) vertex_count: usize,
    pub(crate) indices: Indices<'a>,
    pub(crate) transform: Option<Affine3A>,
    pub(crate) flags: GeometryFlags,
}

impl<'a> Triangles<'a> {
    /// Triangles over tightly packed `vertices` (stride 12 bytes), not indexed.
    #[doc(alias("OptixBuildInputTriangleArray"))]
    pub fn new(vertices: &'a [Vec3]) -> Self {
        Triangles::strided(bytemuck::cast_slice(vertices), VERTEX_SIZE, vertices.len())
    }

    /// Triangles over `count` vertices whose f32×3 positions start every `stride`
    /// bytes of `bytes` (so positions can sit inside a larger vertex struct).
    /// The stride must be a multiple of 4 and at least 12.
    pub fn strided(bytes: &'a [u8], stride: u64, count: usize) -> Self {
        Triangles {
            vertex_bytes: bytes,
            stride,
            vertex_count: count,
            indices: Indices::None,
            transform: None,
            flags: GeometryFlags::NONE,
        }
    }

    /// Triangles whose positions are the f32×3 at byte `position_offset` of each
    /// element of `vertices` (a `#[repr(C)]` vertex struct).
    pub fn from_vertex_structs<T: bytemuck::Pod>(vertices: &'a [T], position_offset: usize) -> Self {
        let bytes: &[u8] = bytemuck::cast_slice(vertices);
        let bytes = bytes.get(position_offset..).unwrap_or(&[]);
        Triangles::strided(bytes, std::mem::size_of::<T>() as u64, vertices.len())
    }

    /// Three indices per triangle, in any [`Indices`] format.
    #[must_use]
    pub fn indices(mut self, indices: Indices<'a>) -> Self {
        self.indices = indices;
        self
    }

    /// Three 32-bit indices per triangle.
    #[must_use]
    pub fn indices_u32(self, indices: &'a [u32]) -> Self {
        self.indices(Indices::U32(indices))
    }

    /// Three 16-bit indices per triangle.
    #[must_use]
    pub fn indices_u16(self, indices: &'a [u16]) -> Self {
        self.indices(Indices::U16(indices))
    }

    /// A transform applied to the vertices at build time (OptiX's
    /// `preTransform`, Vulkan's `transformData`).
    #[must_use]
    pub fn transform(mut self, transform: Affine3A) -> Self {
        self.transform = Some(transform);
        self
    }

    /// The geometry's flags.
    #[must_use]
    pub fn flags(mut self, flags: GeometryFlags) -> Self {
        self.flags = flags;
        self
    }

    /// Number of triangles (without validation).
    pub fn triangle_count(&self) -> usize {
        match self.indices {
            Indices::None => self.vertex_count / 3,
            _ => self.indices.len() / 3,
        }
    }

    /// Position of vertex `i` (in range, checked by the caller).
    pub(crate) fn vertex(&self, i: usize) -> [f32; 3] {
        let at = i * self.stride as usize;
        bytemuck::pod_read_unaligned(&self.vertex_bytes[at..at + VERTEX_SIZE as usize])
    }
}

/// An axis-aligned box, `VkAabbPositionsKHR`.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The box from `min` to `max`.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min: min.to_array(), max: max.to_array() }
    }

    /// The smallest `f32` box that holds the sphere exactly: `centre ∓ radius`
    /// rounded outwards, and never past `±f32::MAX` (a sphere that reaches
    /// `f32::MAX` keeps finite bounds: no `f32` lies beyond it).
    pub fn around_sphere(centre: Vec3, radius: f32) -> Self {
        let min = (centre - Vec3::splat(radius)).to_array().map(|v| v.next_down().max(f32::MIN));
        let max = (centre + Vec3::splat(radius)).to_array().map(|v| v.next_up().min(f32::MAX));
        Aabb { min, max }
    }

    /// A box around every position of a sphere of `radius` moving linearly
    /// from `start` to `end`: the union of its boxes at the two ends (the
    /// sweep is their convex hull), widened on every side by `4ε` times the
    /// centres' largest coordinate and rounded outwards, so that a centre the
    /// device interpolates in `f32` (`start · (1 − t) + end · t`: three
    /// roundings of terms no larger than that coordinate) keeps its sphere inside.
    pub fn around_sweep(start: Vec3, end: Vec3, radius: f32) -> Self {
        let (a, b) = (Aabb::around_sphere(start, radius), Aabb::around_sphere(end, radius));
        let slack = 4.0 * f32::EPSILON * start.abs().max(end.abs()).max_element();
        let min = std::array::from_fn(|k| (a.min[k].min(b.min[k]) - slack).next_down().max(f32::MIN));
        let max = std::array::from_fn(|k| (a.max[k].max(b.max[k]) + slack).next_up().min(f32::MAX));
        Aabb { min, max }
    }
}

/// A procedural geometry: boxes whose contents an intersection program decides.
#[derive(Copy, Clone, Debug)]
pub struct Aabbs<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) stride: u64,
    pub(crate) count: usize,
    pub(crate) flags: GeometryFlags,
}

impl<'a> Aabbs<'a> {
    /// Tightly packed boxes (stride 24 bytes).
    #[doc(alias("OptixBuildInputCustomPrimitiveArray"))]
    pub fn new(boxes: &'a [Aabb]) -> Self {
        Aabbs::strided(bytemuck::cast_slice(boxes), AABB_SIZE, boxes.len())
    }

    /// `count` boxes (six f32 each) starting every `stride` bytes of `bytes`;
    /// the stride must be a multiple of 8 and at least 24.
    pub fn strided(bytes: &'a [u8], stride: u64, count: usize) -> Self {
        Aabbs { bytes, stride, count, flags: GeometryFlags::NONE }
    }

    /// The geometry's flags.
    #[must_use]
    pub fn flags(mut self, flags: GeometryFlags) -> Self {
        self.flags = flags;
        self
    }

    pub(crate) fn aabb(&self, i: usize) -> Aabb {
        let at = i * self.stride as usize;
        bytemuck::pod_read_unaligned(&self.bytes[at..at + AABB_SIZE as usize])
    }
}

/// One geometry of a GAS build.
#[derive(Copy, Clone, Debug)]
pub enum BuildInput<'a> {
    /// Triangles.
    #[doc(alias("OptixBuildInput", "OPTIX_BUILD_INPUT_TYPE_TRIANGLES"))]
    Triangles(Triangles<'a>),
    /// Boxes for an intersection program.
    #[doc(alias("OptixBuildInput", "OPTIX_BUILD_INPUT_TYPE_CUSTOM_PRIMITIVES"))]
    Aabbs(Aabbs<'a>),
}

impl<'a> From<Triangles<'a>> for BuildInput<'a> {
    fn from(t: Triangles<'a>) -> Self {
        BuildInput::Triangles(t)
    }
}

impl<'a> From<Aabbs<'a>> for BuildInput<'a> {
    fn from(a: Aabbs<'a>) -> Self {
        BuildInput::Aabbs(a)
    }
}

/// What an update must keep equal: a geometry's kind, counts, formats, index
/// data and flags (Vulkan's rules for `VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Shape {
    Triangles {
        triangles: u32,
        vertices: u32,
        index: IndexKind,
        index_hash: u64,
        transform: bool,
        flags: GeometryFlags,
    },
    Aabbs {
        count: u32,
        flags: GeometryFlags,
    },
}

impl Shape {
    pub(crate) fn primitives(&self) -> u32 {
        match self {
            Shape::Triangles { triangles, .. } => *triangles,
            Shape::Aabbs { count, .. } => *count,
        }
    }

    pub(crate) fn kind_name(&self) -> &'static str {
        match self {
            Shape::Triangles { .. } => "triangles",
            Shape::Aabbs { .. } => "AABBs",
        }
    }
}

/// Which way the builder trades build time against trace time (OptiX's
/// `OPTIX_BUILD_FLAG_PREFER_FAST_TRACE` / `_BUILD`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildPreference {
    /// Slower builds, faster traversal (the default, for static geometry).
    #[default]
    FastTrace,
    /// Faster builds, slower traversal (for geometry rebuilt every frame).
    FastBuild,
    /// Let the driver choose.
    Neither,
}

/// Build flags of one acceleration structure.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BuildOptions {
    /// Build-time versus trace-time preference.
    #[doc(alias("OptixAccelBuildOptions", "OPTIX_BUILD_FLAG_PREFER_FAST_TRACE"))]
    pub preference: BuildPreference,
    /// Allow [`Gas::update`](crate::Gas::update) / [`Ias::update`](crate::Ias::update) (refit) later.
    #[doc(alias("OPTIX_BUILD_FLAG_ALLOW_UPDATE"))]
    pub allow_update: bool,
    /// Allow [`Gas::compact`](crate::Gas::compact) later.
    #[doc(alias("OPTIX_BUILD_FLAG_ALLOW_COMPACTION"))]
    pub allow_compaction: bool,
}

impl BuildOptions {
    /// Prefer fast traversal (the default).
    #[must_use]
    pub fn fast_trace(mut self) -> Self {
        self.preference = BuildPreference::FastTrace;
        self
    }

    /// Prefer fast builds.
    #[must_use]
    pub fn fast_build(mut self) -> Self {
        self.preference = BuildPreference::FastBuild;
        self
    }

    /// Allow later refits (`update`).
    #[must_use]
    pub fn allow_update(mut self, allow: bool) -> Self {
        self.allow_update = allow;
        self
    }

    /// Allow later compaction.
    #[must_use]
    pub fn allow_compaction(mut self, allow: bool) -> Self {
        self.allow_compaction = allow;
        self
    }
}

/// Memory an acceleration structure needs, from the driver's size query
/// (OptiX's `OptixAccelBufferSizes`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct AccelSizes {
    /// Bytes of the structure itself (`accelerationStructureSize`).
    pub structure: u64,
    /// Scratch bytes a build needs (`buildScratchSize`).
    pub build_scratch: u64,
    /// Scratch bytes an update needs (`updateScratchSize`).
    pub update_scratch: u64,
}

/// Per-instance flags (`VkGeometryInstanceFlagsKHR`, OptiX's `OPTIX_INSTANCE_FLAG_*`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct InstanceFlags(pub(crate) u8);

impl InstanceFlags {
    /// No flags.
    #[doc(alias("OptixInstanceFlags", "OPTIX_INSTANCE_FLAG_NONE"))]
    pub const NONE: InstanceFlags = InstanceFlags(0);
    /// Disable face culling for this instance's triangles.
    #[doc(alias("OPTIX_INSTANCE_FLAG_DISABLE_TRIANGLE_FACE_CULLING"))]
    pub const DISABLE_TRIANGLE_CULLING: InstanceFlags = InstanceFlags(1 << 0);
    /// Swap front and back faces.
    #[doc(alias("OPTIX_INSTANCE_FLAG_FLIP_TRIANGLE_FACING"))]
    pub const FLIP_TRIANGLE_FACING: InstanceFlags = InstanceFlags(1 << 1);
    /// Treat every geometry as opaque (no any-hit).
    pub const FORCE_OPAQUE: InstanceFlags = InstanceFlags(1 << 2);
    /// Treat every geometry as non-opaque (any-hit runs).
    pub const FORCE_NON_OPAQUE: InstanceFlags = InstanceFlags(1 << 3);

    /// Whether every flag of `other` is set.
    pub fn contains(self, other: InstanceFlags) -> bool {
        self.0 & other.0 == other.0
    }
}

impl std::ops::BitOr for InstanceFlags {
    type Output = InstanceFlags;
    fn bitor(self, rhs: InstanceFlags) -> InstanceFlags {
        InstanceFlags(self.0 | rhs.0)
    }
}

/// Where one instance places its GAS, as a backend records it: the transform
/// (row-major 3×4), custom index, mask, SBT offset and flags.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct InstancePlacement {
    pub(crate) transform: [f32; 12],
    pub(crate) custom_index: u32,
    pub(crate) mask: u8,
    pub(crate) sbt_offset: u32,
    pub(crate) flags: InstanceFlags,
}

/// A 3×4 row-major matrix (`VkTransformMatrixKHR`) from an affine transform.
pub(crate) fn transform_rows(m: &glam::Affine3A) -> [f32; 12] {
    let (x, y, z, t) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis, m.translation);
    [x.x, y.x, z.x, t.x, x.y, y.y, z.y, t.y, x.z, y.z, z.z, t.z]
}
