//! `next_week [OUTPUT.png] [WIDTH HEIGHT SPP]`: path-traces the final scene of
//! *Ray Tracing: The Next Week* with raykit to a PNG, and the linear radiance
//! beside it as a PFM. `RAYKIT_BACKEND=cpu` runs the device programs on the CPU.

use next_week_device::{Material, Params, CHECKER, CH_MESH, CH_SPHERE, DIELECTRIC, IS_MOVING, IS_SPHERE, LAMBERTIAN};
use next_week_device::{LIGHT, METAL, MS, RG};
use raykit::device::camera::ThinLensCamera;
use raykit::glam::{Affine3A, Quat, UVec2, Vec3, Vec4};
use raykit::{Buffer, Context, ContextOptions, Gas, Ias, Instance, LinkOptions, Mesh, Module, Pipeline, ProgramGroup};
use std::path::Path;

/// The device crate's SPIR-V, built by build.rs.
static SPIRV: raykit::EmbeddedSpirv = raykit::include_spirv!("next_week-device");

/// Traces a path takes at most.
pub const BOUNCES: u32 = 16;

/// A GAS's primitives.
pub enum Shape {
    /// Triangles (boxes and quads).
    Mesh(Mesh),
    /// Spheres: centres and one radius.
    Spheres(Vec<Vec3>, f32),
    /// One sphere moving from the first centre (time 0) to the second (time 1).
    Moving(Vec3, Vec3, f32),
}

/// The ground: 20 × 20 boxes 100 wide, 1 to 96 high.
pub fn ground() -> Mesh {
    let mut mesh = Mesh::default();
    for (i, j) in (0..20).flat_map(|i| (0..20).map(move |j| (i, j))) {
        let (x, z) = (-1000.0 + 100.0 * i as f32, -1000.0 + 100.0 * j as f32);
        let height = 1.0 + 5.0 * ((7 * i + 13 * j) % 20) as f32;
        mesh.append(&Mesh::cuboid(Vec3::new(x, 0.0, z), Vec3::new(x + 100.0, height, z + 100.0)));
    }
    mesh
}

/// 1000 centres in the cube from 0 to 165, from a linear congruential generator.
pub fn cluster() -> Vec<Vec3> {
    let mut state = 1u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / 16_777_216.0 * 165.0
    };
    (0..1000).map(|_| Vec3::new(next(), next(), next())).collect()
}

/// Per GAS: its material (kind, parameter, colour), its shape and its instance's transform.
pub fn scene() -> Vec<(u32, f32, Vec3, Shape, Affine3A)> {
    let v = Vec3::new;
    let still = Affine3A::IDENTITY;
    let turned =
        Affine3A::from_rotation_translation(Quat::from_rotation_y(15f32.to_radians()), v(-100.0, 270.0, 395.0));
    let light = Mesh::quad(v(123.0, 554.0, 147.0), v(300.0, 0.0, 0.0), v(0.0, 0.0, 265.0));
    vec![
        (LAMBERTIAN, 0.0, v(0.48, 0.83, 0.53), Shape::Mesh(ground()), still),
        (LIGHT, 0.0, Vec3::splat(7.0), Shape::Mesh(light), still),
        (LAMBERTIAN, 0.0, v(0.7, 0.3, 0.1), Shape::Moving(v(400.0, 400.0, 200.0), v(430.0, 400.0, 200.0), 50.0), still),
        (DIELECTRIC, 1.5, Vec3::ONE, Shape::Spheres(vec![v(260.0, 150.0, 45.0)], 50.0), still),
        (DIELECTRIC, 1.5, Vec3::ONE, Shape::Spheres(vec![v(360.0, 150.0, 145.0)], 70.0), still),
        (METAL, 1.0, v(0.8, 0.8, 0.9), Shape::Spheres(vec![v(0.0, 150.0, 145.0)], 50.0), still),
        (CHECKER, 20.0, v(0.2, 0.3, 0.1), Shape::Spheres(vec![v(400.0, 200.0, 400.0)], 100.0), still),
        (CHECKER, 10.0, v(0.6, 0.2, 0.2), Shape::Spheres(vec![v(220.0, 280.0, 300.0)], 80.0), still),
        (LAMBERTIAN, 0.0, Vec3::splat(0.73), Shape::Spheres(cluster(), 10.0), turned),
    ]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let output = args.first().map_or("next_week.png", |s| s.as_str());
    let number = |i: usize, default: u32| args.get(i).map_or(Ok(default), |s| s.parse::<u32>());
    let (width, height, spp) = (number(1, 400)?, number(2, 400)?, number(3, 64)?);

    let ctx = Context::new(ContextOptions::default())?;
    let module = Module::from_embedded(&ctx, &SPIRV)?;
    let (raygen, miss) = (ProgramGroup::raygen(&module, RG)?, ProgramGroup::miss(&module, MS)?);
    let spheres = ProgramGroup::hit_group(&module).intersection(IS_SPHERE).closest_hit(CH_SPHERE).build()?;
    let moving = ProgramGroup::hit_group(&module).intersection(IS_MOVING).closest_hit(CH_SPHERE).build()?;
    let meshes = ProgramGroup::hit_group(&module).closest_hit(CH_MESH).build()?;
    let groups = [&raygen, &miss, &spheres, &moving, &meshes];
    let pipeline = Pipeline::<Params>::new(&ctx, &groups, LinkOptions { max_trace_depth: 1 })?;

    // Per GAS a hit record and an instance using it; the shutter times are per pixel.
    let pixels = (width * height) as usize;
    let (image, times) = (ctx.buffer::<Vec4>(pixels)?, ctx.buffer::<f32>(pixels)?);
    let mut sbt = raykit::Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ());
    let mut instances = Vec::new();
    for (i, (kind, param, albedo, shape, transform)) in scene().into_iter().enumerate() {
        let (gas, group) = match shape {
            Shape::Mesh(mesh) => (Gas::mesh(&ctx, &mesh)?, &meshes),
            Shape::Spheres(centres, r) => (Gas::spheres(&ctx, &centres, &vec![r; centres.len()])?, &spheres),
            Shape::Moving(from, to, r) => (Gas::moving_spheres(&ctx, &[from], &[to], &[r])?, &moving),
        };
        let balls = gas.sphere_buffer().or(gas.moving_sphere_buffer()).unwrap_or(Buffer::from_table_index(0));
        let mesh = gas.mesh_data().unwrap_or_else(raykit::bytemuck::Zeroable::zeroed);
        sbt = sbt.hit(group, Material { spheres: balls, times: times.handle(), mesh, kind, param, albedo });
        instances.push(Instance::new(&gas).transform(transform).sbt_offset(i as u32));
    }
    let (sbt, scene) = (sbt.build()?, Ias::new(&ctx, &instances)?);

    // Launches of 16 samples per pixel, adding to the image.
    let (eye, target) = (Vec3::new(478.0, 278.0, -600.0), Vec3::new(278.0, 278.0, 0.0));
    let camera = ThinLensCamera::look_at(eye, target, Vec3::Y, 40.0, width as f32 / height as f32, 0.0, 10.0);
    let mut params = Params {
        scene: scene.handle(),
        image: image.handle(),
        times: times.handle(),
        size: UVec2::new(width, height),
        samples: 16,
        launch: 0,
        bounces: BOUNCES,
        camera,
    };
    for launch in 0..spp.div_ceil(16) {
        params.launch = launch;
        pipeline.launch(&sbt, &params, [width, height, 1])?;
    }
    let radiance: Vec<Vec3> = image.read()?.iter().map(|sum| sum.truncate() / sum.w).collect();
    raykit::write_png_srgb(Path::new(output), width, height, &radiance)?;
    raykit::scene::write_pfm(&Path::new(output).with_extension("pfm"), width, height, &radiance)?;
    println!("rendered {width}x{height}, {} spp on {} to {output}", spp.div_ceil(16) * 16, ctx.device_name());

    // With `RAYKIT_VALIDATION=1` the Khronos validation layer checks every call: any message is a bug.
    let messages = ctx.messages().snapshot();
    for message in &messages {
        eprintln!("validation: {message}");
    }
    if !messages.is_empty() {
        return Err(format!("{} validation messages", messages.len()).into());
    }
    Ok(())
}
