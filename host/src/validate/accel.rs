//! Validation of GAS build inputs: everything the Vulkan valid-usage rules and the
//! device's limits require, checked before anything is uploaded; pure and unit-tested.

use std::hash::{Hash, Hasher};

use glam::Affine3A;

use crate::error::AccelError;
use crate::error::{Error, Result};
use crate::types::accel::{Aabbs, BuildInput, Indices, Shape, Triangles, AABB_SIZE, VERTEX_SIZE};
use crate::types::context::DeviceLimits;

fn check_stride(geometry: usize, what: &'static str, stride: u64, alignment: u64, min: u64) -> Result<()> {
    if !stride.is_multiple_of(alignment) || stride < min || stride > u32::MAX as u64 {
        return Err(Error::Accel(AccelError::MisalignedStride { geometry, what, stride, alignment, min }));
    }
    Ok(())
}

fn check_len(geometry: usize, what: &'static str, len: usize, count: usize, stride: u64, element: u64) -> Result<()> {
    let needed = (count as u64 - 1).saturating_mul(stride).saturating_add(element);
    if (len as u64) < needed {
        return Err(Error::Accel(AccelError::InputTooShort { geometry, what, needed, len: len as u64 }));
    }
    Ok(())
}

fn check_transform(what: String, t: &Affine3A) -> Result<()> {
    if !t.is_finite() {
        return Err(Error::Accel(AccelError::NonFiniteTransform { what }));
    }
    Ok(())
}

/// Checks a `Gas::mesh` mesh's attributes: one normal and one uv per position
/// when given, finite. (Its positions and indices are the GAS's triangles,
/// checked as every triangle input is.)
pub(crate) fn mesh(mesh: &crate::types::mesh::Mesh) -> Result<()> {
    let vertices = mesh.positions.len();
    let refuse = |attribute, reason: String| Err(Error::Accel(AccelError::MeshAttribute { attribute, reason }));
    if let Some(normals) = &mesh.normals {
        if normals.len() != vertices {
            return refuse(
                "normals",
                format!("{} normals for {vertices} positions; give one per position, or none", normals.len()),
            );
        }
        if let Some(i) = normals.iter().position(|n| !n.is_finite()) {
            return refuse("normals", format!("normal {i} is {} (not finite); give finite normals", normals[i]));
        }
    }
    if let Some(uvs) = &mesh.uvs {
        if uvs.len() != vertices {
            return refuse(
                "uvs",
                format!("{} texture coordinates for {vertices} positions; give one per position, or none", uvs.len()),
            );
        }
        if let Some(i) = uvs.iter().position(|uv| !uv.is_finite()) {
            return refuse("uvs", format!("texture coordinate {i} is {} (not finite); give finite ones", uvs[i]));
        }
    }
    Ok(())
}

/// Checks the inputs of `Gas::spheres`: one radius per centre, finite
/// centres, radii finite and ≥ 0, and boxes (centre ± radius) within `f32`.
pub(crate) fn spheres(centres: &[glam::Vec3], radii: &[f32]) -> Result<()> {
    if centres.len() != radii.len() {
        return Err(Error::Accel(AccelError::SphereCount { centres: centres.len(), radii: radii.len() }));
    }
    for (sphere, (centre, &radius)) in centres.iter().zip(radii).enumerate() {
        let reason = if !centre.is_finite() {
            Some("its centre is not finite; give finite coordinates")
        } else if radius.is_nan() {
            Some("its radius is NaN; give a finite radius ≥ 0")
        } else if radius.is_infinite() {
            Some("its radius is infinite; give a finite radius ≥ 0 (a plane is two triangles)")
        } else if radius < 0.0 {
            Some("its radius is negative; give a radius ≥ 0")
        } else if !(*centre - glam::Vec3::splat(radius)).is_finite()
            || !(*centre + glam::Vec3::splat(radius)).is_finite()
        {
            Some("centre ± radius overflows f32; make the sphere smaller or scale the scene down")
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(Error::Accel(AccelError::InvalidSphere { sphere, centre: centre.to_array(), radius, reason }));
        }
    }
    Ok(())
}

/// Checks the inputs of `Gas::moving_spheres`: as many end centres as start
/// centres, each end a sphere `Gas::spheres` accepts, and the sweep's box
/// within `f32`.
pub(crate) fn moving_spheres(start: &[glam::Vec3], end: &[glam::Vec3], radii: &[f32]) -> Result<()> {
    if start.len() != end.len() {
        return Err(Error::Accel(AccelError::MovingSphereCount { start: start.len(), end: end.len() }));
    }
    spheres(start, radii)?;
    spheres(end, radii)
}

/// Checks `inputs` against Vulkan's rules and `limits`; returns each geometry's
/// shape. Pure: nothing is uploaded. `for_update` also fingerprints the index
/// data (needed only by builds that allow updates).
pub(crate) fn validate(inputs: &[BuildInput<'_>], limits: &DeviceLimits, for_update: bool) -> Result<Vec<Shape>> {
    if inputs.is_empty() {
        return Err(Error::Accel(AccelError::Empty { what: "the GAS build has no geometry".to_owned() }));
    }
    if inputs.len() as u64 > limits.max_geometry_count {
        return Err(Error::Accel(AccelError::Limit {
            what: "geometries",
            count: inputs.len() as u64,
            limit: limits.max_geometry_count,
            limit_name: "maxGeometryCount",
        }));
    }
    let mut shapes = Vec::with_capacity(inputs.len());
    let mut total: u64 = 0;
    for (g, input) in inputs.iter().enumerate() {
        let first = &inputs[0];
        if std::mem::discriminant(first) != std::mem::discriminant(input) {
            return Err(Error::Accel(AccelError::MixedGeometryTypes { first: 0, other: g }));
        }
        let shape = match input {
            BuildInput::Triangles(t) => validate_triangles(g, t, for_update)?,
            BuildInput::Aabbs(a) => validate_aabbs(g, a)?,
        };
        total += shape.primitives() as u64;
        shapes.push(shape);
    }
    if total > limits.max_primitive_count {
        return Err(Error::Accel(AccelError::Limit {
            what: "primitives in one GAS",
            count: total,
            limit: limits.max_primitive_count,
            limit_name: "maxPrimitiveCount",
        }));
    }
    Ok(shapes)
}

/// `count` fits the 32 bits Vulkan takes for it (`limit_name`).
fn check_fits_u32(what: &'static str, count: usize, limit_name: &'static str) -> Result<()> {
    if count > u32::MAX as usize {
        return Err(Error::Accel(AccelError::Limit { what, count: count as u64, limit: u32::MAX as u64, limit_name }));
    }
    Ok(())
}

fn validate_triangles(g: usize, t: &Triangles<'_>, for_update: bool) -> Result<Shape> {
    check_stride(g, "vertex", t.stride, 4, VERTEX_SIZE)?;
    if t.vertex_count == 0 {
        return Err(Error::Accel(AccelError::Empty { what: format!("geometry {g} has no vertices") }));
    }
    check_fits_u32("vertices in one geometry", t.vertex_count, "the 32-bit maxVertex")?;
    check_len(g, "vertex", t.vertex_bytes.len(), t.vertex_count, t.stride, VERTEX_SIZE)?;
    let index_count = match t.indices {
        Indices::None => {
            if !t.vertex_count.is_multiple_of(3) {
                return Err(Error::Accel(AccelError::TriangleCount {
                    geometry: g,
                    what: "vertices without indices",
                    count: t.vertex_count,
                }));
            }
            t.vertex_count
        }
        ref indices => {
            let n = indices.len();
            if n == 0 {
                return Err(Error::Accel(AccelError::Empty {
                    what: format!("geometry {g} has an empty index buffer"),
                }));
            }
            if !n.is_multiple_of(3) {
                return Err(Error::Accel(AccelError::TriangleCount { geometry: g, what: "indices", count: n }));
            }
            for i in 0..n {
                let index = indices.get(i);
                if index as usize >= t.vertex_count {
                    return Err(Error::Accel(AccelError::IndexOutOfRange {
                        geometry: g,
                        position: i,
                        index,
                        vertex_count: t.vertex_count as u64,
                    }));
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
            return Err(Error::Accel(AccelError::NonFiniteVertex { geometry: g, vertex: v, position: p }));
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
        return Err(Error::Accel(AccelError::Empty { what: format!("geometry {g} has no AABBs") }));
    }
    check_fits_u32("AABBs in one geometry", a.count, "the 32-bit primitiveCount")?;
    check_len(g, "AABB", a.bytes.len(), a.count, a.stride, AABB_SIZE)?;
    for i in 0..a.count {
        let b = a.aabb(i);
        let finite = b.min.iter().chain(&b.max).all(|c| c.is_finite());
        let ordered = (0..3).all(|k| b.min[k] <= b.max[k]);
        if !finite || !ordered {
            return Err(Error::Accel(AccelError::InvalidAabb {
                geometry: g,
                primitive: i,
                min: b.min,
                max: b.max,
                reason: if finite { "min is greater than max on some axis" } else { "a coordinate is not finite" },
            }));
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
                format!("geometry {g} changed from {} to {}", a.kind_name(), b.kind_name())
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
    use crate::types::accel::Aabb;
    use glam::Vec3;

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
        assert!(
            matches!(err, Error::Accel(AccelError::Limit { count: 5, limit: 4, limit_name: "maxPrimitiveCount", .. })),
            "{err}"
        );
        let t: BuildInput<'_> = Triangles::new(&TRI).into();
        let err = validate(&[t, t, t], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::Limit { limit_name: "maxGeometryCount", .. })), "{err}");
        assert!(validate(&[t, t], &limits(), true).is_ok());
    }

    #[test]
    fn strides_must_be_aligned_and_cover_a_vertex() {
        let bytes = [0u8; 64];
        for stride in [10, 14, 8] {
            let err = validate(&[Triangles::strided(&bytes, stride, 3).into()], &limits(), true).unwrap_err();
            assert!(matches!(err, Error::Accel(AccelError::MisalignedStride { alignment: 4, .. })), "{stride}: {err}");
        }
        let err = validate(&[Triangles::strided(&bytes, 32, 3).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::InputTooShort { needed: 76, len: 64, .. })), "{err}");
        assert!(validate(&[Triangles::strided(&bytes, 16, 3).into()], &limits(), true).is_ok());
        let boxes = [0u8; 96];
        let err = validate(&[Aabbs::strided(&boxes, 28, 2).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::MisalignedStride { alignment: 8, .. })), "{err}");
        assert!(validate(&[Aabbs::strided(&boxes, 32, 3).into()], &limits(), true).is_ok());
    }

    #[test]
    fn indices_and_vertices_are_checked() {
        let err = validate(&[Triangles::new(&TRI).indices_u16(&[0, 1, 3]).into()], &limits(), true).unwrap_err();
        assert!(
            matches!(err, Error::Accel(AccelError::IndexOutOfRange { position: 2, index: 3, vertex_count: 3, .. })),
            "{err}"
        );
        let err = validate(&[Triangles::new(&TRI).indices_u32(&[0, 1]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::TriangleCount { count: 2, .. })), "{err}");
        let err = validate(&[Triangles::new(&TRI[..2]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::TriangleCount { count: 2, .. })), "{err}");
        let err = validate(&[Triangles::new(&[]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::Empty { .. })), "{err}");
        let err = validate(&[Triangles::new(&TRI).indices_u32(&[]).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::Empty { .. })), "{err}");
        let bad = [Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0), Vec3::Y];
        let err = validate(&[Triangles::new(&bad).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::NonFiniteVertex { vertex: 1, .. })), "{err}");
        let err = validate(
            &[Triangles::new(&TRI).transform(Affine3A::from_scale(Vec3::splat(f32::NAN))).into()],
            &limits(),
            true,
        )
        .unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::NonFiniteTransform { .. })), "{err}");
    }

    #[test]
    fn boxes_must_be_finite_and_ordered() {
        let flipped = [Aabb::new(Vec3::ONE, Vec3::ZERO)];
        let err = validate(&[Aabbs::new(&flipped).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::InvalidAabb { primitive: 0, .. })), "{err}");
        let nan = [Aabb::new(Vec3::ZERO, Vec3::ONE), Aabb::new(Vec3::ZERO, Vec3::splat(f32::NAN))];
        let err = validate(&[Aabbs::new(&nan).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::InvalidAabb { primitive: 1, .. })), "{err}");
    }

    #[test]
    fn spheres_need_finite_centres_and_radii() {
        use glam::Vec3;
        let ok = [Vec3::ZERO, Vec3::X];
        assert!(spheres(&ok, &[1.0, 0.0]).is_ok());
        let err = spheres(&ok, &[1.0]).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::SphereCount { centres: 2, radii: 1 })), "{err}");
        for (radius, what) in [(f32::NAN, "NaN"), (f32::INFINITY, "infinite"), (-1.0, "negative")] {
            let err = spheres(&ok, &[1.0, radius]).unwrap_err();
            assert!(matches!(err, Error::Accel(AccelError::InvalidSphere { sphere: 1, .. })), "{err}");
            assert!(err.to_string().contains(what), "{err}");
        }
        let err = spheres(&[Vec3::new(f32::MAX, 0.0, 0.0)], &[1e38]).unwrap_err();
        assert!(err.to_string().contains("overflows"), "{err}");
        let err = spheres(&[Vec3::new(0.0, f32::NAN, 0.0)], &[1.0]).unwrap_err();
        assert!(err.to_string().contains("centre is not finite"), "{err}");
        // A sphere that reaches f32::MAX is accepted, and its box stays finite.
        let (centre, radius) = (Vec3::new(f32::MAX / 2.0, 0.0, -f32::MAX / 2.0), f32::MAX / 2.0);
        assert!(spheres(&[centre], &[radius]).is_ok());
        let b = crate::types::accel::Aabb::around_sphere(centre, radius);
        assert!(b.min.iter().chain(&b.max).all(|v| v.is_finite()), "{b:?}");
        assert!(b.max[0] == f32::MAX && b.min[2] == f32::MIN && b.min[0] <= 0.0, "{b:?}");
        // The box holds the sphere: rounded outwards.
        let b = crate::types::accel::Aabb::around_sphere(Vec3::new(0.1, -1000.0, 3.0), 1000.0);
        assert!(b.min[0] < 0.1 - 1000.0 && b.max[1] > 0.0 && b.min[1] < -2000.0 && b.max[2] > 1003.0);
        let boxes = [Aabb::new(Vec3::ZERO, Vec3::ONE)];
        let err = validate(&[Triangles::new(&TRI).into(), Aabbs::new(&boxes).into()], &limits(), true).unwrap_err();
        assert!(matches!(err, Error::Accel(AccelError::MixedGeometryTypes { first: 0, other: 1 })), "{err}");
    }

    #[test]
    fn a_sweeps_box_holds_the_sphere_wherever_the_device_puts_it() {
        // The device's centre: `raykit_device::sphere::moving_sphere_at`, in f32.
        let mut rng = raykit_device::sampling::Pcg::new(5, 3);
        // Random sweeps, and centres far from the origin with radii nearly as large
        // (the box's faces near 0, where its ulps are smaller than the centre's).
        let mut sweeps: Vec<(Vec3, Vec3, f32)> = (0..2000)
            .map(|_| {
                let scale = 10f32.powi((rng.next_f32() * 8.0) as i32 - 2);
                let point = |rng: &mut raykit_device::sampling::Pcg| (rng.next_vec3() * 2.0 - 1.0) * scale;
                (point(&mut rng), point(&mut rng), rng.next_f32() * scale)
            })
            .collect();
        for k in 0..200 {
            let c = Vec3::splat(1000.0 + k as f32);
            sweeps.extend([(c, c, 999.9 + k as f32), (c, c + Vec3::new(0.0, 0.25, 0.5), 999.95 + k as f32)]);
        }
        for (start, end, radius) in sweeps {
            let b = crate::types::accel::Aabb::around_sweep(start, end, radius);
            for k in 0..=256 {
                let t = if k % 2 == 0 { k as f32 / 256.0 } else { rng.next_f32() };
                let at = raykit_device::sphere::moving_sphere_at(start.extend(radius), end.extend(radius), t);
                let (lo, hi) = (at.truncate() - Vec3::splat(at.w), at.truncate() + Vec3::splat(at.w));
                let inside = (0..3).all(|i| b.min[i] <= lo[i] && hi[i] <= b.max[i]);
                assert!(inside, "{start} → {end}, r {radius}, t {t}: the sphere [{lo}, {hi}] leaves {b:?}");
            }
        }
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
