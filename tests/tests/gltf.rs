//! glTF scenes against a CPU reference of their primary hits, on both backends
//! (`with_each_backend`: Vulkan, then the CPU backend, same references).
//!
//! The generated file (`raykit_tests::gltf_fixture`: two meshes, three textured
//! materials, a node hierarchy, an alpha-masked leaf with holes) is loaded, its
//! structure checked against what the generator wrote, and rendered: per pixel,
//! the primary hit's material index and texture coordinates. The CPU reference
//! traces the same triangles, placed by the same world transforms, with the
//! same alpha test (the leaf texture's texel, nearest, repeat). Pixels whose
//! answer a ray 0.02 pixel away would change (an edge, a hole's border) are
//! not compared; every other pixel must have the same material exactly, the
//! same texture coordinates within 10⁻³ and, away from texel edges, the same
//! base colour (the texel closest-hit sampled, in linear light, times the
//! material's factor) within 2/255.

use gltf_pathtracer::{GpuScene, Renderer};
use raykit::glam::{Vec2, Vec3};
use raykit_scene::gltf::{AlphaMode, GltfError, GltfScene};
use raykit_scene::Camera;
use raykit_tests::gltf_fixture::{self, Broken};
use raykit_tests::with_each_backend;

const SIZE: u32 = 64;

fn camera() -> Camera {
    Camera { eye: Vec3::new(0.0, 0.0, 5.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 40.0 }
}

/// The camera ray through `(x, y)` in pixels (the device's mapping).
fn ray(x: f32, y: f32) -> (Vec3, Vec3) {
    let (u, v, w) = camera().uvw(1.0);
    let d = 2.0 * Vec2::new(x, y) / SIZE as f32 - 1.0;
    (camera().eye, (d.x * u - d.y * v + w).normalize())
}

/// The linear value of an 8-bit sRGB code: the sRGB transfer function in `f64`,
/// the reference's own (it shares no code with the samplers it checks).
fn srgb_decode(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    (if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }) as f32
}

/// The CPU reference's primary hit: material, uv, whether an alpha test decided
/// it within 0.02 texel of a texel border, and whether the ray passed through a
/// hole of a masked surface before it.
fn cpu_hit(scene: &GltfScene, origin: Vec3, dir: Vec3) -> Option<(usize, Vec2, bool, bool)> {
    let mut best: Option<(f32, usize, Vec2, bool)> = None;
    let mut nearest_hole = f32::MAX;
    for inst in &scene.instances {
        for p in &scene.meshes[inst.mesh].primitives {
            let material = &scene.materials[p.material];
            for t in p.indices.chunks_exact(3) {
                let world = |i: u32| inst.transform.transform_point3(p.positions[i as usize]);
                let tri = [world(t[0]), world(t[1]), world(t[2])];
                let t_max = best.map_or(1e16, |b| b.0);
                let Some((dist, b)) = raykit_tests::ray_triangle(origin, dir, tri, 1e-4, t_max) else { continue };
                let uvs = [t[0], t[1], t[2]].map(|i| p.uvs[i as usize]);
                let uv = uvs[0] * (1.0 - b.x - b.y) + uvs[1] * b.x + uvs[2] * b.y;
                let mut near_edge = false;
                if let AlphaMode::Mask(cutoff) = material.alpha {
                    let img = &scene.images[material.base_color_texture.unwrap()];
                    let (tx, ty) = (uv.x * img.width as f32, uv.y * img.height as f32);
                    let frac = |c: f32| (c - c.round()).abs();
                    near_edge = frac(tx) < 0.02 || frac(ty) < 0.02;
                    let (ix, iy) = (
                        (tx.floor() as i64).rem_euclid(img.width as i64),
                        (ty.floor() as i64).rem_euclid(img.height as i64),
                    );
                    let alpha = img.rgba8[((iy * img.width as i64 + ix) * 4 + 3) as usize] as f32 / 255.0;
                    if alpha * material.base_color.w < cutoff {
                        if near_edge {
                            // The device may take this hit; the answer is ambiguous.
                            best = best.map(|b| (b.0, b.1, b.2, true));
                        }
                        nearest_hole = nearest_hole.min(dist);
                        continue;
                    }
                }
                best = Some((dist, p.material, uv, near_edge));
            }
        }
    }
    best.map(|(t, m, uv, edge)| (m, uv, edge, nearest_hole < t))
}

#[test]
fn the_gltf_loader_reads_the_hierarchy_materials_and_meshes() -> anyhow::Result<()> {
    let dir = raykit_tests::temp_dir("gltf_loader")?;
    let scene = GltfScene::load(&gltf_fixture::write(&dir.0, Broken::Nothing)?)?;
    anyhow::ensure!(scene.meshes.len() == 2 && scene.meshes[1].primitives.len() == 2);
    anyhow::ensure!(scene.materials.len() == 4, "three materials and the default");
    let names: Vec<_> = scene.materials.iter().map(|m| m.name.clone().unwrap_or_default()).collect();
    anyhow::ensure!(names[..3] == ["checker", "gradient", "leaf"], "{names:?}");
    anyhow::ensure!(scene.materials[2].alpha == AlphaMode::Mask(0.5));
    anyhow::ensure!(scene.materials[1].base_color.y == 0.8 && scene.materials[1].roughness == 0.2);
    anyhow::ensure!(
        scene.images.len() == 3
            && scene.images
                == gltf_fixture::images().map(|i| raykit_scene::gltf::Image {
                    width: i.width(),
                    height: i.height(),
                    rgba8: i.into_raw(),
                })
    );
    let meshes: Vec<usize> = scene.instances.iter().map(|i| i.mesh).collect();
    anyhow::ensure!(meshes == [0, 1, 0], "{meshes:?}");
    for (inst, want) in scene.instances.iter().zip(gltf_fixture::expected_transforms()) {
        anyhow::ensure!(inst.transform.abs_diff_eq(want, 1e-5), "node {}: {} vs {want}", inst.node, inst.transform);
    }
    let leaf = &scene.meshes[1].primitives[1];
    anyhow::ensure!(leaf.indices == [0, 1, 2, 0, 2, 3] && leaf.uvs == gltf_fixture::LEAF_UV);
    anyhow::ensure!(scene.meshes[0].primitives[0].normals == [Vec3::Z; 4]);
    Ok(())
}

#[test]
fn primary_hits_match_the_cpu_reference() -> anyhow::Result<()> {
    let dir = raykit_tests::temp_dir("gltf_primary")?;
    let scene = GltfScene::load(&gltf_fixture::write(&dir.0, Broken::Nothing)?)?;
    with_each_backend("primary_hits_match_the_cpu_reference", |ctx, backend| {
        let gpu = GpuScene::new(ctx, &scene)?;
        anyhow::ensure!(gpu.records.len() == 4, "board, plant (2 primitives), backdrop");
        let renderer = Renderer::new(ctx, &gpu)?;
        let (got, colors) = renderer.primary_hits(ctx, &gpu, &camera(), SIZE, SIZE)?;
        let (mut compared, mut skipped, mut failures) = (0, 0, Vec::new());
        let mut per_material = [0usize; 4];
        let mut holes = 0;
        let mut worst_color: f32 = 0.0;
        for y in 0..SIZE {
            for x in 0..SIZE {
                let at = |dx: f32, dy: f32| {
                    let (o, d) = ray(x as f32 + 0.5 + dx, y as f32 + 0.5 + dy);
                    cpu_hit(&scene, o, d)
                };
                let centre = at(0.0, 0.0);
                let ambiguous = centre.is_some_and(|c| c.2)
                    || [(0.02, 0.0), (-0.02, 0.0), (0.0, 0.02), (0.0, -0.02)]
                        .iter()
                        .any(|&(dx, dy)| at(dx, dy).map(|h| h.0) != centre.map(|h| h.0));
                if ambiguous {
                    skipped += 1;
                    continue;
                }
                compared += 1;
                let g = got[(y * SIZE + x) as usize];
                let ok = match centre {
                    None => g.x == -1.0,
                    Some((m, uv, _, _)) => {
                        per_material[m] += 1;
                        // The base colour closest-hit sampled: the texel (nearest, repeat) in linear
                        // light times the factor, within the sRGB decode's 8-bit rounding.
                        let material = &scene.materials[m];
                        let img = &scene.images[material.base_color_texture.unwrap()];
                        let (w, h) = (img.width as i64, img.height as i64);
                        let (tx, ty) = (uv.x * w as f32, uv.y * h as f32);
                        let on_edge = (tx - tx.round()).abs() < 0.02 || (ty - ty.round()).abs() < 0.02;
                        let (ix, iy) = ((tx.floor() as i64).rem_euclid(w), (ty.floor() as i64).rem_euclid(h));
                        let at = ((iy * w + ix) * 4) as usize;
                        let texel = Vec3::from_array(std::array::from_fn(|c| srgb_decode(img.rgba8[at + c])));
                        let want = texel * material.base_color.truncate();
                        let color = colors[(y * SIZE + x) as usize].truncate();
                        let color_error = (color - want).abs().max_element();
                        if !on_edge && g.x == m as f32 {
                            worst_color = worst_color.max(color_error);
                        }
                        g.x == m as f32
                            && (Vec2::new(g.y, g.z) - uv).abs().max_element() < 1e-3
                            && (on_edge || color_error < 2.0 / 255.0)
                    }
                };
                // The plant's quad seen through a hole of the leaf in front of it.
                if centre.is_some_and(|c| c.0 == 1 && c.3) {
                    holes += 1;
                }
                if !ok && failures.len() < 20 {
                    failures.push(format!(
                        "pixel ({x}, {y}): device {g}, colour {}, reference {centre:?}",
                        colors[(y * SIZE + x) as usize]
                    ));
                }
            }
        }
        anyhow::ensure!(failures.is_empty(), "primary hits off the reference:\n{}", failures.join("\n"));
        anyhow::ensure!(skipped * 10 < compared, "{skipped} ambiguous pixels of {}", compared + skipped);
        anyhow::ensure!(per_material[..3].iter().all(|&n| n >= 20), "pixels per material: {per_material:?}");
        anyhow::ensure!(holes > 0, "no pixel sees the plant through the leaf's holes");
        eprintln!(
            "[{backend:?}] compared {compared} pixels ({skipped} ambiguous skipped): per material {per_material:?}, {holes} through holes; worst base colour error {worst_color:.2e} (tolerance {:.2e})",
            2.0 / 255.0
        );
        Ok(())
    })
}

#[test]
fn bad_gltf_files_are_typed_errors() -> anyhow::Result<()> {
    let dir = raykit_tests::temp_dir("gltf_bad")?;
    let load = |broken| {
        GltfScene::load(&gltf_fixture::write(&dir.0.join(format!("{broken:?}")), broken)?)
            .map_err(anyhow::Error::from)
            .map(|_| ())
    };
    let err = |broken| -> anyhow::Result<GltfError> {
        let path = gltf_fixture::write(&dir.0.join(format!("{broken:?}")), broken)?;
        match GltfScene::load(&path) {
            Ok(_) => anyhow::bail!("{broken:?}: loaded"),
            Err(e) => Ok(e),
        }
    };
    load(Broken::Nothing)?;
    match err(Broken::MissingBuffer)? {
        e @ GltfError::MissingBuffer { buffer: 0, .. } => {
            anyhow::ensure!(e.to_string().contains("scene.bin") && e.to_string().contains("beside the .gltf"), "{e}")
        }
        e => anyhow::bail!("missing buffer: {e}"),
    }
    match err(Broken::Lines)? {
        e @ GltfError::NotTriangles { mesh: 0, primitive: 0, .. } => {
            anyhow::ensure!(e.to_string().contains("Lines") && e.to_string().contains("triangulate"), "{e}")
        }
        e => anyhow::bail!("lines: {e}"),
    }
    match err(Broken::IndexOutOfRange)? {
        e @ GltfError::IndexOutOfRange { mesh: 1, primitive: 1, index: 9, at: 5, vertices: 4 } => {
            anyhow::ensure!(e.to_string().contains("re-export"), "{e}")
        }
        e => anyhow::bail!("index out of range: {e}"),
    }
    Ok(())
}

#[test]
fn the_path_tracer_conserves_energy_in_a_white_furnace() -> anyhow::Result<()> {
    use gltf_pathtracer::PathTracer;
    use raykit_scene::EnvironmentMap;
    let dir = raykit_tests::temp_dir("gltf_furnace")?;
    let scene = GltfScene::load(&gltf_fixture::write(&dir.0, Broken::Nothing)?)?;
    with_each_backend("the_path_tracer_conserves_energy_in_a_white_furnace", |ctx, backend| {
        // A uniform white environment and surfaces that emit nothing and reflect at
        // most what they receive: no pixel can be brighter than 1 on average.
        let env = EnvironmentMap::new(16, 8, vec![Vec3::ONE; 16 * 8])?;
        let gpu = GpuScene::new(ctx, &scene)?;
        let (size, spp) = (32u32, 32u32);
        let mut tracer = PathTracer::new(ctx, &gpu, &env, &camera(), size, size)?;
        for _ in 0..spp / 8 {
            tracer.launch(8)?;
        }
        let (radiance, rays) = tracer.image()?;
        anyhow::ensure!(radiance.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "NaN or negative radiance");
        let lum: Vec<f64> = radiance.iter().map(|c| ((c.x + c.y + c.z) / 3.0) as f64).collect();
        let n = lum.len() as f64;
        let mean = lum.iter().sum::<f64>() / n;
        // The spread of pixel means holds the scene's variation as well as the noise:
        // a conservative standard error of the image mean.
        let se = (lum.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / (n - 1.0) / n).sqrt();
        anyhow::ensure!(mean <= 1.0 + 5.0 * se, "image mean {mean} ± {se} is over the environment's 1");
        anyhow::ensure!(mean > 0.3, "image mean {mean}: the surfaces reflect too little");
        anyhow::ensure!(rays >= (size * size * spp) as u64, "{rays} rays");
        eprintln!("[{backend:?}] white furnace: image mean {mean:.4} ± {se:.4}, {rays} rays");

        // Looking away from the scene, every path misses at once and sees the environment.
        let away = Camera { eye: Vec3::new(0.0, 0.0, 5.0), look_at: Vec3::new(0.0, 0.0, 10.0), ..camera() };
        let mut tracer = PathTracer::new(ctx, &gpu, &env, &away, 8, 8)?;
        tracer.launch(4)?;
        let (radiance, _) = tracer.image()?;
        anyhow::ensure!(radiance.iter().all(|c| (*c - Vec3::ONE).abs().max_element() < 1e-6), "{}", radiance[0]);
        Ok(())
    })
}

#[test]
fn both_material_modes_shade_as_the_shared_material_code() -> anyhow::Result<()> {
    use gltf_pathtracer::device::materials::color_of;
    use gltf_pathtracer::{MaterialMode, MaterialRenderer};
    let dir = raykit_tests::temp_dir("gltf_materials")?;
    let scene = GltfScene::load(&gltf_fixture::write(&dir.0, Broken::Nothing)?)?;
    with_each_backend("both_material_modes_shade_as_the_shared_material_code", |ctx, backend| {
        let gpu = GpuScene::new(ctx, &scene)?;
        let mut images = Vec::new();
        for mode in [MaterialMode::Callables, MaterialMode::Inlined] {
            let renderer = MaterialRenderer::new(ctx, &gpu, mode)?;
            let (out, colors) = renderer.render(ctx, &gpu, &camera(), SIZE, SIZE)?;
            let mut slots = std::collections::BTreeSet::new();
            for (o, c) in out.iter().zip(&colors) {
                anyhow::ensure!(o.x >= 0.0, "{mode:?}: a pixel missed the backdrop");
                let slot = o.x as u32;
                slots.insert(slot);
                let want = color_of(slot, Vec2::new(o.y, o.z));
                anyhow::ensure!(
                    (c.truncate() - want).abs().max_element() < 1e-4,
                    "{mode:?}: material {slot} at uv ({}, {}): {} vs the host's {want}",
                    o.y,
                    o.z,
                    c.truncate()
                );
            }
            anyhow::ensure!(slots.len() == 3, "{mode:?}: materials seen {slots:?}");
            eprintln!("[{backend:?}] {mode:?}: pipeline linked in {:?}", renderer.link_time);
            images.push(colors);
        }
        // A grid of 12 quads with 12 glTF materials uses all eight procedural ones.
        let grid = GltfScene::load(&gltf_pathtracer::demo_scene::write_grid(&dir.0.join("grid"), 12)?)?;
        anyhow::ensure!(grid.instances.len() == 12 && grid.materials.len() == 13);
        let grid_gpu = GpuScene::new(ctx, &grid)?;
        let renderer = MaterialRenderer::new(ctx, &grid_gpu, MaterialMode::Callables)?;
        let front = Camera { eye: Vec3::new(0.0, 0.0, 3.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 60.0 };
        let (out, _) = renderer.render(ctx, &grid_gpu, &front, 32, 32)?;
        let seen: std::collections::BTreeSet<u32> = out.iter().filter(|o| o.x >= 0.0).map(|o| o.x as u32).collect();
        anyhow::ensure!(seen.len() == 8, "grid materials seen {seen:?}");
        let worst = images[0].iter().zip(&images[1]).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0, f32::max);
        anyhow::ensure!(worst < 1e-5, "the two modes differ by {worst}");
        Ok(())
    })
}

#[test]
fn the_path_tracer_writes_denoiser_guides_in_the_same_launch_and_denoising_with_them_converges() -> anyhow::Result<()> {
    use gltf_pathtracer::PathTracer;
    use raykit_denoise::{DenoiseDevice, Denoiser, Input};
    let dir = raykit_tests::temp_dir("gltf_guides")?;
    // Four quads with base colours (i/4, 1 − i/4, 0.5) filling [-1, 1]² at z = 0, normals +z.
    let scene = GltfScene::load(&gltf_pathtracer::demo_scene::write_grid(&dir.0, 4)?)?;
    let denoiser = Denoiser::new(DenoiseDevice::Cpu)?;
    with_each_backend("the_path_tracer_writes_denoiser_guides_in_the_same_launch", |ctx, backend| {
        let env = gltf_pathtracer::default_sky(64, 32)?;
        let gpu = GpuScene::new(ctx, &scene)?;
        let size = 48u32;
        // The grid fills the middle of the picture; the sky is around it.
        let cam = Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 40.0 };
        let render = |guides: bool, spp: u32| -> anyhow::Result<PathTracer> {
            let mut tracer = PathTracer::new(ctx, &gpu, &env, &cam, size, size)?;
            if guides {
                tracer.enable_guides(ctx)?;
            }
            for _ in 0..spp / 4 {
                tracer.launch(4)?;
            }
            Ok(tracer)
        };
        let guided = render(true, 8)?;
        let (noisy, _) = guided.image()?;
        let (plain, _) = render(false, 8)?.image()?;
        anyhow::ensure!(noisy == plain, "writing the guides changed the picture");
        let guides = guided.guides()?.ok_or(anyhow::anyhow!("no guides"))?;

        // Pixels whose whole footprint sees one quad: its colour and +z exactly;
        // pixels that see only sky: zero.
        let pixel_world = |x: f32, y: f32| -> Option<Vec3> {
            let (u, v, w) = cam.uvw(1.0);
            let d = 2.0 * Vec2::new(x, y) / size as f32 - 1.0;
            let dir = (d.x * u - d.y * v + w).normalize();
            (dir.z < 0.0).then(|| cam.eye + dir * (-cam.eye.z / dir.z))
        };
        let quad_of = |p: Vec3| -> Option<usize> {
            (p.x.abs() < 1.0 && p.y.abs() < 1.0).then(|| usize::from(p.x > 0.0) + 2 * usize::from(p.y < 0.0))
        };
        let (mut on_quads, mut on_sky) = (0, 0);
        for y in 0..size {
            for x in 0..size {
                let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .map(|(dx, dy)| pixel_world(x as f32 + dx, y as f32 + dy).and_then(quad_of));
                let i = (y * size + x) as usize;
                let (albedo, normal) = (guides.albedo[i], guides.normal[i]);
                if let Some(quad) = corners[0].filter(|q| corners.iter().all(|c| *c == Some(*q))) {
                    let c = quad as f32 / 4.0;
                    let want = Vec3::new(c, 1.0 - c, 0.5);
                    anyhow::ensure!(
                        (albedo - want).abs().max_element() < 1e-5,
                        "pixel ({x}, {y}): albedo {albedo}, quad {quad}'s {want}"
                    );
                    anyhow::ensure!((normal - Vec3::Z).abs().max_element() < 1e-5, "pixel ({x}, {y}): normal {normal}");
                    on_quads += 1;
                } else if corners.iter().all(Option::is_none) {
                    anyhow::ensure!(
                        albedo == Vec3::ZERO && normal == Vec3::ZERO,
                        "pixel ({x}, {y}) sees sky: {albedo} {normal}"
                    );
                    on_sky += 1;
                }
            }
        }
        anyhow::ensure!(on_quads > 600 && on_sky > 300, "{on_quads} quad pixels, {on_sky} sky pixels");

        // Denoised with the guides, 8 spp comes closer to 512 spp than the noisy input.
        let (reference, _) = render(false, 512)?.image()?;
        let rgb = |v: &[Vec3]| v.iter().map(|c| c.to_array()).collect::<Vec<_>>();
        let (color, albedo, normal) = (rgb(&noisy), rgb(&guides.albedo), rgb(&guides.normal));
        let denoised = denoiser.denoise(&Input::new(size, size, &color).with_guides(&albedo, &normal))?;
        let denoised: Vec<Vec3> = denoised.into_iter().map(Vec3::from_array).collect();
        anyhow::ensure!(denoised.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "NaN or negative pixels");
        // On the displayed scale (Reinhard), as the path tracer's own test measures.
        let mse = |a: &[Vec3], b: &[Vec3]| -> f64 {
            let tone = |c: Vec3| c / (Vec3::ONE + c);
            a.iter().zip(b).map(|(p, q)| (tone(*p) - tone(*q)).length_squared() as f64).sum::<f64>() / a.len() as f64
        };
        let (before, after) = (mse(&noisy, &reference), mse(&denoised, &reference));
        eprintln!("[{backend:?}] glTF guides: {on_quads} quad pixels, {on_sky} sky; MSE {before:.3e} noisy, {after:.3e} denoised ({:.1}x)", before / after);
        anyhow::ensure!(after * 3.0 < before, "denoised MSE {after:.3e} is not 3x below the noisy {before:.3e}");
        Ok(())
    })
}

/// Per pixel, the estimates of `batches` independent batches of `spp` paths each.
fn batch_images(tracer: &mut gltf_pathtracer::PathTracer, batches: usize, spp: u32) -> anyhow::Result<Vec<Vec<f64>>> {
    let mut previous: Option<Vec<f64>> = None;
    let mut out = Vec::new();
    for _ in 0..batches {
        tracer.launch(spp)?;
        let (radiance, _) = tracer.image()?;
        anyhow::ensure!(radiance.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "NaN or negative radiance");
        let n = tracer.samples_done() as f64;
        let sums: Vec<f64> = radiance.iter().map(|c| ((c.x + c.y + c.z) / 3.0) as f64 * n).collect();
        let batch = match &previous {
            Some(p) => sums.iter().zip(p).map(|(s, p)| (s - p) / spp as f64).collect(),
            None => sums.iter().map(|s| s / spp as f64).collect(),
        };
        out.push(batch);
        previous = Some(sums);
    }
    Ok(out)
}

#[test]
fn emissive_triangles_as_lights_match_bsdf_sampling_with_less_noise() -> anyhow::Result<()> {
    use gltf_pathtracer::PathTracer;
    use raykit_scene::EnvironmentMap;
    let dir = raykit_tests::temp_dir("gltf_emissive")?;
    let scene = GltfScene::load(&gltf_fixture::write_emissive_quad(&dir.0)?)?;
    anyhow::ensure!(scene.materials[1].emissive_strength == 20.0, "{:?}", scene.materials[1]);
    with_each_backend("emissive_triangles_as_lights_match_bsdf_sampling_with_less_noise", |ctx, backend| {
        let env = EnvironmentMap::new(16, 8, vec![Vec3::splat(0.1); 16 * 8])?;
        let gpu = GpuScene::new(ctx, &scene)?;
        anyhow::ensure!(gpu.light_table.len() == 2, "{} light triangles", gpu.light_table.len());
        let cam = Camera {
            eye: Vec3::new(0.0, 3.0, 1.5),
            look_at: Vec3::new(0.0, 0.0, 0.0),
            up: Vec3::Y,
            fov_y_degrees: 40.0,
        };
        let (size, batches, spp) = (32u32, 32usize, 16u32);
        let mut images = Vec::new();
        for light_sampling in [true, false] {
            let mut tracer = PathTracer::new(ctx, &gpu, &env, &cam, size, size)?;
            tracer.set_light_sampling(light_sampling);
            tracer.set_max_depth(8);
            images.push(batch_images(&mut tracer, batches, spp)?);
        }
        // Per pixel: the mean over batches and the sample variance of one batch.
        let k = batches as f64;
        let stats = |b: &Vec<Vec<f64>>, pixel: usize| {
            let mean = b.iter().map(|img| img[pixel]).sum::<f64>() / k;
            let var = b.iter().map(|img| (img[pixel] - mean).powi(2)).sum::<f64>() / (k - 1.0);
            (mean, var)
        };
        let pixels = (size * size) as usize;
        let (mut var_mis, mut var_bsdf) = (0.0, 0.0);
        for pixel in 0..pixels {
            var_mis += stats(&images[0], pixel).1 / pixels as f64;
            var_bsdf += stats(&images[1], pixel).1 / pixels as f64;
        }
        // 4 × 4 blocks: the block's mean per batch, compared between the estimators
        // by their standard errors (from the spread of the batches).
        let block = 4u32;
        let mut worst: f64 = 0.0;
        let mut lit_blocks = 0;
        for by in 0..size / block {
            for bx in 0..size / block {
                let per_batch = |b: &Vec<Vec<f64>>| -> Vec<f64> {
                    b.iter()
                        .map(|img| {
                            let mut s = 0.0;
                            for y in by * block..(by + 1) * block {
                                for x in bx * block..(bx + 1) * block {
                                    s += img[(y * size + x) as usize];
                                }
                            }
                            s / (block * block) as f64
                        })
                        .collect()
                };
                let mean_se = |v: Vec<f64>| {
                    let m = v.iter().sum::<f64>() / k;
                    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt())
                };
                let (a, sa) = mean_se(per_batch(&images[0]));
                let (b, sb) = mean_se(per_batch(&images[1]));
                if a > 0.2 {
                    lit_blocks += 1;
                }
                let z = (a - b).abs() / (sa * sa + sb * sb).sqrt().max(1e-9);
                worst = worst.max(z);
                anyhow::ensure!(
                    z < 4.5,
                    "block ({bx}, {by}): MIS {a:.4} ± {sa:.4}, BSDF only {b:.4} ± {sb:.4} (z = {z:.2})"
                );
            }
        }
        let mean = |b: &Vec<Vec<f64>>| b.iter().flatten().sum::<f64>() / (k * pixels as f64);
        eprintln!(
            "[{backend:?}] emissive quad: image mean MIS {:.4}, BSDF only {:.4}; worst block z {worst:.2}; mean per-pixel variance of a {spp}-path batch: MIS {var_mis:.5}, BSDF only {var_bsdf:.5} (ratio {:.1})",
            mean(&images[0]),
            mean(&images[1]),
            var_bsdf / var_mis
        );
        anyhow::ensure!(lit_blocks >= 8, "{lit_blocks} blocks lit: the light does not reach the floor");
        anyhow::ensure!(var_mis * 2.0 < var_bsdf, "MIS variance {var_mis} is not below half of BSDF-only {var_bsdf}");
        Ok(())
    })
}

#[test]
fn normal_maps_tilt_the_shading_normal_as_the_tangent_frame_says() -> anyhow::Result<()> {
    use gltf_fixture::Quad;
    use raykit::glam::Vec4;
    let dir = raykit_tests::temp_dir("gltf_normal_map")?;
    // A constant normal map: tangent-space (x, y, z) = texel × 2 − 1, x and y scaled by 0.5.
    let texel = [191u8, 160, 230];
    let map = image::RgbaImage::from_pixel(2, 2, image::Rgba([texel[0], texel[1], texel[2], 255]));
    let quad = |x0: f32, sign: f32, material: usize| Quad {
        corners: [
            Vec3::new(x0, -0.5, 0.0),
            Vec3::new(x0 + 1.0, -0.5, 0.0),
            Vec3::new(x0 + 1.0, 0.5, 0.0),
            Vec3::new(x0, 0.5, 0.0),
        ],
        normal: Vec3::Z,
        tangent: Some(Vec4::new(1.0, 0.0, 0.0, sign)),
        material,
    };
    let materials = r#"[{"name": "bumpy", "normalTexture": {"index": 0, "scale": 0.5}}, {"name": "flat"}]"#;
    let path = gltf_fixture::write_quads(
        &dir.0,
        &[quad(-1.6, 1.0, 0), quad(-0.5, -1.0, 0), quad(0.6, 1.0, 1)],
        materials,
        r#"[{"source": 0}]"#,
        r#"[{"uri": "normal.png"}]"#,
        &[("normal.png", map)],
    )?;
    let scene = GltfScene::load(&path)?;
    anyhow::ensure!(scene.materials[0].normal_scale == 0.5 && scene.materials[0].normal_texture == Some(0));
    with_each_backend("normal_maps_tilt_the_shading_normal_as_the_tangent_frame_says", |ctx, backend| {
        let gpu = GpuScene::new(ctx, &scene)?;
        let renderer = Renderer::new(ctx, &gpu)?;
        let (out, _, normals) = renderer.primary_hits_with_normals(ctx, &gpu, &camera(), SIZE, SIZE)?;
        // The CPU reference: T = +x, B = sign × (N × T) = sign × +y, N = +z.
        let m = Vec3::from_array(texel.map(|c| c as f32 / 255.0 * 2.0 - 1.0));
        let want = |sign: f32| Vec3::new(m.x * 0.5, sign * m.y * 0.5, m.z).normalize();
        let mut counts = [0usize; 3];
        let mut worst: f32 = 0.0;
        for y in 0..SIZE {
            for x in 0..SIZE {
                let (o, d) = ray(x as f32 + 0.5, y as f32 + 0.5);
                let p = o + d * (-o.z / d.z);
                let which = if p.y.abs() > 0.48 {
                    continue;
                } else if (-1.58..-0.62).contains(&p.x) {
                    0
                } else if (-0.48..0.48).contains(&p.x) {
                    1
                } else if (0.62..1.58).contains(&p.x) {
                    2
                } else {
                    continue;
                };
                let expected = [want(1.0), want(-1.0), Vec3::Z][which];
                let i = (y * SIZE + x) as usize;
                anyhow::ensure!(out[i].x >= 0.0, "pixel ({x}, {y}) missed quad {which}");
                let got = normals[i].truncate();
                let err = (got - expected).length();
                worst = worst.max(err);
                anyhow::ensure!(err < 1e-3, "pixel ({x}, {y}) on quad {which}: normal {got}, reference {expected}");
                counts[which] += 1;
            }
        }
        anyhow::ensure!(counts.iter().all(|&n| n >= 50), "pixels per quad {counts:?}");
        let tilt = want(1.0).dot(Vec3::Z).acos().to_degrees();
        eprintln!("[{backend:?}] normal map: {counts:?} pixels per quad, tilt {tilt:.2}°, worst error {worst:.2e}");
        Ok(())
    })
}
