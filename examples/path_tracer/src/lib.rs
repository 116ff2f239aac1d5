//! optixPathTracer on raykit: the host half.
//!
//! [`Renderer`] builds the Cornell box's acceleration structure (one GAS with a
//! geometry per material group, so each group gets its own hit records), links
//! the five programs (raygen, two miss programs, two hit groups: one ray type for
//! radiance, one for shadows), lays out the SBT from the ray types, and launches
//! progressively: each launch adds `samples` paths per pixel to an accumulation
//! buffer, seeded by the launch index, so a render is the same whatever the
//! launches are cut into. [`Image`] holds the result: linear radiance per pixel,
//! written as PFM, and tonemapped to PNG.
//!
//! [`GroupRenderer`] renders the same picture on several devices at once (a
//! `raykit::DeviceGroup`): one renderer per device, each launch split into bands
//! of rows by the devices' measured speeds, the bands gathered into one image.
//!
//! The device half, and the math and scene both halves share, are in the
//! `path-tracer-device` crate. [`Programs::glsl`] loads a GLSL twin of the same
//! programs (`glsl/`), and [`Programs::wgsl`] a WGSL twin (`wgsl/`, compiled by
//! naga at build time), used by the tests and the benchmarks.

use std::ops::Range;
use std::path::Path;

use path_tracer_device::math::{tonemap, CameraFrame};
use path_tracer_device::scene::{self, MATERIALS, VERTICES};
use path_tracer_device::{GuidesRaygenRecord, HitRecord, Params, Radiance, RaygenRecord, Shadow};
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{
    Band, BandRows, Context, DeviceBuffer, DeviceGroup, Gas, GeometryFlags, Ias, LinkOptions, Module, Pipeline,
    ProgramGroup, Sbt, Split, Triangles,
};
pub use raykit_scene::Camera;

pub use path_tracer_device as device;

#[cfg(feature = "viewer")]
pub mod view;

/// A `--exposure` that is not a finite number above zero (NaN, infinite,
/// zero or negative exposures would write a picture of nothing after the whole
/// render).
#[derive(Debug, Clone, PartialEq)]
pub struct ExposureError {
    /// The value given.
    pub value: String,
}

impl std::fmt::Display for ExposureError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "--exposure {:?}: give a finite number above 0 (1 leaves the radiance as it is)", self.value)
    }
}

impl std::error::Error for ExposureError {}

/// `--exposure`'s parser: a finite `f32` above 0, else [`ExposureError`].
pub fn parse_exposure(value: &str) -> Result<f32, ExposureError> {
    match value.trim().parse::<f32>() {
        Ok(exposure) if exposure.is_finite() && exposure > 0.0 => Ok(exposure),
        _ => Err(ExposureError { value: value.to_owned() }),
    }
}

/// optixPathTracer's camera.
pub const CAMERA: Camera = Camera {
    eye: scene::CAMERA_EYE,
    look_at: scene::CAMERA_LOOK_AT,
    up: scene::CAMERA_UP,
    fov_y_degrees: scene::CAMERA_FOV_Y,
};

/// The camera basis of optixPathTracer's camera for an image of `aspect` =
/// width / height (sutil's `Camera::UVWFrame`).
pub fn camera_frame(aspect: f32) -> CameraFrame {
    let (u, v, w) = CAMERA.uvw(aspect);
    CameraFrame { eye: CAMERA.eye, u, v, w }
}

/// The unit geometric normal of each triangle of [`VERTICES`].
pub fn triangle_normals() -> Vec<Vec3> {
    VERTICES.chunks_exact(3).map(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize()).collect()
}

/// The path tracer's program groups.
#[derive(Clone)]
pub struct Programs {
    /// `__raygen__rg`: the path loop.
    pub raygen: ProgramGroup,
    /// Miss program of radiance rays.
    pub miss: ProgramGroup,
    /// Miss program of shadow rays (the light is visible).
    pub shadow_miss: ProgramGroup,
    /// Hit group of radiance rays (reports the hit).
    pub hit: ProgramGroup,
    /// Hit group of shadow rays (its closest-hit never runs).
    pub shadow_hit: ProgramGroup,
    /// `__raygen__rg_guides`: the path loop that also writes the first-hit
    /// albedo and normals for a denoiser ([`Renderer::enable_guides`]); the
    /// Rust programs only (the GLSL and WGSL twins have none).
    pub raygen_guides: Option<ProgramGroup>,
}

impl Programs {
    /// The Rust programs of `path-tracer-device`.
    pub fn rust(ctx: &Context) -> raykit::Result<Programs> {
        Self::rust_from(&Module::from_device_crate(ctx, "path-tracer-device")?)
    }

    /// The Rust programs from an already loaded module.
    pub fn rust_from(module: &Module) -> raykit::Result<Programs> {
        use path_tracer_device::{CH, CH_SHADOW, MS, MS_SHADOW, RG, RG_GUIDES};
        Ok(Programs {
            raygen: ProgramGroup::raygen(module, RG)?,
            raygen_guides: Some(ProgramGroup::raygen(module, RG_GUIDES)?),
            miss: ProgramGroup::miss(module, MS)?,
            shadow_miss: ProgramGroup::miss(module, MS_SHADOW)?,
            hit: ProgramGroup::hit_group(module).closest_hit(CH).build()?,
            shadow_hit: ProgramGroup::hit_group(module).closest_hit(CH_SHADOW).build()?,
        })
    }

    /// The GLSL twin (`glsl/`, compiled with glslang and `spirv-opt -O`): one
    /// module per program, entry points `main`.
    pub fn glsl(ctx: &Context) -> raykit::Result<Programs> {
        let [rgen, rmiss, shadow_rmiss, rchit, shadow_rchit] = GLSL_SPIRV;
        let raygen = Module::new(ctx, rgen.1)?;
        let miss = Module::new(ctx, rmiss.1)?;
        let shadow_miss = Module::new(ctx, shadow_rmiss.1)?;
        let hit = Module::new(ctx, rchit.1)?;
        let shadow_hit = Module::new(ctx, shadow_rchit.1)?;
        Ok(Programs {
            raygen: ProgramGroup::raygen(&raygen, "main")?,
            miss: ProgramGroup::miss(&miss, "main")?,
            shadow_miss: ProgramGroup::miss(&shadow_miss, "main")?,
            hit: ProgramGroup::hit_group(&hit).closest_hit("main").build()?,
            shadow_hit: ProgramGroup::hit_group(&shadow_hit).closest_hit("main").build()?,
            raygen_guides: None,
        })
    }
}

impl Programs {
    /// The WGSL twin (`wgsl/path_tracer.wgsl`, compiled by naga at build time):
    /// one module, entry points `rg`, `ms`, `ms_shadow`, `ch`, `ch_shadow`.
    pub fn wgsl(ctx: &Context) -> raykit::Result<Programs> {
        let module = Module::new(ctx, WGSL_SPIRV)?;
        Ok(Programs {
            raygen: ProgramGroup::raygen(&module, "rg")?,
            miss: ProgramGroup::miss(&module, "ms")?,
            shadow_miss: ProgramGroup::miss(&module, "ms_shadow")?,
            hit: ProgramGroup::hit_group(&module).closest_hit("ch").build()?,
            shadow_hit: ProgramGroup::hit_group(&module).closest_hit("ch_shadow").build()?,
            raygen_guides: None,
        })
    }
}

/// The WGSL twin's SPIR-V, compiled from `wgsl/path_tracer.wgsl` by `build.rs`.
pub const WGSL_SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/path_tracer.wgsl.spv"));

/// The GLSL twin's SPIR-V files (name, bytes), as committed in `glsl/`.
pub const GLSL_SPIRV: [(&str, &[u8]); 5] = [
    ("path_tracer.rgen.spv", include_bytes!("../glsl/path_tracer.rgen.spv")),
    ("path_tracer.rmiss.spv", include_bytes!("../glsl/path_tracer.rmiss.spv")),
    ("shadow.rmiss.spv", include_bytes!("../glsl/shadow.rmiss.spv")),
    ("path_tracer.rchit.spv", include_bytes!("../glsl/path_tracer.rchit.spv")),
    ("shadow.rchit.spv", include_bytes!("../glsl/shadow.rchit.spv")),
];

/// The Cornell box's acceleration structures and triangle normals, shareable
/// between renderers (the benchmarks run the Rust and GLSL programs on one scene).
pub struct Scene {
    /// The TLAS over the one GAS.
    pub ias: Ias,
    /// Per-triangle normals read by the closest-hit program.
    pub normals: DeviceBuffer<Vec3>,
}

impl Scene {
    /// Builds the GAS (one geometry per material group) and its TLAS.
    pub fn new(ctx: &Context) -> raykit::Result<Scene> {
        let mut builder = Gas::builder();
        for group in MATERIALS {
            let first = group.first_triangle as usize * 3;
            let end = first + group.triangles as usize * 3;
            builder = builder.triangles(Triangles::new(&VERTICES[first..end]).flags(GeometryFlags::OPAQUE));
        }
        let gas = builder.build(ctx)?;
        let ias = Ias::single(ctx, &gas)?;
        let normals = ctx.buffer_from(&triangle_normals())?;
        Ok(Scene { ias, normals })
    }
}

/// The pipeline and SBT of `programs`: one radiance and one shadow hit group per material.
fn link(ctx: &Context, programs: &Programs) -> raykit::Result<(Pipeline<Params>, Sbt)> {
    let Programs { raygen, miss, shadow_miss, hit, shadow_hit, .. } = programs;
    let pipeline = Pipeline::<Params>::new(
        ctx,
        &[raygen, miss, shadow_miss, hit, shadow_hit],
        LinkOptions { max_trace_depth: 1 },
    )?;
    let sbt = finish_sbt(Sbt::builder(&pipeline).raygen(raygen, RaygenRecord::new(&scene::LIGHT)), programs)?;
    Ok((pipeline, sbt))
}

/// The pipeline of [`Programs::raygen_guides`] (with the same miss and hit
/// groups as [`link`]'s), and its SBT, whose raygen record points at `guides`.
fn link_guides(
    ctx: &Context,
    programs: &Programs,
    raygen: &ProgramGroup,
    albedo: &DeviceBuffer<Vec4>,
    normal: &DeviceBuffer<Vec4>,
) -> raykit::Result<(Pipeline<Params>, Sbt)> {
    let Programs { miss, shadow_miss, hit, shadow_hit, .. } = programs;
    let pipeline = Pipeline::<Params>::new(
        ctx,
        &[raygen, miss, shadow_miss, hit, shadow_hit],
        LinkOptions { max_trace_depth: 1 },
    )?;
    let light = &scene::LIGHT;
    let record = GuidesRaygenRecord {
        corner: light.corner,
        v1: light.v1,
        v2: light.v2,
        emission: light.emission,
        albedo: albedo.handle(),
        normal: normal.handle(),
    };
    let sbt = finish_sbt(Sbt::builder(&pipeline).raygen(raygen, record), programs)?;
    Ok((pipeline, sbt))
}

/// The miss and hit records of both pipelines.
fn finish_sbt(sbt: raykit::SbtBuilder<'_, Params>, programs: &Programs) -> raykit::Result<Sbt> {
    let Programs { miss, shadow_miss, hit, shadow_hit, .. } = programs;
    let mut sbt = sbt.miss_for::<Radiance, _>(miss, ()).miss_for::<Shadow, _>(shadow_miss, ());
    for (geometry, group) in MATERIALS.iter().enumerate() {
        let record =
            HitRecord { emission: group.emission, first_triangle: group.first_triangle, albedo: group.albedo, _pad: 0 };
        sbt = sbt.hit_for::<Radiance, _>(geometry, hit, record).hit_for::<Shadow, _>(geometry, shadow_hit, ());
    }
    sbt.build()
}

/// Why [`Renderer::enable_guides`] failed.
#[derive(Debug, thiserror::Error)]
pub enum GuidesError {
    /// The programs have no guide-writing raygen.
    #[error(
        "these programs have no guide-writing raygen (`__raygen__rg_guides`): only the Rust programs          (`Programs::rust`) write the denoiser's albedo and normals; render with them, or denoise without guides"
    )]
    NoGuidesProgram,
    /// Linking or allocating failed.
    #[error(transparent)]
    Raykit(#[from] raykit::Error),
}

/// The guide buffers and the pipeline that writes them.
struct Guides {
    albedo: DeviceBuffer<Vec4>,
    normal: DeviceBuffer<Vec4>,
    pipeline: Pipeline<Params>,
    sbt: Sbt,
    /// The programs linked (for a resize's new SBT).
    programs: Programs,
    /// Their guide-writing raygen.
    raygen: ProgramGroup,
}

impl Guides {
    fn new(ctx: &Context, programs: &Programs, raygen: &ProgramGroup, pixels: usize) -> raykit::Result<Guides> {
        let albedo = ctx.buffer::<Vec4>(pixels)?;
        let normal = ctx.buffer::<Vec4>(pixels)?;
        let (pipeline, sbt) = link_guides(ctx, programs, raygen, &albedo, &normal)?;
        Ok(Guides { albedo, normal, pipeline, sbt, programs: programs.clone(), raygen: raygen.clone() })
    }
}

/// The denoiser's guides of a render: per pixel, the mean over its paths of
/// the first hit's albedo and of its world normal (facing the camera), row 0 at the top.
#[derive(Clone, Debug)]
pub struct GuideImages {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// First-hit albedo (an emitter's colour normalised to 1; 0 for a miss).
    pub albedo: Vec<Vec3>,
    /// First-hit world normal (averaged over the pixel, so shorter than 1 at edges; 0 for a miss).
    pub normal: Vec<Vec3>,
}

/// Mean of an accumulated guide (sum in xyz, paths in w).
fn guide_mean(sums: &[Vec4]) -> Vec<Vec3> {
    sums.iter().map(|s| if s.w > 0.0 { s.truncate() / s.w } else { Vec3::ZERO }).collect()
}

/// A linked path tracer for one image size: pipeline, SBT, accumulation buffer.
pub struct Renderer {
    pipeline: Pipeline<Params>,
    sbt: Sbt,
    accum: DeviceBuffer<Vec4>,
    params: Params,
    /// Paths per pixel accumulated so far.
    samples_done: u32,
    /// Launches so far (the next launch's seed).
    subframe: u32,
    /// The guide-writing pipeline, once [`Renderer::enable_guides`] ran.
    guides: Option<Guides>,
}

impl Renderer {
    /// Links `programs` and lays out the SBT for a `width × height` render of `scene`.
    pub fn new(ctx: &Context, programs: &Programs, scene: &Scene, width: u32, height: u32) -> raykit::Result<Renderer> {
        let (pipeline, sbt) = link(ctx, programs)?;
        let accum = ctx.buffer::<Vec4>(width as usize * height as usize)?;
        let camera = camera_frame(width as f32 / height as f32);
        let params = Params {
            accum: accum.handle(),
            normals: scene.normals.handle(),
            size: UVec2::new(width, height),
            subframe: 0,
            samples: 1,
            max_depth: scene::MAX_DEPTH,
            row_offset: 0,
            cam_eye: camera.eye,
            cam_u: camera.u,
            cam_v: camera.v,
            cam_w: camera.w,
            handle: scene.ias.handle(),
        };
        Ok(Renderer { pipeline, sbt, accum, params, samples_done: 0, subframe: 0, guides: None })
    }

    /// From now on every launch also writes the denoiser's guides (first-hit
    /// albedo and normals, [`Renderer::guides`]) in the same launch, with
    /// `programs`' guide-writing raygen ([`Programs::raygen_guides`]; the Rust
    /// programs). Links that second pipeline; starts sampling over. Without this
    /// call the renderer launches, writes and costs what it always did.
    pub fn enable_guides(&mut self, ctx: &Context, programs: &Programs) -> Result<(), GuidesError> {
        let pixels = self.params.size.x as usize * self.params.size.y as usize;
        let raygen = programs.raygen_guides.as_ref().ok_or(GuidesError::NoGuidesProgram)?;
        self.guides = Some(Guides::new(ctx, programs, raygen, pixels)?);
        self.reset();
        Ok(())
    }

    fn pixels(&self) -> usize {
        self.params.size.x as usize * self.params.size.y as usize
    }

    /// Whether launches write the guides.
    pub fn has_guides(&self) -> bool {
        self.guides.is_some()
    }

    /// Reads the guides back (`None` unless [`Renderer::enable_guides`] ran).
    pub fn guides(&self) -> raykit::Result<Option<GuideImages>> {
        let Some(guides) = &self.guides else { return Ok(None) };
        let size = self.params.size;
        Ok(Some(GuideImages {
            width: size.x,
            height: size.y,
            albedo: guide_mean(&guides.albedo.read()?),
            normal: guide_mean(&guides.normal.read()?),
        }))
    }

    /// The pipeline and SBT launches use: the guide-writing ones when enabled.
    fn active(&self) -> (&Pipeline<Params>, &Sbt) {
        match &self.guides {
            Some(g) => (&g.pipeline, &g.sbt),
            None => (&self.pipeline, &self.sbt),
        }
    }

    /// Hot reload: links new `programs` (rebuilt from edited device code) and
    /// lays out the SBT again from the same records; keeps the scene and the
    /// accumulation buffer, and starts sampling over. On an error the renderer
    /// keeps its current pipeline. With guides enabled, their pipeline is
    /// relinked too (and the guides turn off if `programs` have no
    /// guide-writing raygen).
    pub fn swap_programs(&mut self, ctx: &Context, programs: &Programs) -> raykit::Result<()> {
        let (pipeline, sbt) = link(ctx, programs)?;
        if self.guides.is_some() {
            // New programs without a guide-writing raygen turn the guides off
            // ([`Renderer::has_guides`] says so).
            self.guides = match &programs.raygen_guides {
                Some(raygen) => Some(Guides::new(ctx, programs, raygen, self.pixels())?),
                None => None,
            };
        }
        self.pipeline = pipeline;
        self.sbt = sbt;
        self.reset();
        Ok(())
    }

    /// Aims `camera` (the default is [`CAMERA`]) at the image's aspect; starts
    /// sampling over.
    pub fn set_camera(&mut self, camera: &Camera) {
        let size = self.params.size;
        let (u, v, w) = camera.uvw(size.x as f32 / size.y as f32);
        (self.params.cam_eye, self.params.cam_u, self.params.cam_v, self.params.cam_w) = (camera.eye, u, v, w);
        self.reset();
    }

    /// A new accumulation buffer for `width × height` pixels, the camera kept
    /// (its frame follows the new aspect); starts sampling over.
    pub fn resize(&mut self, ctx: &Context, width: u32, height: u32, camera: &Camera) -> raykit::Result<()> {
        self.accum = ctx.buffer::<Vec4>(width as usize * height as usize)?;
        self.params.accum = self.accum.handle();
        self.params.size = UVec2::new(width, height);
        if let Some(guides) = &self.guides {
            let pixels = self.pixels();
            self.guides = Some(Guides::new(ctx, &guides.programs, &guides.raygen, pixels)?);
        }
        self.set_camera(camera);
        Ok(())
    }

    /// Submits a launch adding `samples` paths per pixel without waiting for it
    /// (the viewer's frames); the accumulation is complete once it has finished.
    pub fn launch_async(&mut self, samples: u32) -> raykit::Result<raykit::Launch> {
        let params = Params { subframe: self.subframe, samples, ..self.params };
        let size = self.params.size;
        let (pipeline, sbt) = self.active();
        let launch = pipeline.launch_async(sbt, &params, [size.x, size.y, 1])?;
        self.subframe += 1;
        self.samples_done += samples;
        Ok(launch)
    }

    /// Submits a launch adding `samples` paths per pixel to the rows `rows` only,
    /// with the seeds of the current launch of the progressive sequence, without
    /// waiting; the launch that reaches the last row completes that launch (the
    /// next one is the sequence's next). A pass of bands from the top to the bottom
    /// accumulates what one [`Renderer::launch_async`] does, bit for bit.
    pub fn launch_rows_async(&mut self, samples: u32, rows: Range<u32>) -> raykit::Result<raykit::Launch> {
        let size = self.params.size;
        let rows = rows.start.min(size.y)..rows.end.min(size.y);
        let params = Params { subframe: self.subframe, samples, row_offset: rows.start, ..self.params };
        let (pipeline, sbt) = self.active();
        let launch = pipeline.launch_async(sbt, &params, [size.x, rows.len().max(1) as u32, 1])?;
        if rows.end == size.y {
            self.subframe += 1;
            self.samples_done += samples;
        }
        Ok(launch)
    }

    /// The accumulation buffer (per pixel: radiance sum in xyz, rays in w).
    pub fn accumulation_buffer(&self) -> &DeviceBuffer<Vec4> {
        &self.accum
    }

    /// Sets the safety cap on path length (bounces; the default is
    /// [`scene::MAX_DEPTH`], past which Russian roulette almost surely ended the
    /// path). A small cap biases the picture dark. Starts sampling over.
    pub fn set_max_depth(&mut self, max_depth: u32) {
        self.params.max_depth = max_depth.max(1);
        self.reset();
    }

    /// Image size.
    pub fn size(&self) -> UVec2 {
        self.params.size
    }

    /// Paths per pixel accumulated so far.
    pub fn samples_done(&self) -> u32 {
        self.samples_done
    }

    /// Starts over: the next launch overwrites the accumulation buffer and uses
    /// the first seed again.
    pub fn reset(&mut self) {
        self.samples_done = 0;
        self.subframe = 0;
    }

    /// One launch adding `samples` paths per pixel; waits for it.
    pub fn launch(&mut self, samples: u32) -> raykit::Result<()> {
        let params = Params { subframe: self.subframe, samples, ..self.params };
        let size = self.params.size;
        let (pipeline, sbt) = self.active();
        pipeline.launch(sbt, &params, [size.x, size.y, 1])?;
        self.subframe += 1;
        self.samples_done += samples;
        Ok(())
    }

    /// One launch adding `samples` paths per pixel to the rows of `band` only,
    /// as launch `subframe` of the progressive sequence (0 overwrites those rows
    /// of the accumulation buffer); waits for it. Leaves the renderer's own
    /// counters alone: for split launches ([`GroupRenderer`]), which keep them.
    pub fn launch_band(&self, subframe: u32, samples: u32, band: &Band) -> raykit::Result<()> {
        let params = Params { subframe, samples, row_offset: band.first_row(), ..self.params };
        let (pipeline, sbt) = self.active();
        pipeline.launch(sbt, &params, band.launch_dims(self.params.size.x, 1))
    }

    /// [`Renderer::launch`] timed by GPU timestamps around the trace.
    pub fn launch_timed(&mut self, samples: u32, timer: &raykit::LaunchTimer) -> raykit::Result<std::time::Duration> {
        let params = Params { subframe: self.subframe, samples, ..self.params };
        let size = self.params.size;
        let (pipeline, sbt) = self.active();
        let time = pipeline.launch_timed(sbt, &params, [size.x, size.y, 1], timer)?;
        self.subframe += 1;
        self.samples_done += samples;
        Ok(time)
    }

    /// The launch params of the next launch of `samples` paths (for code that
    /// launches the same pipeline by other means, such as the benchmarks).
    pub fn next_params(&self, samples: u32) -> Params {
        Params { subframe: self.subframe, samples, ..self.params }
    }

    /// The pipeline.
    pub fn pipeline(&self) -> &Pipeline<Params> {
        &self.pipeline
    }

    /// The SBT.
    pub fn sbt(&self) -> &Sbt {
        &self.sbt
    }

    /// Reads the accumulation buffer back: mean radiance per pixel and the rays
    /// traced so far.
    pub fn image(&self) -> raykit::Result<Image> {
        Ok(Image::from_accumulation(self.params.size, &self.accum.read()?, self.samples_done))
    }

    /// The accumulation buffer as it stands: per pixel, the sum of the radiance
    /// samples (xyz) and the rays traced (w).
    pub fn accumulation(&self) -> raykit::Result<Vec<Vec4>> {
        self.accum.read()
    }

    /// Rays traced so far (reads the accumulation buffer back).
    pub fn rays(&self) -> raykit::Result<u64> {
        Ok(self.accum.read()?.iter().map(|a| a.w as f64).sum::<f64>() as u64)
    }
}

/// A [`Renderer`]'s rows are those of its accumulation buffer: what a split
/// launch gathers, and moves between devices when the bands change.
impl BandRows for Renderer {
    type Item = Vec4;

    fn row_len(&self) -> usize {
        self.params.size.x as usize
    }

    fn read_rows(&self, rows: Range<u32>, out: &mut [Vec4]) -> raykit::Result<()> {
        self.accum.read_into(rows.start as usize * self.row_len(), out)
    }

    fn write_rows(&mut self, rows: Range<u32>, data: &[Vec4]) -> raykit::Result<()> {
        let first = rows.start as usize * self.row_len();
        self.accum.write_at(first, data)
    }
}

/// One device's part of a [`GroupRenderer`]: its copy of the scene and its
/// renderer (pipeline, SBT, accumulation buffer).
pub struct DevicePart {
    /// The device's renderer.
    pub renderer: Renderer,
    /// The scene on the device (the renderer's params point into it).
    pub scene: Scene,
}

impl BandRows for DevicePart {
    type Item = Vec4;

    fn row_len(&self) -> usize {
        self.renderer.row_len()
    }

    fn read_rows(&self, rows: Range<u32>, out: &mut [Vec4]) -> raykit::Result<()> {
        self.renderer.read_rows(rows, out)
    }

    fn write_rows(&mut self, rows: Range<u32>, data: &[Vec4]) -> raykit::Result<()> {
        self.renderer.write_rows(rows, data)
    }
}

/// The path tracer on several devices: each device renders a band of rows of
/// every launch with its own scene, pipeline and accumulation buffer; the bands
/// follow the devices' measured speeds and are gathered into one image. The
/// picture is the one a single [`Renderer`] makes, bit for bit on devices that
/// compute alike (rows that change device carry their accumulated sums along;
/// see `raykit::device_group`).
pub struct GroupRenderer {
    split: Split<DevicePart>,
    size: UVec2,
    samples_done: u32,
    subframe: u32,
}

impl GroupRenderer {
    /// Builds the scene, the programs (`programs`, called once per device, e.g.
    /// [`Programs::rust`]) and a renderer on every device of `group`, in parallel,
    /// for a `width × height` render.
    pub fn new(
        group: &DeviceGroup,
        width: u32,
        height: u32,
        programs: impl Fn(&Context) -> raykit::Result<Programs> + Sync,
    ) -> raykit::Result<GroupRenderer> {
        let split = group.split(height, |ctx| {
            let scene = Scene::new(ctx)?;
            let renderer = Renderer::new(ctx, &programs(ctx)?, &scene, width, height)?;
            Ok(DevicePart { renderer, scene })
        })?;
        Ok(GroupRenderer { split, size: UVec2::new(width, height), samples_done: 0, subframe: 0 })
    }

    /// One split launch adding `samples` paths per pixel; waits for every device.
    pub fn launch(&mut self, samples: u32) -> raykit::Result<()> {
        if self.subframe == 0 {
            // This launch overwrites: nothing accumulated is to be carried over.
            self.split.forget_rows();
        }
        let subframe = self.subframe;
        self.split.launch(|part, band| part.renderer.launch_band(subframe, samples, band))?;
        self.subframe += 1;
        self.samples_done += samples;
        Ok(())
    }

    /// Sets the cap on path length on every device (see
    /// [`Renderer::set_max_depth`]). Starts sampling over.
    pub fn set_max_depth(&mut self, max_depth: u32) {
        for part in self.split.states_mut() {
            part.renderer.set_max_depth(max_depth);
        }
        self.reset();
    }

    /// Starts over; the devices' measured speeds stay.
    pub fn reset(&mut self) {
        self.samples_done = 0;
        self.subframe = 0;
    }

    /// Image size.
    pub fn size(&self) -> UVec2 {
        self.size
    }

    /// Paths per pixel accumulated so far.
    pub fn samples_done(&self) -> u32 {
        self.samples_done
    }

    /// The split: bands, timings, balance, the devices' renderers.
    pub fn split(&self) -> &Split<DevicePart> {
        &self.split
    }

    /// The split, to change its balance.
    pub fn split_mut(&mut self) -> &mut Split<DevicePart> {
        &mut self.split
    }

    /// Gathers the accumulation buffers' rows from the devices that rendered them.
    pub fn accumulation(&self) -> raykit::Result<Vec<Vec4>> {
        self.split.gather_vec()
    }

    /// Gathers the image: mean radiance per pixel and the rays traced so far.
    pub fn image(&self) -> raykit::Result<Image> {
        Ok(Image::from_accumulation(self.size, &self.accumulation()?, self.samples_done))
    }
}

/// The contexts `spec` names, for a [`GroupRenderer`]: `all` is one per
/// ray-tracing device (`Context::all`); a count `N` is N contexts over those
/// devices in turn (on a machine with one device, N contexts share it: the split
/// at work where there is one device, for tests and demonstrations). On the CPU
/// backend (`options.backend`), `all` is one context and `N` is N.
pub fn device_contexts(spec: &str, options: raykit::ContextOptions) -> anyhow::Result<Vec<Context>> {
    let count = match spec {
        "all" => None,
        n => match n.parse::<usize>() {
            Ok(n) if n > 0 => Some(n),
            _ => anyhow::bail!("devices: `all` or a count of at least 1, got {n:?}"),
        },
    };
    let all = Context::all(options.clone())?;
    let Some(n) = count else { return Ok(all) };
    let mut contexts = Vec::with_capacity(n);
    for i in 0..n {
        let device = &all[i % all.len()];
        if i < all.len() {
            contexts.push(device.clone());
            continue;
        }
        if device.backend() == raykit::Backend::Cpu {
            contexts.push(Context::new(options.clone())?);
            continue;
        }
        // Another context on device `i % len`: found by its name and its rank
        // among the devices of that name.
        let name = device.device_name().into_owned();
        let rank = all[..i % all.len()].iter().filter(|c| c.device_name() == name).count();
        contexts.push(Context::new(raykit::ContextOptions {
            device_name_contains: Some(name),
            device_index: Some(rank),
            ..options.clone()
        })?);
    }
    Ok(contexts)
}

/// A rendered image: mean linear radiance per pixel, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Mean radiance per pixel, row-major.
    pub radiance: Vec<Vec3>,
    /// Rays traced (radiance and shadow rays) for all samples so far.
    pub rays: u64,
}

impl Image {
    /// The image of an accumulation buffer (per pixel: radiance sum, rays) after
    /// `samples` paths per pixel.
    pub fn from_accumulation(size: UVec2, accum: &[Vec4], samples: u32) -> Image {
        let n = samples.max(1) as f32;
        let radiance = accum.iter().map(|a| a.truncate() / n).collect();
        let rays = accum.iter().map(|a| a.w as f64).sum::<f64>() as u64;
        Image { width: size.x, height: size.y, radiance, rays }
    }

    /// Tonemapped RGBA8 pixels (exposure, Reinhard, sRGB).
    pub fn tonemapped(&self, exposure: f32) -> Vec<u32> {
        self.radiance.iter().map(|&c| tonemap(c, exposure)).collect()
    }

    /// Writes the tonemapped image as PNG.
    pub fn write_png(&self, path: &Path, exposure: f32) -> anyhow::Result<()> {
        Ok(raykit_scene::write_png_rgba8(path, self.width, self.height, &self.tonemapped(exposure))?)
    }

    /// Writes the linear radiance as a PFM file.
    pub fn write_pfm(&self, path: &Path) -> anyhow::Result<()> {
        Ok(raykit_scene::write_pfm(path, self.width, self.height, &self.radiance)?)
    }

    /// This image denoised by `denoiser` (OIDN's RT filter), guided by
    /// `guides` (the same render's first-hit albedo and normals,
    /// [`Renderer::guides`]) when given. The rays count is kept.
    pub fn denoised(
        &self,
        denoiser: &raykit_denoise::Denoiser,
        guides: Option<&GuideImages>,
    ) -> Result<Image, raykit_denoise::Error> {
        let rgb = |v: &[Vec3]| v.iter().map(|c| c.to_array()).collect::<Vec<_>>();
        let color = rgb(&self.radiance);
        let albedo = guides.map(|g| rgb(&g.albedo));
        let normal = guides.map(|g| rgb(&g.normal));
        let mut input = raykit_denoise::Input::new(self.width, self.height, &color);
        if let (Some(albedo), Some(normal)) = (&albedo, &normal) {
            input = input.with_guides(albedo, normal);
        }
        let out = denoiser.denoise(&input)?;
        Ok(Image { radiance: out.into_iter().map(Vec3::from_array).collect(), ..self.clone() })
    }

    /// Writes the linear radiance as an OpenEXR file (32-bit float RGB).
    pub fn write_exr(&self, path: &Path) -> anyhow::Result<()> {
        Ok(raykit_scene::write_exr(path, self.width, self.height, &self.radiance)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposures_that_make_no_picture_are_refused() {
        for value in ["nan", "inf", "-inf", "0", "-1", "1e39", "bright", ""] {
            let err = parse_exposure(value).expect_err(value).to_string();
            assert!(err.contains("--exposure") && err.contains("finite number above 0"), "{value}: {err}");
        }
        assert_eq!(parse_exposure("1"), Ok(1.0));
        assert_eq!(parse_exposure("0.25"), Ok(0.25));
    }
}
