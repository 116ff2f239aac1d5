//! What the CPU backend's trees hold: geometries, and the primitives their
//! leaves name.

use glam::Vec3A;
use obvhs::aabb::Aabb as BvhAabb;

use crate::types::accel::GeometryFlags;

/// One triangle as the intersection test wants it: a vertex and two edges.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Triangle {
    pub(crate) v0: Vec3A,
    pub(crate) e1: Vec3A,
    pub(crate) e2: Vec3A,
}

/// One geometry of a GAS.
#[derive(Debug)]
pub(crate) enum Geometry {
    /// Triangles (kept, with the geometry's transform applied, in the leaves).
    Triangles { count: usize, flags: GeometryFlags },
    /// Boxes for an intersection program.
    Aabbs { boxes: Vec<BvhAabb>, flags: GeometryFlags },
}

impl Geometry {
    pub(crate) fn flags(&self) -> GeometryFlags {
        match self {
            Geometry::Triangles { flags, .. } | Geometry::Aabbs { flags, .. } => *flags,
        }
    }

    /// Whether the geometry is opaque by its own flag.
    pub(crate) fn opaque(&self) -> bool {
        self.flags().contains(GeometryFlags::OPAQUE)
    }
}

/// One primitive in the order the tree's leaves name them: traversal reads
/// what it tests from one place.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Leaf {
    /// The triangle, for triangle geometries (zeros for AABBs).
    pub(crate) triangle: Triangle,
    pub(crate) geometry: u32,
    pub(crate) primitive: u32,
}
