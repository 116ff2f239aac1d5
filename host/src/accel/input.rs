//! Build inputs of a [`Gas`](super::Gas) and their validation.
//!
//! A build input is one *geometry* (`VkAccelerationStructureGeometryKHR`):
//! [`Triangles`] (f32×3 vertices at any stride, u16, u32 or no indices, an
//! optional 3×4 transform) or [`Aabbs`] (boxes hit through an intersection
//! program). Each geometry has its [`GeometryFlags`], and its SBT index is its
//! position in the build: a ray hitting geometry `g` of an instance with SBT
//! offset `o` runs hit record `o + g × stride + ray type offset` (see
//! [the SBT indexing rules](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#shader-binding-table-indexing-rules)).
//!
//! Validation checks everything the Vulkan valid-usage rules and the device's
//! limits require before anything is uploaded; it is pure and unit-tested.

use std::hash::{Hash, Hasher};

use glam::{Affine3A, Vec3};

use crate::context::DeviceLimits;
use crate::error::{Error, Result};

/// Size of one f32×3 vertex position.
const VERTEX_SIZE: u64 = 12;
/// Size of one `VkAabbPositionsKHR`.
const AABB_SIZE: u64 = 24;

/// Per-geometry flags (`VkGeometryFlagsKHR`, OptiX's `OPTIX_GEOMETRY_FLAG_*`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct GeometryFlags(pub(crate) u32);

impl GeometryFlags {
    /// No flags: any-hit programs run (OptiX's `OPTIX_GEOMETRY_FLAG_NONE`).
    pub const NONE: GeometryFlags = GeometryFlags(0);
    /// The geometry is opaque: any-hit programs are skipped.
    pub const OPAQUE: GeometryFlags = GeometryFlags(crate::vulkan::accel::structure::GEOMETRY_OPAQUE);
    /// Any-hit runs at most once per primitive along a ray.
    pub const NO_DUPLICATE_ANY_HIT: GeometryFlags =
        GeometryFlags(crate::vulkan::accel::structure::GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION);

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
    fn len(&self) -> usize {
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
    fn vertex(&self, i: usize) -> [f32; 3] {
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
    Triangles(Triangles<'a>),
    /// Boxes for an intersection program.
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

    fn kind(&self) -> &'static str {
        match self {
            Shape::Triangles { .. } => "triangles",
            Shape::Aabbs { .. } => "AABBs",
        }
    }
}

fn check_stride(geometry: usize, what: &'static str, stride: u64, alignment: u64, min: u64) -> Result<()> {
    if !stride.is_multiple_of(alignment) || stride < min || stride > u32::MAX as u64 {
        return Err(Error::MisalignedStride { geometry, what, stride, alignment, min });
    }
    Ok(())
}

fn check_len(geometry: usize, what: &'static str, len: usize, count: usize, stride: u64, element: u64) -> Result<()> {
    let needed = (count as u64 - 1).saturating_mul(stride).saturating_add(element);
    if (len as u64) < needed {
        return Err(Error::InputTooShort { geometry, what, needed, len: len as u64 });
    }
    Ok(())
}

fn check_transform(what: String, t: &Affine3A) -> Result<()> {
    if !t.is_finite() {
        return Err(Error::NonFiniteTransform { what });
    }
    Ok(())
}

/// Checks `inputs` against Vulkan's rules and `limits`; returns each geometry's
/// shape. Pure: nothing is uploaded. `for_update` also fingerprints the index
/// data (needed only by builds that allow updates).
pub(crate) fn validate(inputs: &[BuildInput<'_>], limits: &DeviceLimits, for_update: bool) -> Result<Vec<Shape>> {
    if inputs.is_empty() {
        return Err(Error::AccelEmpty { what: "the GAS build has no geometry".to_owned() });
    }
    if inputs.len() as u64 > limits.max_geometry_count {
        return Err(Error::AccelLimit {
            what: "geometries",
            count: inputs.len() as u64,
            limit: limits.max_geometry_count,
            limit_name: "maxGeometryCount",
        });
    }
    let mut shapes = Vec::with_capacity(inputs.len());
    let mut total: u64 = 0;
    for (g, input) in inputs.iter().enumerate() {
        let first = &inputs[0];
        if std::mem::discriminant(first) != std::mem::discriminant(input) {
            return Err(Error::MixedGeometryTypes { first: 0, other: g });
        }
        let shape = match input {
            BuildInput::Triangles(t) => validate_triangles(g, t, for_update)?,
            BuildInput::Aabbs(a) => validate_aabbs(g, a)?,
        };
        total += shape.primitives() as u64;
        shapes.push(shape);
    }
    if total > limits.max_primitive_count {
        return Err(Error::AccelLimit {
            what: "primitives in one GAS",
            count: total,
            limit: limits.max_primitive_count,
            limit_name: "maxPrimitiveCount",
        });
    }
    Ok(shapes)
}

/// `count` fits the 32 bits Vulkan takes for it (`limit_name`).
fn check_fits_u32(what: &'static str, count: usize, limit_name: &'static str) -> Result<()> {
    if count > u32::MAX as usize {
        return Err(Error::AccelLimit { what, count: count as u64, limit: u32::MAX as u64, limit_name });
    }
    Ok(())
}

fn validate_triangles(g: usize, t: &Triangles<'_>, for_update: bool) -> Result<Shape> {
    check_stride(g, "vertex", t.stride, 4, VERTEX_SIZE)?;
    if t.vertex_count == 0 {
        return Err(Error::AccelEmpty { what: format!("geometry {g} has no vertices") });
    }
    check_fits_u32("vertices in one geometry", t.vertex_count, "the 32-bit maxVertex")?;
    check_len(g, "vertex", t.vertex_bytes.len(), t.vertex_count, t.stride, VERTEX_SIZE)?;
    let index_count = match t.indices {
        Indices::None => {
            if !t.vertex_count.is_multiple_of(3) {
                return Err(Error::TriangleCount {
                    geometry: g,
                    what: "vertices without indices",
                    count: t.vertex_count,
                });
            }
            t.vertex_count
        }
        ref indices => {
            let n = indices.len();
            if n == 0 {
                return Err(Error::AccelEmpty { what: format!("geometry {g} has an empty index buffer") });
            }
            if !n.is_multiple_of(3) {
                return Err(Error::TriangleCount { geometry: g, what: "indices", count: n });
            }
            for i in 0..n {
                let index = indices.get(i);
                if index as usize >= t.vertex_count {
                    return Err(Error::IndexOutOfRange {
                        geometry: g,
                        position: i,
                        index,
                        vertex_count: t.vertex_count as u64,
                    });
                }
            }
            n
        }
    };
    let triangles = index_count / 3;
    check_fits_u32("triangles in one geometry", triangles, "the 32-bit primitiveCount")?;
    for v in 0..t.vertex_count {
        let p = t.vertex(v);
        if !p.iter().all(|c| c.is_finite()) {
            return Err(Error::NonFiniteVertex { geometry: g, vertex: v, position: p });
        }
    }
    if let Some(transform) = &t.transform {
        check_transform(format!("the transform of geometry {g}"), transform)?;
    }
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    if for_update {
        t.indices.bytes().hash(&mut hasher);
    }
    Ok(Shape::Triangles {
        triangles: triangles as u32,
        vertices: t.vertex_count as u32,
        index: t.indices.kind(),
        index_hash: hasher.finish(),
        transform: t.transform.is_some(),
        flags: t.flags,
    })
}

fn validate_aabbs(g: usize, a: &Aabbs<'_>) -> Result<Shape> {
    check_stride(g, "AABB", a.stride, 8, AABB_SIZE)?;
    if a.count == 0 {
        return Err(Error::AccelEmpty { what: format!("geometry {g} has no AABBs") });
    }
    check_fits_u32("AABBs in one geometry", a.count, "the 32-bit primitiveCount")?;
    check_len(g, "AABB", a.bytes.len(), a.count, a.stride, AABB_SIZE)?;
    for i in 0..a.count {
        let b = a.aabb(i);
        let finite = b.min.iter().chain(&b.max).all(|c| c.is_finite());
        let ordered = (0..3).all(|k| b.min[k] <= b.max[k]);
        if !finite || !ordered {
            return Err(Error::InvalidAabb {
                geometry: g,
                primitive: i,
                min: b.min,
                max: b.max,
                reason: if finite { "min is greater than max on some axis" } else { "a coordinate is not finite" },
            });
        }
    }
    Ok(Shape::Aabbs { count: a.count as u32, flags: a.flags })
}

/// Why `new` cannot update a structure built with `old`; `None` when it can.
pub(crate) fn update_refusal(old: &[Shape], new: &[Shape]) -> Option<String> {
    if old.len() != new.len() {
        return Some(format!("the geometry count changed from {} to {}", old.len(), new.len()));
    }
    for (g, (a, b)) in old.iter().zip(new).enumerate() {
        if a == b {
            continue;
        }
        let reason = match (a, b) {
            (Shape::Triangles { .. }, Shape::Aabbs { .. }) | (Shape::Aabbs { .. }, Shape::Triangles { .. }) => {
                format!("geometry {g} changed from {} to {}", a.kind(), b.kind())
            }
            (Shape::Aabbs { count: c0, .. }, Shape::Aabbs { count: c1, .. }) if c0 != c1 => {
                format!("geometry {g} has {c1} AABBs, the build had {c0}")
            }
            (
                Shape::Triangles { triangles: t0, vertices: v0, index: i0, index_hash: h0, transform: x0, .. },
                Shape::Triangles { triangles: t1, vertices: v1, index: i1, index_hash: h1, transform: x1, .. },
            ) => {
                if t0 != t1 {
                    format!("geometry {g} has {t1} triangles, the build had {t0}")
                } else if v0 != v1 {
                    format!("geometry {g} has {v1} vertices, the build had {v0}")
                } else if i0 != i1 {
                    format!("geometry {g}'s index format changed from {i0:?} to {i1:?}")
                } else if h0 != h1 {
                    format!("geometry {g}'s index data changed (only vertex positions may move)")
                } else if x0 != x1 {
                    format!("geometry {g} {} a transform", if *x1 { "gained" } else { "lost" })
                } else {
                    format!("geometry {g}'s flags changed")
                }
            }
            _ => format!("geometry {g}'s flags changed"),
        };
        return Some(reason);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> DeviceLimits {
        DeviceLimits {
            shader_group_handle_size: 32,
            shader_group_handle_alignment: 32,
            shader_group_base_alignment: 64,
            max_shader_group_stride: 4096,
            max_ray_recursion_depth: 31,
            max_ray_dispatch_invocation_count: 1 << 30,
            max_ray_hit_attribute_size: 32,
            max_push_constants_size: 128,
            max_uniform_buffer_range: 65536,
            max_storage_buffer_range: 1 << 27,
            min_uniform_buffer_offset_alignment: 256,
            min_scratch_alignment: 128,
            max_geometry_count: 2,
            max_primitive_count: 4,
            max_instance_count: 8,
        }
    }

    const TRI: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

    #[test]
    fn counts_over_the_device_limits_are_refused() {
        let verts = [Vec3::ZERO; 15];
        let err = validate(&[Triangles::new(&verts).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::AccelLimit { count: 5, limit: 4, limit_name: "maxPrimitiveCount", .. }), "{err}");
        let t: BuildInput<'_> = Triangles::new(&TRI).into();
        let err = validate(&[t, t, t], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::AccelLimit { limit_name: "maxGeometryCount", .. }), "{err}");
        assert!(validate(&[t, t], &limits(), true).is_ok());
    }

    #[test]
    fn strides_must_be_aligned_and_cover_a_vertex() {
        let bytes = [0u8; 64];
        for stride in [10, 14, 8] {
            let err = validate(&[Triangles::strided(&bytes, stride, 3).into()], &limits(), true).unwrap_err();
            assert!(matches!(err, Error::MisalignedStride { alignment: 4, .. }), "{stride}: {err}");
        }
        let err = validate(&[Triangles::strided(&bytes, 32, 3).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::InputTooShort { needed: 76, len: 64, .. }), "{err}");
        assert!(validate(&[Triangles::strided(&bytes, 16, 3).into()], &limits(), true).is_ok());
        let boxes = [0u8; 96];
        let err = validate(&[Aabbs::strided(&boxes, 28, 2).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::MisalignedStride { alignment: 8, .. }), "{err}");
        assert!(validate(&[Aabbs::strided(&boxes, 32, 3).into()], &limits(), true).is_ok());
    }

    #[test]
    fn indices_and_vertices_are_checked() {
        let err = validate(&[Triangles::new(&TRI).indices_u16(&[0, 1, 3]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::IndexOutOfRange { position: 2, index: 3, vertex_count: 3, .. }), "{err}");
        let err = validate(&[Triangles::new(&TRI).indices_u32(&[0, 1]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::TriangleCount { count: 2, .. }), "{err}");
        let err = validate(&[Triangles::new(&TRI[..2]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::TriangleCount { count: 2, .. }), "{err}");
        let err = validate(&[Triangles::new(&[]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::AccelEmpty { .. }), "{err}");
        let err = validate(&[Triangles::new(&TRI).indices_u32(&[]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::AccelEmpty { .. }), "{err}");
        let bad = [Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::Y];
        let err = validate(&[Triangles::new(&bad).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::NonFiniteVertex { vertex: 1, .. }), "{err}");
        let err = validate(
            &[Triangles::new(&TRI).transform(Affine3A::from_scale(Vec3::splat(f32::NAN))).into()],
            &limits(),
            true,
        )
        .unwrap_err();
        assert!(matches!(err, Error::NonFiniteTransform { .. }), "{err}");
    }

    #[test]
    fn boxes_must_be_finite_and_ordered() {
        let flipped = [Aabb::new(Vec3::ONE, Vec3::ZERO)];
        let err = validate(&[Aabbs::new(&flipped).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::InvalidAabb { primitive: 0, .. }), "{err}");
        let nan = [Aabb::new(Vec3::ZERO, Vec3::ONE), Aabb::new(Vec3::ZERO, Vec3::splat(f32::NAN))];
        let err = validate(&[Aabbs::new(&nan).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::InvalidAabb { primitive: 1, .. }), "{err}");
        let boxes = [Aabb::new(Vec3::ZERO, Vec3::ONE)];
        let err = validate(&[Triangles::new(&TRI).into(), Aabbs::new(&boxes).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::MixedGeometryTypes { first: 0, other: 1 }), "{err}");
    }

    #[test]
    fn updates_need_the_same_topology() -> std::result::Result<(), Box<dyn std::error::Error>> {
        let moved = [Vec3::ZERO, Vec3::X * 2.0, Vec3::Y];
        let quad = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE];
        let shapes = |i: BuildInput<'_>| validate(&[i], &limits(), true);
        let base = shapes(Triangles::new(&TRI).indices_u32(&[0, 1, 2]).into())?;
        assert_eq!(update_refusal(&base, &shapes(Triangles::new(&moved).indices_u32(&[0, 1, 2]).into())?), None);
        let r = update_refusal(&base, &shapes(Triangles::new(&moved).indices_u32(&[0, 2, 1]).into())?)
            .ok_or("expected a refusal")?;
        assert!(r.contains("index data"), "{r}");
        let r = update_refusal(&base, &shapes(Triangles::new(&moved).indices_u16(&[0, 1, 2]).into())?)
            .ok_or("expected a refusal")?;
        assert!(r.contains("index format"), "{r}");
        let r = update_refusal(&base, &shapes(Triangles::new(&quad).indices_u32(&[0, 1, 2, 1, 3, 2]).into())?)
            .ok_or("expected a refusal")?;
        assert!(r.contains("2 triangles"), "{r}");
        let r = update_refusal(&base, &shapes(Triangles::new(&moved).into())?).ok_or("expected a refusal")?;
        assert!(r.contains("index format"), "{r}");
        let t: BuildInput<'_> = Triangles::new(&TRI).into();
        let r = update_refusal(&base, &validate(&[t, t], &limits(), true)?).ok_or("expected a refusal")?;
        assert!(r.contains("geometry count"), "{r}");
        Ok(())
    }
}
