//! Small triangle GASes tested without their tree: a ray against eight
//! triangles at once, all of them, in leaf order.
//!
//! For a few dozen triangles (a Cornell box, a quad light, a simple prop) the
//! tree's node tests cost more than testing every triangle eight lanes wide.
//! The lanes compute what the one-triangle test ([`super::intersect::intersect_triangle`]) computes, with
//! the same operations in the same order, so each triangle's `t`, barycentrics
//! and determinant are bit for bit those of the tree walk; the candidates then
//! go through the same opacity, culling and any-hit steps in leaf order.

use glam::Vec3A;

use super::geometry::{Geometry, Leaf};
use super::simd::{Intersections, Lanes};

/// GASes of at most this many triangles (and no AABBs) are tested flat.
pub(crate) const MAX_TRIANGLES: usize = 64;

/// Eight triangles, a vertex and two edges each, coordinate by coordinate.
#[derive(Clone, Debug, Default)]
#[repr(C)]
pub(crate) struct TriangleBlock {
    v0: [Lanes; 3],
    e1: [Lanes; 3],
    e2: [Lanes; 3],
    /// Lanes that hold a triangle (the last block may be part empty).
    lanes: u8,
}

/// The blocks of `leaves`, when the GAS is small and all triangles.
pub(crate) fn blocks(geometries: &[Geometry], leaves: &[Leaf]) -> Option<Box<[TriangleBlock]>> {
    let small = leaves.len() <= MAX_TRIANGLES;
    let triangles = geometries.iter().all(|g| matches!(g, Geometry::Triangles { .. }));
    if !small || !triangles || leaves.is_empty() {
        return None;
    }
    let blocks = leaves
        .chunks(8)
        .map(|chunk| {
            let mut block = TriangleBlock::default();
            for (lane, leaf) in chunk.iter().enumerate() {
                let t = &leaf.triangle;
                for axis in 0..3 {
                    block.v0[axis].0[lane] = t.v0[axis];
                    block.e1[axis].0[lane] = t.e1[axis];
                    block.e2[axis].0[lane] = t.e2[axis];
                }
                block.lanes |= 1 << lane;
            }
            block
        })
        .collect();
    Some(blocks)
}

/// Tests the ray `origin + t·direction` against `block`'s triangles: the
/// one-triangle test's Möller–Trumbore, lane by lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
pub(crate) fn intersect(
    block: &TriangleBlock,
    origin: Vec3A,
    direction: Vec3A,
    t_min: f32,
    t_max: f32,
) -> Intersections {
    use std::arch::x86_64::*;
    let set = |v: f32| _mm256_set1_ps(v);
    // SAFETY: each row holds eight `f32`s on a 32-byte boundary, which the load reads.
    let load = |rows: &[Lanes; 3]| rows.each_ref().map(|row| unsafe { _mm256_load_ps(row.0.as_ptr()) });
    let ray = |v: Vec3A| [set(v.x), set(v.y), set(v.z)];
    super::simd::intersect_triangles(
        ray(origin),
        ray(direction),
        load(&block.v0),
        load(&block.e1),
        load(&block.e2),
        set(t_min),
        set(t_max),
        block.lanes,
    )
}
