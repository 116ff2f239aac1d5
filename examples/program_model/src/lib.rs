//! OptiX's program model on raykit, one scene per program kind. Each scene's
//! host half is here; the device programs and the constants both halves share
//! are in `program-model-device`. Every scene renders RGBA8 pixels through an
//! orthographic camera looking down −z at `[-1, 1]²`.
//!
//! * [`spheres`]: AABB primitives and an intersection program reporting typed
//!   attributes (the normal), shaded by closest-hit;
//! * [`cutout`]: an any-hit program that ignores hits where a checkerboard is clear;
//! * [`shadows`]: two ray types, radiance and shadow, with a point light (also
//!   linked from pipeline libraries: [`shadows_linked_as`]);
//! * [`callables`]: a closest-hit that picks a material callable by the
//!   instance's custom index;
//! * [`sbt_data`]: instances sharing one hit program, each reading its own SBT record.

use program_model_device::{ColorRecord, Params, Radiance, Shadow, ShadowedRadiance};
use raykit::glam::{Affine3A, Quat, UVec2, Vec3, Vec4};
use raykit::{
    Aabb, Aabbs, Context, Gas, GeometryFlags, Ias, Instance, LibraryOptions, LinkOptions, Module, Pipeline,
    PipelineLibrary, ProgramGroup, Sbt, Triangles,
};

/// The scenes, by name.
pub const SCENES: [&str; 5] = ["spheres", "cutout", "shadows", "callables", "sbt_data"];

/// The spheres of [`spheres`]: centre (xyz) and radius (w).
pub const SPHERES: [Vec4; 3] =
    [Vec4::new(-0.4, -0.3, 0.0, 0.35), Vec4::new(0.35, 0.25, -0.5, 0.5), Vec4::new(0.1, -0.5, 0.5, 0.2)];

/// [`cutout`]'s unit triangle is scaled by this and moved by [`CUTOUT_OFFSET`].
pub const CUTOUT_SCALE: f32 = 1.6;
/// See [`CUTOUT_SCALE`].
pub const CUTOUT_OFFSET: Vec3 = Vec3::new(-0.8, -0.8, 0.0);

/// The two ground triangles of [`shadows`] (z = 0, covering `[-1, 1]²`).
pub const GROUND: [[Vec3; 3]; 2] = [
    [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
    [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
];
/// The occluder of [`shadows`], at z = 1.
pub const OCCLUDER_TRIANGLE: [Vec3; 3] =
    [Vec3::new(-0.4, -0.35, 1.0), Vec3::new(0.25, -0.35, 1.0), Vec3::new(-0.1, 0.3, 1.0)];

/// The quad (0,0)–(0.5,0.5) that [`callables`] and [`sbt_data`] instance.
pub const QUAD: [Vec3; 6] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(0.5, 0.0, 0.0),
    Vec3::new(0.5, 0.5, 0.0),
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(0.5, 0.5, 0.0),
    Vec3::new(0.0, 0.5, 0.0),
];
/// Where [`callables`] places its instances (lower-left corners); instance i
/// uses material callable i.
pub const CALLABLE_PLACES: [Vec3; 3] =
    [Vec3::new(-0.9, -0.25, 0.0), Vec3::new(-0.25, -0.25, 0.0), Vec3::new(0.4, -0.25, 0.0)];
/// Where [`sbt_data`] places its instances, and the colour of each one's record.
pub const SBT_DATA_INSTANCES: [(Vec3, Vec3); 4] = [
    (Vec3::new(-0.9, -0.9, 0.0), Vec3::new(0.9, 0.1, 0.1)),
    (Vec3::new(0.3, -0.6, 0.0), Vec3::new(0.1, 0.8, 0.2)),
    (Vec3::new(-0.3, 0.35, 0.0), Vec3::new(0.2, 0.3, 0.9)),
    (Vec3::new(0.4, 0.4, 0.0), Vec3::new(0.7, 0.7, 0.1)),
];

fn module(ctx: &Context) -> raykit::Result<Module> {
    Module::from_device_crate(ctx, "program-model-device")
}

/// Launches `pipeline` over a `size²` image of `scene`; returns the pixels.
fn launch(
    ctx: &Context,
    pipeline: &Pipeline<Params>,
    sbt: &Sbt,
    scene: &Ias,
    size: u32,
    spheres: &[Vec4],
) -> raykit::Result<Vec<u32>> {
    let image = ctx.buffer::<u32>((size * size) as usize)?;
    let sphere_buffer = ctx.buffer_from::<Vec4>(if spheres.is_empty() { &[Vec4::ZERO] } else { spheres })?;
    let params = Params {
        image: image.handle(),
        spheres: sphere_buffer.handle(),
        size: UVec2::splat(size),
        scene: scene.handle(),
    };
    pipeline.launch(sbt, &params, [size, size, 1])?;
    image.read()
}

/// Renders with the radiance raygen and miss, `hit` as the only hit group, and
/// `callables` in the callable region.
fn render_one_hit_group(
    ctx: &Context,
    module: &Module,
    hit: &ProgramGroup,
    callables: &[&ProgramGroup],
    scene: &Ias,
    size: u32,
    spheres: &[Vec4],
) -> raykit::Result<Vec<u32>> {
    let raygen = ProgramGroup::raygen(module, program_model_device::RG)?;
    let miss = ProgramGroup::miss(module, program_model_device::MS)?;
    let mut groups = vec![&raygen, &miss, hit];
    groups.extend_from_slice(callables);
    let pipeline = Pipeline::<Params>::new(ctx, &groups, LinkOptions { max_trace_depth: 1 })?;
    let mut sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss_for::<Radiance, _>(&miss, ())
        .hit_for::<Radiance, _>(0, hit, ());
    for callable in callables {
        sbt = sbt.callable(callable, ());
    }
    launch(ctx, &pipeline, &sbt.build()?, scene, size, spheres)
}

/// Spheres: one GAS of AABBs, an intersection program computing ray–sphere
/// hits and reporting the normal as typed attributes.
pub fn spheres(ctx: &Context, size: u32) -> raykit::Result<Vec<u32>> {
    let boxes: Vec<Aabb> = SPHERES.iter().map(|s| Aabb::new(s.truncate() - s.w, s.truncate() + s.w)).collect();
    let gas = Gas::builder().aabbs(Aabbs::new(&boxes).flags(GeometryFlags::OPAQUE)).build(ctx)?;
    let scene = Ias::single(ctx, &gas)?;
    let module = module(ctx)?;
    let hit = ProgramGroup::hit_group(&module)
        .intersection(program_model_device::SPHERE)
        .closest_hit(program_model_device::SPHERE_SHADE)
        .build()?;
    render_one_hit_group(ctx, &module, &hit, &[], &scene, size, &SPHERES)
}

/// Cut-out: a non-opaque triangle whose any-hit program ignores hits in the
/// clear cells of a checkerboard.
pub fn cutout(ctx: &Context, size: u32) -> raykit::Result<Vec<u32>> {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let gas = Gas::builder().triangles(Triangles::new(&tri).flags(GeometryFlags::NONE)).build(ctx)?;
    let to_world = Affine3A::from_scale_rotation_translation(Vec3::splat(CUTOUT_SCALE), Quat::IDENTITY, CUTOUT_OFFSET);
    let scene = Ias::new(ctx, &[Instance::new(&gas).transform(to_world)])?;
    let module = module(ctx)?;
    let hit = ProgramGroup::hit_group(&module)
        .any_hit(program_model_device::CUTOUT)
        .closest_hit(program_model_device::CUTOUT_SHADE)
        .build()?;
    render_one_hit_group(ctx, &module, &hit, &[], &scene, size, &[])
}

/// Shadows: a ground and an occluder; the ground's closest-hit traces a shadow
/// ray of a second ray type towards a point light. The SBT is placed from the
/// two ray types' declarations.
pub fn shadows(ctx: &Context, size: u32) -> raykit::Result<Vec<u32>> {
    shadows_linked_as(ctx, size, Linking::Monolithic)
}

/// How [`shadows_linked_as`] makes its pipeline.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Linking {
    /// One `Pipeline::new` of all groups.
    Monolithic,
    /// Two pipeline libraries, the raygen and the rest (both misses and hit
    /// groups), joined by `Pipeline::link`.
    Libraries,
}

/// [`shadows`], its pipeline made as `linking` says.
pub fn shadows_linked_as(ctx: &Context, size: u32, linking: Linking) -> raykit::Result<Vec<u32>> {
    let vertices: Vec<Vec3> = GROUND.iter().flatten().copied().chain(OCCLUDER_TRIANGLE).collect();
    let gas = Gas::triangles(ctx, &vertices, None)?;
    let scene = Ias::single(ctx, &gas)?;
    let module = module(ctx)?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG_SHADOWS)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS_SHADOWS)?;
    let shadow_miss = ProgramGroup::miss(&module, program_model_device::MS_SHADOW)?;
    let shade = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SHADE_SHADOWED).build()?;
    let shadow_hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SHADOW_HIT).build()?;
    let link = LinkOptions { max_trace_depth: 2 };
    let pipeline = match linking {
        Linking::Monolithic => {
            Pipeline::<Params>::new(ctx, &[&raygen, &miss, &shadow_miss, &shade, &shadow_hit], link)?
        }
        Linking::Libraries => {
            let rest = [&miss, &shadow_miss, &shade, &shadow_hit];
            // One interface for both libraries: the largest payload of all groups.
            let all = [&raygen, &miss, &shadow_miss, &shade, &shadow_hit];
            let options =
                LibraryOptions { max_trace_depth: 2, interface: Some(PipelineLibrary::<Params>::interface_for(&all)) };
            let raygen_library = PipelineLibrary::<Params>::new(ctx, &[&raygen], options)?;
            let rest_library = PipelineLibrary::<Params>::new(ctx, &rest, options)?;
            Pipeline::link(ctx, &[&raygen_library, &rest_library], link)?
        }
    };
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss_for::<ShadowedRadiance, _>(&miss, ())
        .miss_for::<Shadow, _>(&shadow_miss, ())
        .hit_for::<ShadowedRadiance, _>(0, &shade, ())
        .hit_for::<Shadow, _>(0, &shadow_hit, ())
        .build()?;
    launch(ctx, &pipeline, &sbt, &scene, size, &[])
}

/// Callables: three instances of a quad; the closest-hit calls the material
/// callable whose index is the instance's custom index (two direct callables
/// and a continuation callable).
pub fn callables(ctx: &Context, size: u32) -> raykit::Result<Vec<u32>> {
    let gas = Gas::triangles(ctx, &QUAD, None)?;
    let instances: Vec<Instance> = CALLABLE_PLACES
        .iter()
        .enumerate()
        .map(|(i, p)| Instance::new(&gas).transform(Affine3A::from_translation(*p)).custom_index(i as u32))
        .collect();
    let scene = Ias::new(ctx, &instances)?;
    let module = module(ctx)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::MATERIAL_SHADE).build()?;
    let red = ProgramGroup::callable(&module, program_model_device::RED)?;
    let green = ProgramGroup::callable(&module, program_model_device::GREEN)?;
    let blue = ProgramGroup::callable(&module, program_model_device::BLUE)?;
    render_one_hit_group(ctx, &module, &hit, &[&red, &green, &blue], &scene, size, &[])
}

/// SBT data: four instances of a quad share one closest-hit program; each
/// instance's SBT offset selects its own record, whose data is its colour.
pub fn sbt_data(ctx: &Context, size: u32) -> raykit::Result<Vec<u32>> {
    let gas = Gas::triangles(ctx, &QUAD, None)?;
    let instances: Vec<Instance> = SBT_DATA_INSTANCES
        .iter()
        .enumerate()
        .map(|(i, (p, _))| Instance::new(&gas).transform(Affine3A::from_translation(*p)).sbt_offset(i as u32))
        .collect();
    let scene = Ias::new(ctx, &instances)?;
    let module = module(ctx)?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::RECORD_COLOR).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss_for::<Radiance, _>(&miss, ());
    for (i, (_, color)) in SBT_DATA_INSTANCES.iter().enumerate() {
        sbt = sbt.hit_for::<Radiance, _>(i, &hit, ColorRecord { color: *color });
    }
    launch(ctx, &pipeline, &sbt.build()?, &scene, size, &[])
}

/// Renders scene `name` (one of [`SCENES`]).
pub fn render(ctx: &Context, name: &str, size: u32) -> anyhow::Result<Vec<u32>> {
    Ok(match name {
        "spheres" => spheres(ctx, size)?,
        "cutout" => cutout(ctx, size)?,
        "shadows" => shadows(ctx, size)?,
        "callables" => callables(ctx, size)?,
        "sbt_data" => sbt_data(ctx, size)?,
        other => anyhow::bail!("unknown scene {other:?}; scenes: {}", SCENES.join(", ")),
    })
}

/// Writes RGBA8 pixels of a `size²` image to a PNG file.
pub fn write_png(path: &std::path::Path, size: u32, pixels: &[u32]) -> anyhow::Result<()> {
    Ok(raykit_scene::write_png_rgba8(path, size, size, pixels)?)
}
