//! The host half of the README's first renderer: the scene (built-in spheres
//! of three materials, one GAS and one hit record per material), the camera,
//! progressive launches and the picture.

use first_renderer_device::{Material, Params, DIFFUSE, GLASS, METAL};
use raykit::device::camera::ThinLensCamera;
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{Context, Gas, Ias, Instance, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};

/// One material and its spheres `(centre, radius)`.
pub struct Group {
    /// `kind`, `param` and `albedo` of the hit record (its sphere buffer is set by [`render`]).
    pub material: Material,
    /// The spheres.
    pub spheres: Vec<(Vec3, f32)>,
}

/// A material without its spheres yet.
fn material(kind: u32, param: f32, albedo: Vec3) -> Material {
    Material { spheres: raykit::Buffer::from_table_index(0), kind, param, albedo }
}

/// The scene: a ground of radius 1000 and the book's three large spheres, with small ones around.
pub fn scene() -> Vec<Group> {
    let small = |x: f32, z: f32| (Vec3::new(x, 0.2, z), 0.2);
    vec![
        Group {
            material: material(DIFFUSE, 0.0, Vec3::new(0.5, 0.5, 0.5)),
            spheres: vec![(Vec3::new(0.0, -1000.0, 0.0), 1000.0)],
        },
        Group {
            material: material(DIFFUSE, 0.0, Vec3::new(0.4, 0.2, 0.1)),
            spheres: vec![(Vec3::new(-4.0, 1.0, 0.0), 1.0), small(-2.5, 1.8), small(1.5, 2.2)],
        },
        Group {
            material: material(METAL, 0.05, Vec3::new(0.7, 0.6, 0.5)),
            spheres: vec![(Vec3::new(4.0, 1.0, 0.0), 1.0), small(2.8, -1.6)],
        },
        Group {
            material: material(GLASS, 1.5, Vec3::ONE),
            spheres: vec![(Vec3::new(0.0, 1.0, 0.0), 1.0), small(-1.0, 2.4)],
        },
    ]
}

/// The book's camera: from (13, 2, 3) at the origin, 20° vertically, focused at 10 with aperture 0.1.
pub fn camera(width: u32, height: u32) -> ThinLensCamera {
    let aspect = width as f32 / height as f32;
    ThinLensCamera::look_at(Vec3::new(13.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y, 20.0, aspect, 0.1, 10.0)
}

/// Renders `launches` launches of `samples` samples per pixel; returns, after
/// each launch, every pixel's summed radiance and sample count (`w`).
pub fn render(ctx: &Context, size: UVec2, samples: u32, launches: u32) -> raykit::Result<Vec<Vec<Vec4>>> {
    let groups = scene();
    let mut gases = Vec::new();
    for group in &groups {
        let (centres, radii): (Vec<Vec3>, Vec<f32>) = group.spheres.iter().copied().unzip();
        gases.push(Gas::spheres(ctx, &centres, &radii)?);
    }
    let instances: Vec<Instance> =
        gases.iter().enumerate().map(|(i, gas)| Instance::new(gas).sbt_offset(i as u32)).collect();
    let scene = Ias::new(ctx, &instances)?;

    let module = Module::from_device_crate(ctx, "first-renderer-device")?;
    let raygen = ProgramGroup::raygen(&module, first_renderer_device::RG)?;
    let miss = ProgramGroup::miss(&module, first_renderer_device::MS)?;
    let hit = ProgramGroup::hit_group(&module)
        .intersection(first_renderer_device::IS_SPHERE)
        .closest_hit(first_renderer_device::CH)
        .build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ());
    for (group, gas) in groups.iter().zip(&gases) {
        let spheres = gas.sphere_buffer().expect("a GAS made by Gas::spheres has its sphere buffer");
        sbt = sbt.hit(&hit, Material { spheres, ..group.material });
    }
    let sbt = sbt.build()?;

    let image = ctx.buffer::<Vec4>((size.x * size.y) as usize)?;
    let mut params = Params {
        image: image.handle(),
        size,
        samples,
        launch: 0,
        camera: camera(size.x, size.y),
        scene: scene.handle(),
    };
    let mut steps = Vec::new();
    for launch in 0..launches {
        params.launch = launch;
        pipeline.launch(&sbt, &params, [size.x, size.y, 1])?;
        steps.push(image.read()?);
    }
    Ok(steps)
}

/// Sums to RGBA8 sRGB pixels.
pub fn to_rgba8(sums: &[Vec4]) -> Vec<u32> {
    sums.iter().map(|s| raykit::device::color::pack_srgb8(s.truncate() / s.w.max(1.0))).collect()
}
