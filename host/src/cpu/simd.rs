//! Eight-lane AVX2 pieces the CPU backend's walks share: `f32` lanes on a
//! 32-byte boundary, the one-triangle test eight pairs at a time, and a CWBVH
//! node's quantized bounds and hit mask.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use obvhs::cwbvh::node::CwBvhNode;

/// Eight `f32` lanes on a 32-byte boundary: AVX2 loads and stores of them
/// never split a cache line.
#[derive(Copy, Clone, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct Lanes(pub(crate) [f32; 8]);

/// What [`intersect_triangles`] found: the lanes hit, and each lane's `t`,
/// barycentrics and determinant (filled only when a lane was hit).
pub(crate) struct Intersections {
    pub(crate) t: Lanes,
    pub(crate) u: Lanes,
    pub(crate) v: Lanes,
    pub(crate) det: Lanes,
    pub(crate) lanes: u8,
}

/// A vector of three coordinates, eight lanes each.
#[cfg(target_arch = "x86_64")]
pub(crate) type Vec3x8 = [__m256; 3];

/// Möller–Trumbore for eight (ray, triangle) pairs, lane by lane: each ray
/// `o + t·d` against the triangle `v0`, `v0 + e1`, `v0 + e2`, hit inside
/// `[t_min, t_max]`, among the `candidates` lanes. The same operations in the
/// same order as the one-triangle test in [`super::launch`] (glam's cross and
/// dot, no fused multiply-add), so every lane gets its bits exactly.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn intersect_triangles(
    [ox, oy, oz]: Vec3x8,
    [dx, dy, dz]: Vec3x8,
    [v0x, v0y, v0z]: Vec3x8,
    [e1x, e1y, e1z]: Vec3x8,
    [e2x, e2y, e2z]: Vec3x8,
    t_min: __m256,
    t_max: __m256,
    candidates: u8,
) -> Intersections {
    let set = |v: f32| _mm256_set1_ps(v);
    let (mul, sub, add) = (
        |a: __m256, b: __m256| _mm256_mul_ps(a, b),
        |a: __m256, b: __m256| _mm256_sub_ps(a, b),
        |a: __m256, b: __m256| _mm256_add_ps(a, b),
    );
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
    let (sx, sy, sz) = (sub(ox, v0x), sub(oy, v0y), sub(oz, v0z));
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
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(t, t_min));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(t, t_max));
    let mut found = Intersections {
        t: Lanes::default(),
        u: Lanes::default(),
        v: Lanes::default(),
        det: Lanes::default(),
        lanes: (_mm256_movemask_ps(ok) as u8) & candidates,
    };
    if found.lanes != 0 {
        // SAFETY: each holds eight `f32`s on a 32-byte boundary, which the store writes.
        unsafe {
            _mm256_store_ps(found.t.0.as_mut_ptr(), t);
            _mm256_store_ps(found.u.0.as_mut_ptr(), u);
            _mm256_store_ps(found.v.0.as_mut_ptr(), v);
            _mm256_store_ps(found.det.0.as_mut_ptr(), det);
        }
    }
    found
}

/// A node's eight quantized child coordinates `q`, widened exactly to `f32`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
pub(crate) fn quantized(q: &[u8; 8]) -> __m256 {
    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_set_epi64x(0, i64::from_le_bytes(*q))))
}

/// obvhs's hit mask of `node` (see `CwBvhNode::intersect_ray`) for the
/// children whose bits are set in `hits`.
#[inline(always)]
pub(crate) fn child_mask(node: &CwBvhNode, mut hits: u32, oct_inv4: u32) -> u32 {
    let (child_bits, bit_index) = node.get_child_and_index_bits(oct_inv4);
    let byte = |x: u64, b: u32| ((x >> (b * 8)) as u32) & 0xff;
    let mut mask = 0;
    while hits != 0 {
        let child = hits.trailing_zeros();
        hits &= hits - 1;
        mask |= byte(child_bits, child) << byte(bit_index, child);
    }
    mask
}
