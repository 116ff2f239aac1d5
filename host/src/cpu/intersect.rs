//! Ray intersection tests of the CPU backend's traversal: a BVH node's eight
//! children, and one triangle.

use glam::Vec3A;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray as BvhRay;

/// `direction` with its `-0.0` components made `+0.0` (adding `+0.0` does it and
/// changes nothing else), for the box tests: they pick a slab's near plane by
/// `direction < 0.0` but divide by the signed zero, so a `-0.0` component gave
/// an infinite near distance on the wrong plane and a ray along an axis
/// (`-Vec3::Z`) missed every box.
#[inline(always)]
pub(super) fn without_negative_zeros(direction: Vec3A) -> Vec3A {
    direction + Vec3A::ZERO
}

/// The hit mask of `node`'s children for `ray` (see [`CwBvhNode::intersect_ray`]);
/// `AVX2` only where the CPU has the features of
/// [`Traversal::run_avx2`](super::traverse::Traversal::run_avx2).
#[inline(always)]
pub(super) fn intersect_node<const AVX2: bool>(node: &CwBvhNode, ray: &BvhRay, oct_inv4: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: `AVX2` is true only inside `run_avx2`, run where the CPU has its features.
        return unsafe { intersect_node_avx2(node, ray, oct_inv4) };
    }
    node.intersect_ray(ray, oct_inv4)
}

/// [`CwBvhNode::intersect_ray`] with the eight children at once: the same
/// operations on each child (its quantized bounds widened exactly to `f32`, one
/// multiply and one add per slab plane, the same min/max order), so the same
/// mask, without the four-wide version's 48 scalar conversions.
///
/// # Safety
/// The CPU must have the features named below.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
unsafe fn intersect_node_avx2(node: &CwBvhNode, ray: &BvhRay, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    /// obvhs's lower bound on a child's entry distance.
    const EPSILON: f32 = 0.0001;
    let dir_inv = node.compute_extent() * ray.inv_direction;
    let origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // Eight quantized coordinates as `f32`s.
    let slab = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, dir_inv: f32, origin: f32| {
        let (lo, hi) = (super::simd::quantized(lo), super::simd::quantized(hi));
        let (near, far) = if negative { (hi, lo) } else { (lo, hi) };
        let (scale, offset) = (_mm256_set1_ps(dir_inv), _mm256_set1_ps(origin));
        (_mm256_add_ps(_mm256_mul_ps(near, scale), offset), _mm256_add_ps(_mm256_mul_ps(far, scale), offset))
    };
    let (tmin_x, tmax_x) = slab(&node.child_min_x, &node.child_max_x, ray.direction.x < 0.0, dir_inv.x, origin.x);
    let (tmin_y, tmax_y) = slab(&node.child_min_y, &node.child_max_y, ray.direction.y < 0.0, dir_inv.y, origin.y);
    let (tmin_z, tmax_z) = slab(&node.child_min_z, &node.child_max_z, ray.direction.z < 0.0, dir_inv.z, origin.z);
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(EPSILON));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(ray.tmax));
    let hits = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tmin, tmax)) as u32;
    super::simd::child_mask(node, hits, oct_inv4)
}

/// Möller–Trumbore: `(t, u, v, determinant)` of a hit inside `[t_min, t_max]`.
#[inline(always)]
pub(super) fn intersect_triangle(
    tri: &super::geometry::Triangle,
    origin: Vec3A,
    direction: Vec3A,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32, f32)> {
    let p = direction.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri.v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = direction.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t >= t_min && t <= t_max).then_some((t, u, v, det))
}
