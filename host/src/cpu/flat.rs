//! Small triangle GASes tested without their tree: a ray against eight
//! triangles at once, all of them, in leaf order.
//!
//! For a few dozen triangles (a Cornell box, a quad light, a simple prop) the
//! tree's node tests cost more than testing every triangle eight lanes wide.
//! The lanes compute what [`super::launch`]'s one-triangle test computes, with
//! the same operations in the same order, so each triangle's `t`, barycentrics
//! and determinant are bit for bit those of the tree walk; the candidates then
//! go through the same opacity, culling and any-hit steps in leaf order.

use glam::Vec3A;

use super::accel::{Geometry, Leaf};

/// GASes of at most this many triangles (and no AABBs) are tested flat.
pub(crate) const MAX_TRIANGLES: usize = 64;

/// Eight `f32` lanes on a 32-byte boundary: AVX2 loads and stores of them
/// never split a cache line.
#[derive(Copy, Clone, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct Lanes(pub(crate) [f32; 8]);

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

/// One ray's hits on a block: the lanes hit inside `[t_min, t_max]`, and
/// each lane's `(t, u, v, determinant)`.
pub(crate) struct BlockHits {
    pub(crate) t: Lanes,
    pub(crate) u: Lanes,
    pub(crate) v: Lanes,
    pub(crate) det: Lanes,
    pub(crate) lanes: u8,
}

/// Tests the ray `origin + t·direction` against `block`'s triangles: the
/// one-triangle test's Möller–Trumbore, lane by lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
pub(crate) fn intersect(block: &TriangleBlock, origin: Vec3A, direction: Vec3A, t_min: f32, t_max: f32) -> BlockHits {
    use std::arch::x86_64::*;
    let set = |v: f32| _mm256_set1_ps(v);
    // SAFETY: `a` holds eight `f32`s on a 32-byte boundary, which the load reads.
    let load = |a: &Lanes| unsafe { _mm256_load_ps(a.0.as_ptr()) };
    let (mul, sub, add) = (
        |a: __m256, b: __m256| _mm256_mul_ps(a, b),
        |a: __m256, b: __m256| _mm256_sub_ps(a, b),
        |a: __m256, b: __m256| _mm256_add_ps(a, b),
    );
    let (dx, dy, dz) = (set(direction.x), set(direction.y), set(direction.z));
    let (e1x, e1y, e1z) = (load(&block.e1[0]), load(&block.e1[1]), load(&block.e1[2]));
    let (e2x, e2y, e2z) = (load(&block.e2[0]), load(&block.e2[1]), load(&block.e2[2]));
    // p = d × e2 (glam: a.y·b.z − a.z·b.y, …)
    let px = sub(mul(dy, e2z), mul(dz, e2y));
    let py = sub(mul(dz, e2x), mul(dx, e2z));
    let pz = sub(mul(dx, e2y), mul(dy, e2x));
    // glam's dot: (x·x' + y·y') + z·z'
    let dot = |ax, ay, az, bx, by, bz| add(add(mul(ax, bx), mul(ay, by)), mul(az, bz));
    let det = dot(e1x, e1y, e1z, px, py, pz);
    let abs = |v: __m256| _mm256_andnot_ps(set(-0.0), v);
    let mut ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, set(0.0)),
        _mm256_cmp_ps::<_CMP_LT_OQ>(abs(det), set(f32::INFINITY)),
    );
    let inv = _mm256_div_ps(set(1.0), det);
    let sx = sub(set(origin.x), load(&block.v0[0]));
    let sy = sub(set(origin.y), load(&block.v0[1]));
    let sz = sub(set(origin.z), load(&block.v0[2]));
    let u = mul(dot(sx, sy, sz, px, py, pz), inv);
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(u, set(0.0)));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(u, set(1.0)));
    // q = s × e1
    let qx = sub(mul(sy, e1z), mul(sz, e1y));
    let qy = sub(mul(sz, e1x), mul(sx, e1z));
    let qz = sub(mul(sx, e1y), mul(sy, e1x));
    let v = mul(dot(dx, dy, dz, qx, qy, qz), inv);
    let rejected_v =
        _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(v, set(0.0)), _mm256_cmp_ps::<_CMP_GT_OQ>(add(u, v), set(1.0)));
    ok = _mm256_andnot_ps(rejected_v, ok);
    let t = mul(dot(e2x, e2y, e2z, qx, qy, qz), inv);
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(t, set(t_min)));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(t, set(t_max)));
    let mut hits = BlockHits {
        t: Lanes::default(),
        u: Lanes::default(),
        v: Lanes::default(),
        det: Lanes::default(),
        lanes: (_mm256_movemask_ps(ok) as u8) & block.lanes,
    };
    if hits.lanes != 0 {
        // SAFETY: each holds eight `f32`s on a 32-byte boundary, which the store writes.
        unsafe {
            _mm256_store_ps(hits.t.0.as_mut_ptr(), t);
            _mm256_store_ps(hits.u.0.as_mut_ptr(), u);
            _mm256_store_ps(hits.v.0.as_mut_ptr(), v);
            _mm256_store_ps(hits.det.0.as_mut_ptr(), det);
        }
    }
    hits
}
