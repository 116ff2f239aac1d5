//! Triangle surface hits (`Gas::mesh` and `raykit_device::triangle`) on each
//! backend, against plain f64 Rust.
//!
//! Far from the origin: a tessellated sphere of radius 100 centred near 10⁴ and
//! near 10⁵, once with its vertices there (a GAS) and once at the origin moved
//! there by a rotated, translated instance (an IAS). Rays from outside hit it;
//! each hit spawns one ray outward and one inward from
//! `TriangleSurface::spawn_origin`. The mesh is convex and closed, so an outward
//! ray must hit nothing at all and an inward ray must hit the far side (never
//! its own triangle, never nothing: no acne and no leaks). Every recorded hit
//! point lies within its error bound of the exact plane of its triangle (in
//! f64), and the bound is tight: the worst point comes within 16× of it.
//!
//! Quads and boxes (`Mesh::quad`, `Mesh::cuboid`): each face's geometric and
//! shading normal, the front-face flag from outside and from inside, and the
//! texture coordinates against the host's own ray–plane intersection. (Meshes
//! with bad attributes are in the bad-input catalogue, `bad_input.rs`.)

use raykit::device::sampling::Pcg;
use raykit::glam::{Affine3A, DAffine3, DVec3, Quat, Vec2, Vec3, Vec4};
use raykit::{Gas, Ias, Instance, LinkOptions, Mesh, Module, Pipeline, ProgramGroup, Sbt};
use raykit_tests::with_each_backend;
use spheres_test_device::{MeshRecord, Params, HIT_WORDS, MISS, RAY_WORDS};

/// A UV sphere of `radius` around `centre`: `rings` bands of `segments` quads
/// (triangles at the poles), outward-facing, with exact unit normals and uvs.
fn uv_sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for ring in 0..=rings {
        let theta = std::f64::consts::PI * ring as f64 / rings as f64;
        for segment in 0..=segments {
            let phi = 2.0 * std::f64::consts::PI * segment as f64 / segments as f64;
            let n = DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push((centre.as_dvec3() + n * radius as f64).as_vec3());
            normals.push(n.as_vec3());
            uvs.push(Vec2::new(segment as f32 / segments as f32, ring as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    let mut indices = Vec::new();
    for ring in 0..rings {
        for segment in 0..segments {
            let (a, b) = (ring * row + segment, ring * row + segment + 1);
            let (c, d) = (a + row, b + row);
            // Counter-clockwise seen from outside.
            if ring > 0 {
                indices.extend([a, b, c]);
            }
            if ring + 1 < rings {
                indices.extend([b, d, c]);
            }
        }
    }
    Mesh::new(positions, indices).with_normals(normals).with_uvs(uvs)
}

/// One ray with its bounce direction (zero: none).
#[derive(Copy, Clone, Debug)]
struct TestRay {
    origin: Vec3,
    direction: Vec3,
    bounce: Vec3,
}

/// What the device recorded for one ray.
#[derive(Copy, Clone, Debug)]
struct DeviceHit {
    kind: u32,
    primitive: u32,
    instance: u32,
    position: Vec3,
    plane_error: f32,
    normal: Vec3,
    front: bool,
    /// The bounce ray's `(t, kind, primitive, instance)`.
    bounce: Vec4,
}

/// Which closest-hit program records the hits.
#[derive(Copy, Clone, PartialEq, Eq)]
enum Record {
    /// Position, plane error, geometric normal, spawn origin.
    Spawn,
    /// uv (in position.xy) and the shading normal.
    Shading,
}

/// Traces `rays` into one instance of `mesh`'s GAS with `transform`.
fn trace(
    ctx: &raykit::Context,
    mesh: &Mesh,
    transform: Affine3A,
    rays: &[TestRay],
    record: Record,
) -> anyhow::Result<Vec<DeviceHit>> {
    let gas = Gas::mesh(ctx, mesh)?;
    let data = gas.mesh_data().ok_or_else(|| anyhow::anyhow!("Gas::mesh kept no mesh data"))?;
    let scene = Ias::new(ctx, &[Instance::new(&gas).transform(transform)])?;
    drop(gas);
    let module = Module::from_device_crate(ctx, "spheres-test-device")?;
    let raygen = ProgramGroup::raygen(&module, spheres_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, spheres_test_device::MS)?;
    let closest = match record {
        Record::Spawn => spheres_test_device::CH_TRIANGLE,
        Record::Shading => spheres_test_device::CH_TRIANGLE_SHADING,
    };
    let hit = ProgramGroup::hit_group(&module).closest_hit(closest).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt =
        Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, MeshRecord { mesh: data }).build()?;
    let words: Vec<Vec4> = rays
        .iter()
        .flat_map(|r| {
            let trace_bounce = if r.bounce == Vec3::ZERO { 0.0 } else { 1.0 };
            [r.origin.extend(0.0), r.direction.extend(1e30), r.bounce.extend(trace_bounce)]
        })
        .collect();
    assert_eq!(words.len(), rays.len() * RAY_WORDS as usize);
    let input = ctx.buffer_from(&words)?;
    let output = ctx.buffer::<Vec4>(rays.len() * HIT_WORDS as usize)?;
    let params = Params { rays: input.handle(), hits: output.handle(), scene: scene.handle() };
    pipeline.launch(&sbt, &params, [rays.len() as u32, 1, 1])?;
    Ok(output
        .read()?
        .chunks(HIT_WORDS as usize)
        .map(|w| DeviceHit {
            kind: w[0].y as u32,
            primitive: w[0].z as u32,
            instance: w[0].w as u32,
            position: w[1].truncate(),
            plane_error: w[1].w,
            normal: w[2].truncate(),
            front: w[2].w == 1.0,
            bounce: w[3],
        })
        .collect())
}

/// Triangle `primitive` of `mesh` in world space (f64), through `transform`.
fn world_triangle(mesh: &Mesh, transform: Affine3A, primitive: u32) -> [DVec3; 3] {
    let t = DAffine3::from_cols_array(&transform.to_cols_array().map(f64::from));
    let i = 3 * primitive as usize;
    [0, 1, 2].map(|k| t.transform_point3(mesh.positions[mesh.indices[i + k] as usize].as_dvec3()))
}

/// A unit direction around `n`, at least 0.05 off the plane it is normal to.
fn around(rng: &mut Pcg, n: DVec3) -> Vec3 {
    loop {
        let d = rng.cosine_around(n.as_vec3());
        if d.as_dvec3().dot(n) > 0.05 {
            return d;
        }
    }
}

/// Rays leaving a sphere mesh far from the origin: none hits its own surface.
fn spawn_far_from_origin(
    ctx: &raykit::Context,
    backend: raykit::Backend,
    centre: Vec3,
    instanced: bool,
) -> anyhow::Result<()> {
    let radius = 100.0f32;
    let (mesh, transform) = if instanced {
        let rotation = Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.9);
        (uv_sphere(Vec3::ZERO, radius, 24, 48), Affine3A::from_rotation_translation(rotation, centre))
    } else {
        (uv_sphere(centre, radius, 24, 48), Affine3A::IDENTITY)
    };
    let what =
        format!("[{backend:?}] sphere mesh at {centre} ({})", if instanced { "instanced" } else { "in the GAS" });
    let mut rng = Pcg::new(centre.x as u32 ^ u32::from(instanced), 5);
    let count = 1024;
    // Primary rays from 3 radii away at points within 0.7 radii of the centre.
    let primaries: Vec<(Vec3, Vec3)> = (0..count)
        .map(|_| {
            let from = centre.as_dvec3() + random_unit(&mut rng) * 3.0 * radius as f64;
            let to = centre.as_dvec3() + random_unit(&mut rng) * 0.7 * radius as f64 * rng.next_f32() as f64;
            (from.as_vec3(), (to - from).normalize().as_vec3())
        })
        .collect();
    // The exact triangle each primary hits is known only after tracing: trace
    // once without bounces, then again with bounces around its exact normal.
    let plain: Vec<TestRay> =
        primaries.iter().map(|&(o, d)| TestRay { origin: o, direction: d, bounce: Vec3::ZERO }).collect();
    let first = trace(ctx, &mesh, transform, &plain, Record::Spawn)?;
    let mut rays = Vec::new();
    let mut normals = Vec::new();
    for (i, (hit, &(origin, direction))) in first.iter().zip(&primaries).enumerate() {
        anyhow::ensure!(hit.kind != MISS, "{what}: primary ray {i} missed the mesh");
        let [a, b, c] = world_triangle(&mesh, transform, hit.primitive);
        let n = (b - a).cross(c - a).normalize();
        normals.push(n);
        let outward = i % 2 == 0;
        let bounce = if outward { around(&mut rng, n) } else { around(&mut rng, -n) };
        rays.push(TestRay { origin, direction, bounce });
    }
    let got = trace(ctx, &mesh, transform, &rays, Record::Spawn)?;
    let (mut worst_ratio, mut far_side) = (0.0f64, 0);
    for (i, (hit, (ray, n))) in got.iter().zip(rays.iter().zip(&normals)).enumerate() {
        let at = || format!("{what}: ray {i} {ray:?}: {hit:?}");
        anyhow::ensure!(hit.kind != MISS && hit.instance == 0, "{}: the primary ray missed", at());
        anyhow::ensure!(hit.front, "{}: a ray from outside hit a back face", at());
        let [a, b, c] = world_triangle(&mesh, transform, hit.primitive);
        let exact = (b - a).cross(c - a).normalize();
        anyhow::ensure!(exact == *n, "{}: the second trace hit another triangle", at());
        let normal_error = (hit.normal.as_dvec3() - exact).length();
        anyhow::ensure!(normal_error < 1e-4, "{}: geometric normal off by {normal_error}", at());
        // The recorded point lies within its bound of the triangle's plane.
        let distance = (hit.position.as_dvec3() - a).dot(exact).abs();
        let bound = hit.plane_error as f64;
        anyhow::ensure!(distance <= bound, "{}: {distance} from the plane, over its bound {bound}", at());
        worst_ratio = worst_ratio.max(distance / bound);
        let (kind, primitive) = (hit.bounce.y as u32, hit.bounce.z as u32);
        if i % 2 == 0 {
            anyhow::ensure!(
                kind == MISS,
                "{}: an outward ray hit the convex mesh again (primitive {primitive}, t {})",
                at(),
                hit.bounce.x
            );
        } else {
            anyhow::ensure!(kind != MISS, "{}: an inward ray left the closed mesh (a leak)", at());
            anyhow::ensure!(
                primitive != hit.primitive,
                "{}: an inward ray hit its own triangle at t {}",
                at(),
                hit.bounce.x
            );
            far_side += 1;
        }
    }
    eprintln!(
        "{what}: {count} hits, {far_side} inward rays reached the far side; worst point {:.3} of its bound (1/{:.1})",
        worst_ratio,
        1.0 / worst_ratio
    );
    anyhow::ensure!(
        worst_ratio * 16.0 >= 1.0,
        "{what}: the bound is loose: the worst point reached only {worst_ratio:.4} of it"
    );
    Ok(())
}

/// A uniformly random unit vector.
fn random_unit(rng: &mut Pcg) -> DVec3 {
    loop {
        let v = DVec3::new(rng.next_f32() as f64, rng.next_f32() as f64, rng.next_f32() as f64) * 2.0 - 1.0;
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

#[test]
fn rays_spawned_from_triangles_far_from_the_origin_never_hit_their_own_surface() -> anyhow::Result<()> {
    with_each_backend("rays_spawned_from_triangles_far_from_the_origin", |ctx, backend| {
        for centre in [Vec3::new(1.0e4, -0.7e4, 0.4e4), Vec3::new(1.0e5, 0.6e5, -0.8e5)] {
            for instanced in [false, true] {
                spawn_far_from_origin(ctx, backend, centre, instanced)?;
            }
        }
        Ok(())
    })
}

#[test]
fn quads_and_boxes_have_exact_normals_faces_and_texture_coordinates() -> anyhow::Result<()> {
    let (min, max) = (Vec3::new(-1.0, -0.5, -2.0), Vec3::new(2.0, 1.5, 0.5));
    let cube = Mesh::cuboid(max, min);
    assert_eq!((cube.positions.len(), cube.triangle_count()), (24, 12));
    let centre = (min + max) * 0.5;
    // Per face: its outward axis, and the quad corner and edges it was made from.
    let faces: [(Vec3, Vec3, Vec3, Vec3); 6] = [
        (Vec3::Z, Vec3::new(min.x, min.y, max.z), Vec3::X, Vec3::Y),
        (Vec3::X, Vec3::new(max.x, min.y, max.z), -Vec3::Z, Vec3::Y),
        (-Vec3::Z, Vec3::new(max.x, min.y, min.z), -Vec3::X, Vec3::Y),
        (-Vec3::X, Vec3::new(min.x, min.y, min.z), Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::new(min.x, max.y, max.z), Vec3::X, -Vec3::Z),
        (-Vec3::Y, Vec3::new(min.x, min.y, min.z), Vec3::X, Vec3::Z),
    ];
    let d = max - min;
    let mut rng = Pcg::new(3, 9);
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    for (axis, corner, u, v) in faces {
        let (u, v) = (u * d.abs().dot(u.abs()), v * d.abs().dot(v.abs()));
        for k in 0..32 {
            let (s, t) = (0.05 + 0.9 * rng.next_f32(), 0.05 + 0.9 * rng.next_f32());
            let target = corner + s * u + t * v;
            let inside = k % 2 == 1;
            let origin = if inside { centre } else { target + axis * 3.0 + (u + v) * 0.1 };
            rays.push(TestRay { origin, direction: (target - origin).normalize(), bounce: Vec3::ZERO });
            expected.push((axis, Vec2::new(s, t), !inside));
        }
    }
    with_each_backend("quads_and_boxes_have_exact_normals", |ctx, backend| {
        let spawn = trace(ctx, &cube, Affine3A::IDENTITY, &rays, Record::Spawn)?;
        let shading = trace(ctx, &cube, Affine3A::IDENTITY, &rays, Record::Shading)?;
        for (i, ((geo, sh), (axis, uv, front))) in spawn.iter().zip(&shading).zip(&expected).enumerate() {
            let at = || format!("[{backend:?}] box ray {i} {:?}: {geo:?} {sh:?}", rays[i]);
            anyhow::ensure!(geo.kind != MISS, "{}: missed", at());
            anyhow::ensure!((geo.normal - *axis).abs().max_element() < 1e-6, "{}: geometric normal, want {axis}", at());
            anyhow::ensure!((sh.normal - *axis).abs().max_element() < 1e-6, "{}: shading normal, want {axis}", at());
            anyhow::ensure!(geo.front == *front, "{}: front face {}, want {front}", at(), geo.front);
            let got_uv = sh.position.truncate();
            anyhow::ensure!((got_uv - *uv).abs().max_element() < 1e-4, "{}: uv {got_uv}, want {uv}", at());
        }
        eprintln!("[{backend:?}] box: {} rays, normals, faces and uvs as made", rays.len());
        Ok(())
    })
}
