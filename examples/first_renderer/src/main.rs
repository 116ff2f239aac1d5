//! `first_renderer [OUTPUT.png] [WIDTH HEIGHT SPP]`: path-traces spheres of three
//! materials with raykit to a PNG, and the linear radiance beside it as a PFM.
//! `RAYKIT_BACKEND=cpu` runs the device programs on the CPU instead of Vulkan.

use first_renderer_device::{Material, Paint, Params, CH, DIELECTRIC, IS_SPHERE, LAMBERTIAN, METAL, MS, RG};
use raykit::device::camera::ThinLensCamera;
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{Context, ContextOptions, Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use std::path::Path;

/// The device crate's SPIR-V, built by build.rs.
static SPIRV: raykit::EmbeddedSpirv = raykit::include_spirv!("first_renderer-device");

/// Per material (kind, parameter): its spheres (centre, radius, colour).
pub fn scene() -> Vec<(u32, f32, Vec<(Vec3, f32, Vec3)>)> {
    let small = |x: f32, z: f32, colour: Vec3| (Vec3::new(x, 0.2, z), 0.2, colour);
    let ground = (Vec3::new(0.0, -1000.0, 0.0), 1000.0, Vec3::splat(0.5));
    let diffuse = (Vec3::new(-4.0, 1.0, 0.0), 1.0, Vec3::new(0.4, 0.2, 0.1));
    let (green, red) = (small(-2.5, 1.8, Vec3::new(0.1, 0.6, 0.2)), small(1.5, 2.2, Vec3::new(0.8, 0.2, 0.3)));
    let metal = [(Vec3::new(4.0, 1.0, 0.0), 1.0, Vec3::new(0.7, 0.6, 0.5)), small(2.8, -1.6, Vec3::splat(0.9))];
    let glass = [(Vec3::new(0.0, 1.0, 0.0), 1.0, Vec3::ONE), small(-1.0, 2.4, Vec3::ONE)];
    vec![
        (LAMBERTIAN, 0.0, vec![ground, diffuse, green, red]),
        (METAL, 0.05, metal.into()),
        (DIELECTRIC, 1.5, glass.into()),
    ]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let output = args.first().map_or("first_renderer.png", |s| s.as_str());
    let number = |i: usize, default: u32| args.get(i).map_or(Ok(default), |s| s.parse::<u32>());
    let (width, height, spp) = (number(1, 320)?, number(2, 240)?, number(3, 64)?);

    let ctx = Context::new(ContextOptions::default())?;
    let module = Module::from_embedded(&ctx, &SPIRV)?;
    let raygen = ProgramGroup::raygen(&module, RG)?;
    let miss = ProgramGroup::miss(&module, MS)?;
    let hit = ProgramGroup::hit_group(&module).intersection(IS_SPHERE).closest_hit(CH).build()?;
    let pipeline = Pipeline::<Params>::new(&ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;

    // Per material: a GAS of its spheres, a buffer of their paints and a hit record; instance i uses record i.
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ());
    let (mut instances, mut paints) = (Vec::new(), Vec::new());
    for (i, (kind, param, spheres)) in scene().into_iter().enumerate() {
        let (centres, radii): (Vec<Vec3>, Vec<f32>) = spheres.iter().map(|s| (s.0, s.1)).unzip();
        let gas = Gas::spheres(&ctx, &centres, &radii)?;
        paints.push(ctx.buffer_from(&spheres.iter().map(|s| Paint { albedo: s.2 }).collect::<Vec<_>>())?);
        let spheres = gas.sphere_buffer().ok_or("a GAS of spheres has a sphere buffer")?;
        sbt = sbt.hit(&hit, Material { spheres, paints: paints[i].handle(), kind, param });
        instances.push(Instance::new(&gas).sbt_offset(i as u32));
    }
    let (sbt, scene) = (sbt.build()?, Ias::new(&ctx, &instances)?);

    // Launches of 16 samples per pixel, adding to the image.
    let image = ctx.buffer::<Vec4>((width * height) as usize)?;
    let aspect = width as f32 / height as f32;
    let camera = ThinLensCamera::look_at(Vec3::new(13.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y, 20.0, aspect, 0.1, 10.0);
    let size = UVec2::new(width, height);
    let mut params = Params { image: image.handle(), size, samples: 16, launch: 0, camera, scene: scene.handle() };
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
