//! optixTriangle on raykit: the host half. [`render`] sets up optixTriangle's
//! scene (one triangle, camera at `(0, 0, 2)` looking at the origin, 45° vertical
//! field of view), launches, and returns RGBA8 pixels. The device half, and the
//! types both halves share, are in the `triangle-device` crate.

use raykit::glam::{UVec2, Vec3};
use raykit::{Context, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use triangle_device::{MissData, Params};

/// The triangle's vertices, as in optixTriangle.
pub const VERTICES: [Vec3; 3] = [Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.0, 0.5, 0.0)];

/// The miss program's background colour, as in optixTriangle.
pub const BG_COLOR: Vec3 = Vec3::new(0.3, 0.1, 0.2);

pub use raykit_scene::Camera;

/// optixTriangle's camera: at `(0, 0, 2)` looking at the origin, 45° vertical field of view.
pub const OPTIX_TRIANGLE_CAMERA: Camera =
    Camera { eye: Vec3::new(0.0, 0.0, 2.0), look_at: Vec3::ZERO, up: Vec3::new(0.0, 1.0, 0.0), fov_y_degrees: 45.0 };

/// The launch params for a `width × height` image written to `image`.
pub fn params(width: u32, height: u32, image: raykit::Buffer<u32>, scene: raykit::Traversable) -> Params {
    let (u, v, w) = OPTIX_TRIANGLE_CAMERA.uvw(width as f32 / height as f32);
    Params {
        image,
        size: UVec2::new(width, height),
        cam_eye: OPTIX_TRIANGLE_CAMERA.eye,
        cam_u: u,
        cam_v: v,
        cam_w: w,
        _pad: 0,
        handle: scene,
    }
}

/// The three program groups of optixTriangle.
pub struct Programs {
    /// `__raygen__rg`.
    pub raygen: ProgramGroup,
    /// `__miss__ms`.
    pub miss: ProgramGroup,
    /// A hit group with `__closesthit__ch`.
    pub hit: ProgramGroup,
}

impl Programs {
    /// The Rust programs of `triangle-device`.
    pub fn rust(ctx: &Context) -> raykit::Result<Programs> {
        let module = Module::from_device_crate(ctx, "triangle-device")?;
        Ok(Programs {
            raygen: ProgramGroup::raygen(&module, triangle_device::RG)?,
            miss: ProgramGroup::miss(&module, triangle_device::MS)?,
            hit: ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?,
        })
    }

    /// The GLSL twin (`glsl/`), three modules whose entry points are `main`.
    pub fn glsl(ctx: &Context) -> raykit::Result<Programs> {
        let raygen = Module::new(ctx, include_bytes!("../glsl/triangle.rgen.spv"))?;
        let miss = Module::new(ctx, include_bytes!("../glsl/triangle.rmiss.spv"))?;
        let hit = Module::new(ctx, include_bytes!("../glsl/triangle.rchit.spv"))?;
        Ok(Programs {
            raygen: ProgramGroup::raygen(&raygen, "main")?,
            miss: ProgramGroup::miss(&miss, "main")?,
            hit: ProgramGroup::hit_group(&hit).closest_hit("main").build()?,
        })
    }

    /// The WGSL twin (`wgsl/triangle.wgsl`), compiled by naga when called; its
    /// entry points are `rg`, `ms` and `ch`.
    pub fn wgsl(ctx: &Context) -> raykit::Result<Programs> {
        let module = Module::from_wgsl_named(ctx, WGSL, "examples/triangle/wgsl/triangle.wgsl")?;
        Ok(Programs {
            raygen: ProgramGroup::raygen(&module, "rg")?,
            miss: ProgramGroup::miss(&module, "ms")?,
            hit: ProgramGroup::hit_group(&module).closest_hit("ch").build()?,
        })
    }
}

/// The WGSL twin of the triangle programs.
pub const WGSL: &str = include_str!("../wgsl/triangle.wgsl");

/// Renders optixTriangle at `width × height` with the Rust programs; returns
/// RGBA8 pixels, row 0 at the top.
pub fn render(ctx: &Context, width: u32, height: u32) -> raykit::Result<Vec<u32>> {
    render_with(ctx, &Programs::rust(ctx)?, width, height)
}

/// Renders optixTriangle at `width × height` with `programs`.
pub fn render_with(ctx: &Context, programs: &Programs, width: u32, height: u32) -> raykit::Result<Vec<u32>> {
    let Programs { raygen, miss, hit } = programs;
    let pipeline = Pipeline::<Params>::new(ctx, &[raygen, miss, hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt =
        Sbt::builder(&pipeline).raygen(raygen, ()).miss(miss, MissData { bg_color: BG_COLOR }).hit(hit, ()).build()?;

    let gas = Gas::triangles(ctx, &VERTICES, None)?;
    let scene = Ias::single(ctx, &gas)?;
    let pixel_count = width as usize * height as usize;
    let image = ctx.buffer::<u32>(pixel_count)?;
    pipeline.launch(&sbt, &params(width, height, image.handle(), scene.handle()), [width, height, 1])?;
    image.read()
}

/// Writes RGBA8 pixels to a PNG file.
pub fn write_png(path: &std::path::Path, width: u32, height: u32, pixels: &[u32]) -> anyhow::Result<()> {
    Ok(raykit_scene::write_png_rgba8(path, width, height, pixels)?)
}

/// The README's examples, compiled as this crate's doctests (they use both
/// halves of the triangle).
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
mod readme {}
